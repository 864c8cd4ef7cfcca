//! What a row of the list of drives says: name, link, CiA 402 state, fault, position,
//! motion, and the project check; in lower case, unlike the state tile's headline, so the
//! list never repeats the tile's words.
//!
//! A model: no egui here.

use std::time::SystemTime;

use crate::cia::PowerState;
use crate::signal::AT_REST_RPM;
use crate::ui::drive::{Connection, Drive};
use crate::ui::glance::model::{Tone, doing};
use crate::ui::plots::model::PositionUnit;

/// What a row of the list shows: name, link, CiA 402 state, fault, position, motion.
#[derive(Clone, Debug, PartialEq)]
pub struct DriveRow {
    pub name: String,
    /// The colour index the drive was given when it was added (its lines' colour when
    /// several drives share the plots).
    pub color: usize,
    /// The connection string, and how the link stands when it is not up.
    pub link: String,
    /// The CiA 402 state (from 6041h, or PDI-Status), or NO LINK while not live.
    pub state: String,
    pub tone: Tone,
    /// The fault active, with its code and meaning.
    pub fault: Option<String>,
    pub position: Option<String>,
    /// The position and the velocity as numbers, for sorting.
    pub position_value: Option<f64>,
    pub velocity: Option<f64>,
    /// Drawn in the plots beside the drive shown.
    pub in_plots: bool,
    /// "moving +300 rpm", "still", or nothing known.
    pub motion: String,
    pub connected: bool,
    /// The drive is not the device its project saw, or did not answer the check (`true`:
    /// an alarm), or the project has no identity for it yet (`false`: a caution).
    pub check: Option<(String, bool)>,
}

impl DriveRow {
    /// The row of `drive` at `now`, positions in `unit`.
    pub fn of(drive: &Drive, unit: PositionUnit, now: SystemTime) -> DriveRow {
        let link = match &drive.link.connection {
            Connection::Connected(info) => info.spec.to_string(),
            Connection::Connecting(spec) => format!("{spec} (connecting)"),
            Connection::Failed {
                spec,
                retry_in: Some(_),
                ..
            } => format!("{spec} (link lost, retrying)"),
            Connection::Failed { spec, .. } => format!("{spec} (failed)"),
            Connection::Disconnected => {
                match (&drive.link.lost, drive.settings.connection.spec()) {
                    (Some(_), _) => "link lost".to_owned(),
                    (None, Ok(spec)) => format!("{spec} (not connected)"),
                    (None, Err(_)) => "not connected".to_owned(),
                }
            }
        };
        let live = drive.is_live(now);
        let sample = drive.latest();
        let power = sample
            .and_then(|s| s.statusword())
            .and_then(PowerState::from_statusword);
        let (headline, tone, fault) = match &sample {
            Some(s) => doing(s),
            None => (String::new(), Tone::Alarm, false),
        };
        let words = match (power, &sample) {
            (Some(power), _) => power.name().to_owned(),
            (None, Some(_)) => headline.to_lowercase(),
            (None, None) => "unknown".to_owned(),
        };
        // Lower case, unlike the state tile's headline: the list never repeats the
        // tile's words.
        let (state_text, tone) = if live {
            (words, tone)
        } else {
            let word = match &drive.link.connection {
                Connection::Connected(_) if !drive.link.sampled_since_connect => "waiting for data",
                Connection::Connected(_) => "no data",
                Connection::Connecting(_) if sample.is_none() => "connecting",
                _ => "no link",
            };
            (word.to_owned(), Tone::Alarm)
        };
        let decimals = match unit {
            PositionUnit::Tenths => 0,
            PositionUnit::Degrees => 1,
            PositionUnit::Revolutions => 3,
        };
        let position = sample
            .and_then(|s| s.position())
            .map(|p| format!("{:.*} {}", decimals, p * unit.scale(), unit.unit()));
        let motion = match sample.and_then(|s| s.velocity()) {
            Some(v) if v.abs() >= AT_REST_RPM => format!("moving {v:+.0} rpm"),
            Some(_) => "still".to_owned(),
            None => "speed unknown".to_owned(),
        };
        DriveRow {
            // A name pasted huge (or from a hand-edited settings file) is shortened for the
            // list, as a project's would be refused.
            name: crate::text::shortened(&drive.name, crate::project::MAX_NAME).into_owned(),
            color: drive.color,
            link,
            state: state_text,
            tone,
            fault: (fault && live).then(|| fault_words(sample)),
            position,
            position_value: sample.and_then(|s| s.position()).map(|p| p * unit.scale()),
            velocity: sample.and_then(|s| s.velocity()),
            in_plots: drive.in_plots,
            motion,
            connected: drive.is_connected(),
            check: drive.project_warning(),
        }
    }

    /// The row's second line: link, position, motion.
    pub fn details(&self) -> String {
        let mut parts = vec![self.link.clone()];
        parts.extend(self.position.clone());
        parts.push(self.motion.clone());
        parts.join(" · ")
    }
}

/// The fault in a few words: "fault 2300h output current too large".
fn fault_words(sample: Option<crate::worker::Sample>) -> String {
    let code = crate::cia::ErrorCode(sample.map_or(0, |s| s.tx.error_code));
    if code.0 == 0 {
        "fault".to_owned()
    } else {
        format!("fault {:04X}h {}", code.0, code.meaning())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_huge_name_is_shortened_in_the_list() {
        let drive = Drive::new(
            "A".repeat(10 * 1024 * 1024),
            0,
            Default::default(),
            crate::telemetry::DEFAULT_HISTORY_ROWS,
            &[],
        );
        let row = DriveRow::of(&drive, PositionUnit::default(), SystemTime::now());
        assert_eq!(row.name, format!("{}… (10485760 chars)", "A".repeat(64)));
    }
}
