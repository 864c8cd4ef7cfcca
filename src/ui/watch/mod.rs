//! The watch panel: objects pinned from the dictionary, the plots or by address, read
//! again and again at a rate the user picks, each shown as decimal with its unit, as hex,
//! or bit by bit with the names the catalog gives (what the vendor tool calls monitoring
//! modules). The pins, their formats and the rate are part of the saved layout
//! ([`WatchSettings`] in the window's settings); the readings are not.
//!
//! The panel asks the worker for one `ReadMany` of every pin at a time, never a second
//! before the first has come back, so a slow bus lowers the refresh rate instead of
//! queueing reads without end.
//!
//! The model (this file): no egui here; the view is `panel`.

mod panel;

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::od::{Address, Catalog, DataType, Entry, Value};
// The pins are plain data a project stores per drive: they live in `project`.
pub use crate::project::watch::{Format, MAX_PINS, Pin};
use crate::worker::{ObjectError, ObjectPath, Rejection, Request, RequestId};

pub use panel::watch_ui;

/// The refresh rates offered, Hz.
pub const RATES: [f64; 6] = [0.5, 1.0, 2.0, 5.0, 10.0, 20.0];
/// A read that has not come back after this long counts as lost and is asked again.
pub const LOST_AFTER_S: f64 = 5.0;
/// A value that changed is marked for this long.
pub const CHANGED_FOR_S: f64 = 1.0;

/// What of the watch panel is a drive's: its pins, the rate, the address box. (Whether
/// the panel is shown is the window's.)
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct WatchSettings {
    pub pins: Vec<Pin>,
    /// Refreshes per second.
    pub rate: f64,
    /// The address box as typed.
    pub address: String,
}

impl Default for WatchSettings {
    fn default() -> Self {
        Self {
            pins: Vec::new(),
            rate: 2.0,
            address: String::new(),
        }
    }
}

/// The last value of one pinned object.
#[derive(Clone, Debug, PartialEq)]
pub struct Reading {
    /// The value, or why there is none in words (the device's refusal, a lost link).
    pub result: Result<Value, String>,
    /// When it came (the window's clock, s).
    pub at: f64,
    /// When it last differed from the reading before it.
    pub changed_at: Option<f64>,
}

/// The panel's state at run time.
#[derive(Clone, Debug, Default)]
pub struct Watch {
    readings: BTreeMap<Address, Reading>,
    /// A read is asked for and not yet handed to the worker.
    queued: bool,
    /// The read on its way, and how many of its answers are still to come.
    in_flight: Option<(RequestId, usize)>,
    /// When the last read was asked (window clock).
    asked_at: Option<f64>,
    /// Why the last pin or read did not happen.
    pub message: Option<String>,
}

/// Why an object cannot be pinned.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum PinError {
    #[error("'{0}' is not an address (6041, 6041:00 or 1018h:01h)")]
    BadAddress(String),
    #[error("{0} is not in the dictionary shown (load the drive's EDS to watch it)")]
    Unknown(Address),
    #[error("{0} cannot be read (write-only)")]
    WriteOnly(Address),
    #[error("{0} is pinned already")]
    Pinned(Address),
    #[error("at most {MAX_PINS} objects can be watched")]
    Full,
}

impl WatchSettings {
    /// Pin an object the catalog knows; objects with named bits start in the bits format.
    pub fn pin(&mut self, address: Address, catalog: &Catalog) -> Result<(), PinError> {
        let entry = catalog.get(address).ok_or(PinError::Unknown(address))?;
        if !entry.access.readable() {
            return Err(PinError::WriteOnly(address));
        }
        if self.pins.iter().any(|p| p.address == address) {
            return Err(PinError::Pinned(address));
        }
        if self.pins.len() >= MAX_PINS {
            return Err(PinError::Full);
        }
        let format = if entry.bits.is_empty() {
            Format::Decimal
        } else {
            Format::Bits
        };
        self.pins.push(Pin { address, format });
        Ok(())
    }

    /// Pin what the address box says.
    pub fn pin_typed(&mut self, catalog: &Catalog) -> Result<Address, PinError> {
        let typed = self.address.trim().to_owned();
        let address: Address = typed.parse().map_err(|_| PinError::BadAddress(typed))?;
        self.pin(address, catalog)?;
        self.address.clear();
        Ok(address)
    }

    pub fn unpin(&mut self, address: Address) {
        self.pins.retain(|p| p.address != address);
    }

    pub fn is_pinned(&self, address: Address) -> bool {
        self.pins.iter().any(|p| p.address == address)
    }

    /// Seconds between two reads.
    pub fn period(&self) -> f64 {
        1.0 / self.rate.clamp(RATES[0], RATES[RATES.len() - 1])
    }
}

