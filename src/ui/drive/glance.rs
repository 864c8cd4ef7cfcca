//! The state tile's words for a drive: what it is and does, or that it is not live and
//! when it was last seen; and why Enable cannot be pressed now.
//!
//! A model: no egui here.

use std::time::SystemTime;

use super::Drive;
use super::link::{Connection, age_text};
use crate::ui::glance::model::{Glance, Tone, doing, power_words};

impl Drive {
    /// The tile's words at `now`.
    pub fn glance(&self, now: SystemTime) -> Glance {
        let latest = self.link.latest;
        let last_known = latest
            .map(|s| format!("last known: {}", doing(&s).0))
            .unwrap_or_else(|| "no state known yet".to_owned());
        if !self.is_live(now) {
            let age = self.link.sample_age(now).map(age_text);
            let seen = match &age {
                Some(age) => format!("last seen {age}"),
                None => "never seen".to_owned(),
            };
            let headline = match &self.link.connection {
                Connection::Connected(_) if !self.link.sampled_since_connect => {
                    "WAITING FOR DATA".to_owned()
                }
                Connection::Connected(_) => format!("NO DATA ({seen})"),
                Connection::Connecting(_) if latest.is_none() => "CONNECTING…".to_owned(),
                // Disconnected on purpose: nothing is wrong, so no alarm.
                Connection::Disconnected if self.link.lost.is_none() && latest.is_some() => {
                    return Glance {
                        headline: "DISCONNECTED".to_owned(),
                        tone: Tone::Off,
                        detail: format!("{last_known} ({seen})"),
                        fault: false,
                    };
                }
                _ => format!("NO LINK ({seen})"),
            };
            return Glance {
                headline,
                tone: Tone::Alarm,
                detail: last_known,
                fault: false,
            };
        }
        let Some(sample) = latest else {
            return Glance {
                headline: "WAITING FOR DATA".to_owned(),
                tone: Tone::Alarm,
                detail: last_known,
                fault: false,
            };
        };
        let (headline, tone, fault) = doing(&sample);
        Glance {
            headline,
            tone,
            detail: power_words(&sample),
            fault,
        }
    }

    /// Why Enable cannot be pressed now; `None` when it can.
    pub fn enable_blocker(&self, now: SystemTime) -> Option<String> {
        if let Some(offline) = self.offline_reason() {
            return Some(offline);
        }
        if self.link_info().is_some_and(|i| !i.pdi) {
            return Some("this device has no Plug & Drive interface".to_owned());
        }
        if !self.is_live(now) {
            return Some("the drive's state is not known now".to_owned());
        }
        let sample = self.link.latest?;
        match doing(&sample) {
            (_, _, true) => Some("a fault is active: Clear error first".to_owned()),
            (headline, Tone::Go, _) => Some(format!("already enabled ({headline})")),
            _ => None,
        }
    }
}
