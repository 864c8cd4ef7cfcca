//! Is each drive still the device the project saw? The identity the project stores
//! (1018h:01 to 04: vendor, product code, revision, serial number, as last seen) against
//! what the drive reports now, one verdict per drive: never a drive left out, never a
//! difference passed over. The reading is the caller's (the command line's or the
//! window's worker); this is the comparison and its words.

use std::fmt;

use super::{Drive, Project};
use crate::od::backup::DeviceIdentity;

/// One field of 1018h that differs.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Change {
    /// "vendor id", "product code", "revision number", "serial number".
    pub what: &'static str,
    pub was: u32,
    /// `None`: the drive did not give it now.
    pub now: Option<u32>,
}

impl fmt::Display for Change {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.now {
            Some(now) => write!(f, "{} changed 0x{:08X} -> 0x{now:08X}", self.what, self.was),
            None => write!(f, "{} 0x{:08X} could not be read now", self.what, self.was),
        }
    }
}

/// What a drive's check found.
#[derive(Clone, Debug, PartialEq)]
pub enum Verdict {
    /// Every field the project stored is the same.
    Same,
    /// These fields differ (in 1018h's order).
    Changed(Vec<Change>),
    /// The drive did not answer: the reason (a timeout, a refused connection…).
    NoAnswer(String),
    /// The project has no identity for this drive yet: what it reports now.
    NotRecorded(DeviceIdentity),
}

/// One drive's check.
#[derive(Clone, Debug, PartialEq)]
pub struct DriveCheck {
    pub name: String,
    pub verdict: Verdict,
}

impl DriveCheck {
    /// Whether the drive is the one the project saw.
    pub fn is_same(&self) -> bool {
        self.verdict == Verdict::Same
    }
}

impl fmt::Display for DriveCheck {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: ", self.name)?;
        match &self.verdict {
            Verdict::Same => f.write_str("same device"),
            Verdict::Changed(changes) => {
                let list: Vec<String> = changes.iter().map(Change::to_string).collect();
                f.write_str(&list.join(", "))
            }
            Verdict::NoAnswer(reason) => write!(f, "no answer ({reason})"),
            Verdict::NotRecorded(now) => write!(
                f,
                "no identity stored in the project; it reports {}",
                now.summary()
            ),
        }
    }
}

/// 1018h:01 to 04 of an identity, named.
fn fields(identity: &DeviceIdentity) -> [(&'static str, Option<u32>); 4] {
    [
        ("vendor id", identity.vendor),
        ("product code", identity.product),
        ("revision number", identity.revision),
        ("serial number", identity.serial),
    ]
}

/// Compare `drive`'s stored identity with what it reports now: `Ok(identity)` read from
/// it, or `Err(why)` it did not answer. A field the project did not store is not
/// compared; a stored field the drive no longer gives counts as changed.
pub fn check(drive: &Drive, now: Result<&DeviceIdentity, &str>) -> DriveCheck {
    let verdict = match (now, &drive.identity) {
        (Err(reason), _) => Verdict::NoAnswer(reason.to_owned()),
        (Ok(now), None) => Verdict::NotRecorded(now.clone()),
        (Ok(now), Some(was)) => {
            let changes: Vec<Change> = fields(was)
                .into_iter()
                .zip(fields(now))
                .filter_map(|((what, was), (_, now))| {
                    let was = was?;
                    (now != Some(was)).then_some(Change { what, was, now })
                })
                .collect();
            if changes.is_empty() {
                Verdict::Same
            } else {
                Verdict::Changed(changes)
            }
        }
    };
    DriveCheck {
        name: drive.name.clone(),
        verdict,
    }
}

/// Check every drive of `project`, in its order, with `answer(drive)` giving what the
/// drive reports now.
pub fn check_all<'a>(
    project: &'a Project,
    mut answer: impl FnMut(&'a Drive) -> Result<DeviceIdentity, String>,
) -> Vec<DriveCheck> {
    project
        .drives
        .iter()
        .map(|drive| {
            let now = answer(drive);
            check(drive, now.as_ref().map_err(String::as_str))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::LinkSpec;

    fn identity(serial: u32) -> DeviceIdentity {
        DeviceIdentity {
            vendor: Some(0x26C),
            product: Some(0x1234),
            revision: Some(7),
            serial: Some(serial),
            name: Some("drive".into()),
            ..DeviceIdentity::default()
        }
    }

    fn drive(name: &str, identity: Option<DeviceIdentity>) -> Drive {
        Drive {
            identity,
            ..Drive::new(name, LinkSpec::Sim)
        }
    }

    #[test]
    fn each_verdict_in_words() {
        let x = drive("X axis", Some(identity(1)));
        let mut now = identity(1);
        now.product = Some(0x5678);
        assert_eq!(
            check(&x, Ok(&now)).to_string(),
            "X axis: product code changed 0x00001234 -> 0x00005678"
        );
        let y = drive("Y axis", Some(identity(2)));
        assert_eq!(
            check(&y, Err("timeout after 2 s")).to_string(),
            "Y axis: no answer (timeout after 2 s)"
        );
        let z = drive("Z axis", Some(identity(3)));
        let same = check(&z, Ok(&identity(3)));
        assert!(same.is_same());
        assert_eq!(same.to_string(), "Z axis: same device");
    }

    #[test]
    fn names_change_nothing_and_unread_fields_count_as_changed() {
        let x = drive("X axis", Some(identity(1)));
        let mut now = identity(1);
        now.name = Some("another name".into());
        assert!(check(&x, Ok(&now)).is_same());
        now.serial = None;
        now.revision = Some(8);
        assert_eq!(
            check(&x, Ok(&now)).verdict,
            Verdict::Changed(vec![
                Change {
                    what: "revision number",
                    was: 7,
                    now: Some(8)
                },
                Change {
                    what: "serial number",
                    was: 1,
                    now: None
                },
            ])
        );
    }

    #[test]
    fn a_drive_without_a_stored_identity_says_so() {
        let w = drive("W axis", None);
        let found = check(&w, Ok(&identity(9)));
        assert!(!found.is_same());
        assert!(
            found
                .to_string()
                .starts_with("W axis: no identity stored in the project; it reports drive,"),
            "{found}"
        );
    }

    #[test]
    fn every_drive_gets_a_verdict_in_order() {
        let project = Project::new(vec![
            drive("X axis", Some(identity(1))),
            drive("Y axis", Some(identity(2))),
        ])
        .expect("a project");
        let checks = check_all(&project, |d| {
            if d.name == "X axis" {
                Ok(identity(1))
            } else {
                Err("connection refused".into())
            }
        });
        let lines: Vec<String> = checks.iter().map(ToString::to_string).collect();
        assert_eq!(
            lines,
            [
                "X axis: same device",
                "Y axis: no answer (connection refused)"
            ]
        );
    }
}
