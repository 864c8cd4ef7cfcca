//! A drive of a project: the project's record of it (the identity to compare on
//! connecting, the backup kept when the project is saved again) and what comparing the
//! drive with it found, said once per verdict in its log and on its row of the list.
//!
//! A model: no egui here.

use super::Drive;
use super::link::Connection;
use super::log::{LogEntry, Outcome};
use crate::od::backup::DeviceIdentity;
use crate::project::check::{DriveCheck, Verdict};

/// The project's record of a drive, and the last check against it.
#[derive(Clone, Debug, Default)]
pub struct ProjectRecord {
    /// `None` outside a project.
    pub drive: Option<crate::project::Drive>,
    /// What comparing the drive with the record found, once it did.
    pub check: Option<DriveCheck>,
}

impl Drive {
    /// Compare the drive with the project's record of it, now that its identity was read
    /// (`Ok`) or its connection failed (`Err`). Said once per verdict, in the colour of the
    /// outcome; a failed connection is said only while nothing better is known.
    pub(crate) fn check_against_project(&mut self, now: Result<&DeviceIdentity, &str>) {
        let Some(saved) = &self.project.drive else {
            return;
        };
        if now.is_err() && self.project.check.is_some() {
            return;
        }
        let check = crate::project::check::check(saved, now);
        if self.project.check.as_ref() == Some(&check) {
            return;
        }
        let outcome = match &check.verdict {
            Verdict::Same => Outcome::Succeeded("the device the project saw".into()),
            Verdict::Changed(_) => Outcome::Failed(format!(
                "not the device the project saw: {}",
                verdict_text(&check)
            )),
            Verdict::NoAnswer(_) => Outcome::Failed(verdict_text(&check)),
            Verdict::NotRecorded(_) => Outcome::Caution(verdict_text(&check)),
        };
        self.log.push(LogEntry {
            at: self.clock,
            id: None,
            what: format!("project check of \"{}\"", check.name),
            image: None,
            outcome,
        });
        self.project.check = Some(check);
    }

    /// What the list's row says of the project check, and whether it is an alarm (red)
    /// or a caution (amber): nothing while the drive is the one the project saw (or not
    /// yet checked, or answering now after a failed first try).
    pub fn project_warning(&self) -> Option<(String, bool)> {
        let check = self.project.check.as_ref()?;
        match &check.verdict {
            Verdict::Same => None,
            Verdict::Changed(_) => Some((
                format!("not the project's device: {}", verdict_text(check)),
                true,
            )),
            Verdict::NoAnswer(_) if matches!(self.link.connection, Connection::Connected(_)) => {
                None
            }
            Verdict::NoAnswer(_) => Some((verdict_text(check), true)),
            Verdict::NotRecorded(_) => Some((
                "identity not in the project yet: Project > Save project keeps it".into(),
                false,
            )),
        }
    }
}

/// A check's words without the drive's name.
fn verdict_text(check: &DriveCheck) -> String {
    let text = check.to_string();
    text.strip_prefix(&format!("{}: ", check.name))
        .map(str::to_owned)
        .unwrap_or(text)
}