impl Watch {
    /// The read to ask now, if one is due: every pin the catalog knows the type of, once
    /// the last read has come back and a period has passed.
    pub fn due(
        &mut self,
        settings: &WatchSettings,
        catalog: &Catalog,
        clock: f64,
    ) -> Option<Request> {
        if let (Some(_), Some(asked)) = (self.in_flight, self.asked_at)
            && clock - asked > LOST_AFTER_S
        {
            // Its answers were lost with a link or a worker restart: ask again.
            self.in_flight = None;
        }
        if self.queued || self.in_flight.is_some() {
            return None;
        }
        if self
            .asked_at
            .is_some_and(|asked| clock - asked < settings.period() && clock >= asked)
        {
            return None;
        }
        let objects: Vec<(Address, DataType)> = settings
            .pins
            .iter()
            .filter_map(|p| catalog.get(p.address).map(|e| (p.address, e.dtype)))
            .collect();
        if objects.is_empty() {
            return None;
        }
        self.queued = true;
        self.asked_at = Some(clock);
        Some(Request::ReadMany {
            objects,
            path: ObjectPath::Auto,
        })
    }

    /// The worker took the panel's read as `id`.
    pub fn sent(&mut self, id: RequestId, request: &Request) {
        self.queued = false;
        let count = match request {
            Request::ReadMany { objects, .. } => objects.len(),
            _ => 0,
        };
        self.in_flight = Some((id, count));
    }

    /// The panel's read could not be handed to the worker.
    pub fn unsent(&mut self, reason: &str) {
        self.queued = false;
        self.message = Some(format!("not read: {reason}"));
    }

    /// One answer to the panel's read `id` (an older one's too, come late): `true` once
    /// the read `id` has all its answers.
    pub fn on_read(
        &mut self,
        id: RequestId,
        address: Address,
        result: &Result<Value, ObjectError>,
        clock: f64,
    ) -> bool {
        let result = result.clone().map_err(|e| e.to_string());
        let changed_at = match self.readings.get(&address) {
            Some(before) if before.result.as_ref().ok() != result.as_ref().ok() => Some(clock),
            Some(before) => before.changed_at,
            None => None,
        };
        self.readings.insert(
            address,
            Reading {
                result,
                at: clock,
                changed_at,
            },
        );
        self.message = None;
        self.answered(id)
    }

    /// A refusal of the panel's read (not connected, the link lost on the way).
    pub fn on_rejected(&mut self, id: RequestId, rejection: &Rejection) {
        if *rejection == Rejection::NotConnected {
            self.in_flight = None;
        } else {
            self.answered(id);
        }
        self.message = Some(rejection.to_string());
    }

    /// An answer to `id` came: `true` once it was the last of the read on its way.
    fn answered(&mut self, id: RequestId) -> bool {
        if let Some((flying, left)) = self.in_flight.as_mut()
            && *flying == id
        {
            *left = left.saturating_sub(1);
            if *left == 0 {
                self.in_flight = None;
                return true;
            }
        }
        false
    }

    pub fn reading(&self, address: Address) -> Option<&Reading> {
        self.readings.get(&address)
    }

    /// A read is on its way.
    pub fn busy(&self) -> bool {
        self.queued || self.in_flight.is_some()
    }
}

/// A value as `format` shows it: decimal with the unit, or hex as wide as the type.
pub fn format_value(value: &Value, entry: &Entry, format: Format) -> String {
    match format {
        Format::Decimal => match entry.unit.as_deref() {
            Some(unit) if !unit.is_empty() => format!("{value} {unit}"),
            _ => value.to_string(),
        },
        Format::Hex | Format::Bits => match value.to_hex(entry.dtype) {
            hex if hex.is_empty() => value.to_string(),
            hex => hex,
        },
    }
}

/// Every bit the catalog names, and every other bit that is set, with its state.
pub fn bits(value: &Value, entry: &Entry) -> Vec<(u8, String, bool)> {
    let Some(raw) = value.as_i128() else {
        return Vec::new();
    };
    let width = entry.dtype.size().unwrap_or(0).min(8) * 8;
    let mut shown: Vec<(u8, String, bool)> = entry
        .bits
        .iter()
        .map(|(bit, name)| (*bit, name.clone(), raw >> bit & 1 == 1))
        .collect();
    for bit in 0..width as u8 {
        if raw >> bit & 1 == 1 && !entry.bits.iter().any(|(named, _)| *named == bit) {
            shown.push((bit, format!("bit {bit}"), true));
        }
    }
    shown.sort_by_key(|(bit, _, _)| *bit);
    shown
}

#[cfg(test)]
mod tests {
    use super::*;

    fn catalog() -> &'static Catalog {
        crate::od::builtin()
    }

    const STATUSWORD: Address = Address::new(0x6041, 0);
    const POSITION: Address = Address::new(0x6064, 0);

    #[test]
    fn pinning_checks_the_address_and_picks_the_format() {
        let mut settings = WatchSettings {
            address: "6041".into(),
            ..WatchSettings::default()
        };
        assert_eq!(settings.pin_typed(catalog()), Ok(STATUSWORD));
        assert!(settings.address.is_empty());
        assert_eq!(
            settings.pins[0].format,
            Format::Bits,
            "6041h has named bits"
        );
        settings.pin(POSITION, catalog()).expect("6064h");
        assert_eq!(settings.pins[1].format, Format::Decimal);
        assert_eq!(
            settings.pin(POSITION, catalog()),
            Err(PinError::Pinned(POSITION))
        );
        settings.address = "60x1".into();
        assert!(matches!(
            settings.pin_typed(catalog()),
            Err(PinError::BadAddress(_))
        ));
        assert_eq!(
            settings.address, "60x1",
            "what was typed stays to be corrected"
        );
        let unknown = Address::new(0x5FFF, 0x33);
        assert_eq!(
            settings.pin(unknown, catalog()),
            Err(PinError::Unknown(unknown))
        );
        settings.unpin(STATUSWORD);
        assert!(!settings.is_pinned(STATUSWORD) && settings.is_pinned(POSITION));
    }

    #[test]
    fn one_read_at_a_time_at_the_chosen_rate() {
        let mut settings = WatchSettings {
            rate: 2.0,
            ..WatchSettings::default()
        };
        settings.pin(STATUSWORD, catalog()).expect("pin");
        settings.pin(POSITION, catalog()).expect("pin");
        let mut watch = Watch::default();
        let request = watch.due(&settings, catalog(), 10.0).expect("a first read");
        assert!(matches!(&request, Request::ReadMany { objects, .. } if objects.len() == 2));
        assert_eq!(watch.due(&settings, catalog(), 10.1), None, "not yet sent");
        watch.sent(7, &request);
        assert_eq!(
            watch.due(&settings, catalog(), 11.0),
            None,
            "still on its way"
        );
        let ok = Ok(Value::Uint(0x0637));
        assert!(
            !watch.on_read(7, STATUSWORD, &ok, 10.2),
            "one of two answers"
        );
        assert!(watch.busy());
        assert!(watch.on_read(7, POSITION, &Ok(Value::Int(5)), 10.3), "both");
        assert!(!watch.busy());
        assert_eq!(
            watch.due(&settings, catalog(), 10.4),
            None,
            "a period is 0.5 s"
        );
        let next = watch.due(&settings, catalog(), 10.6).expect("due again");
        watch.sent(9, &next);
        watch.on_read(9, POSITION, &Ok(Value::Int(6)), 10.7);
        let reading = watch.reading(POSITION).expect("read");
        assert_eq!(reading.changed_at, Some(10.7), "5 → 6 is marked");
        assert_eq!(watch.reading(STATUSWORD).map(|r| r.changed_at), Some(None));
    }

    #[test]
    fn a_read_lost_with_the_link_is_asked_again() {
        let mut settings = WatchSettings::default();
        settings.pin(POSITION, catalog()).expect("pin");
        let mut watch = Watch::default();
        let request = watch.due(&settings, catalog(), 1.0).expect("read");
        watch.sent(1, &request);
        assert_eq!(watch.due(&settings, catalog(), 5.0), None);
        assert!(
            watch.due(&settings, catalog(), 6.5).is_some(),
            "lost after 5 s"
        );
        let mut watch = Watch::default();
        let request = watch.due(&settings, catalog(), 1.0).expect("read");
        watch.sent(2, &request);
        watch.on_rejected(2, &Rejection::NotConnected);
        assert!(!watch.busy());
        assert_eq!(watch.message.as_deref(), Some("not connected to a drive"));
    }

    #[test]
    fn formats_name_the_bits_and_keep_the_type_width() {
        let statusword = catalog().get(STATUSWORD).expect("6041h");
        let value = Value::Uint(0x1237);
        assert_eq!(format_value(&value, statusword, Format::Hex), "1237h");
        let shown = bits(&value, statusword);
        let set: Vec<&str> = shown
            .iter()
            .filter(|(_, _, on)| *on)
            .map(|(_, name, _)| name.as_str())
            .collect();
        assert_eq!(
            set,
            [
                "ready to switch on",
                "switched on",
                "operation enabled",
                "voltage enabled",
                "quick stop (0 = active)",
                "remote",
                "mode-specific 12"
            ]
        );
        assert!(
            shown
                .iter()
                .any(|(bit, name, on)| *bit == 3 && name == "fault" && !on)
        );
        let position = catalog().get(POSITION).expect("6064h");
        let text = format_value(&Value::Int(-2), position, Format::Decimal);
        assert!(text.starts_with("-2"), "{text}");
        assert_eq!(
            format_value(&Value::Int(-2), position, Format::Hex),
            "FFFFFFFEh"
        );
        // A set bit the catalog does not name is still shown.
        let inputs = catalog().get(Address::new(0x60FD, 0)).expect("60FDh");
        let shown = bits(&Value::Uint(1 << 30 | 1), inputs);
        assert!(shown.contains(&(30, "bit 30".into(), true)), "{shown:?}");
        assert!(shown.contains(&(0, "negative limit switch".into(), true)));
    }
}
