//! The signals a link can deliver besides the PDI image, in one table: which object each
//! is, its type, unit and name. The links fill [`Signals`] from what their exchange
//! carries, the worker reads what is missing and stamps a [`Sample`], and the telemetry,
//! the window and the command line show them — all by this table.

use std::fmt;

use crate::od::{Address, DataType};
use crate::pdi::TxImage;

/// One plot and status signal of the drive.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Signal {
    Position,
    Velocity,
    Torque,
    FollowingError,
    Statusword,
    DigitalInputs,
    AnalogInput,
    Mode,
}

/// What the table says of a signal.
struct Row {
    signal: Signal,
    address: Address,
    dtype: DataType,
    id: &'static str,
    name: &'static str,
    unit: &'static str,
}

/// The table. Units are the factory-default user units (CiA 402 position in 0.1°,
/// velocity in rpm, torque in ‰ of the rated torque).
const TABLE: [Row; 8] = [
    Row {
        signal: Signal::Position,
        address: Address::new(0x6064, 0),
        dtype: DataType::Integer32,
        id: "position",
        name: "Position 6064h",
        unit: "0.1°",
    },
    Row {
        signal: Signal::Velocity,
        address: Address::new(0x606C, 0),
        dtype: DataType::Integer32,
        id: "velocity",
        name: "Velocity 606Ch",
        unit: "rpm",
    },
    Row {
        signal: Signal::Torque,
        address: Address::new(0x6077, 0),
        dtype: DataType::Integer16,
        id: "torque",
        name: "Torque 6077h",
        unit: "‰",
    },
    Row {
        signal: Signal::FollowingError,
        address: Address::new(0x60F4, 0),
        dtype: DataType::Integer32,
        id: "following_error",
        name: "Following error 60F4h",
        unit: "0.1°",
    },
    Row {
        signal: Signal::Statusword,
        address: Address::new(0x6041, 0),
        dtype: DataType::Unsigned16,
        id: "statusword",
        name: "Statusword 6041h",
        unit: "",
    },
    Row {
        signal: Signal::DigitalInputs,
        address: Address::new(0x60FD, 0),
        dtype: DataType::Unsigned32,
        id: "digital_inputs",
        name: "Digital inputs 60FDh",
        unit: "",
    },
    Row {
        signal: Signal::AnalogInput,
        address: Address::new(0x3220, 1),
        dtype: DataType::Integer16,
        id: "analog_input",
        name: "Analog input 3220h:01",
        unit: "",
    },
    Row {
        signal: Signal::Mode,
        address: Address::new(0x6061, 0),
        dtype: DataType::Integer8,
        id: "mode",
        name: "Modes of operation display 6061h",
        unit: "",
    },
];

impl Signal {
    /// Every signal, in the table's order.
    pub const ALL: [Signal; 8] = [
        Signal::Position,
        Signal::Velocity,
        Signal::Torque,
        Signal::FollowingError,
        Signal::Statusword,
        Signal::DigitalInputs,
        Signal::AnalogInput,
        Signal::Mode,
    ];

    fn index(self) -> usize {
        self as usize
    }

    fn row(self) -> &'static Row {
        &TABLE[self.index()]
    }

    /// The object it is.
    pub fn address(self) -> Address {
        self.row().address
    }

    /// The object's type.
    pub fn dtype(self) -> DataType {
        self.row().dtype
    }

    /// The short name on the command line and in exported files.
    pub fn id(self) -> &'static str {
        self.row().id
    }

    /// The name with its object, for legends and headers.
    pub fn name(self) -> &'static str {
        self.row().name
    }

    /// The unit in the factory-default user units ("" for words and raw values).
    pub fn unit(self) -> &'static str {
        self.row().unit
    }

    /// The signal an object is, if it is one.
    pub fn of_address(address: Address) -> Option<Signal> {
        TABLE
            .iter()
            .find(|row| row.address == address)
            .map(|row| row.signal)
    }

    /// A raw value of `bits` bits (from a process image) as this signal's number, signed
    /// or not by its type.
    pub fn from_raw(self, raw: u32, bits: u8) -> f64 {
        if !self.dtype().is_signed() {
            return f64::from(raw);
        }
        match bits {
            8 => f64::from(raw as u8 as i8),
            16 => f64::from(raw as u16 as i16),
            _ => f64::from(raw as i32),
        }
    }
}

impl fmt::Display for Signal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The signals one exchange (or cycle) brought, each `None` when it did not come.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Signals {
    values: [Option<f64>; 8],
}

impl Signals {
    pub fn get(&self, signal: Signal) -> Option<f64> {
        self.values[signal.index()]
    }

    pub fn set(&mut self, signal: Signal, value: f64) {
        self.values[signal.index()] = Some(value);
    }

    /// These signals with `signal` set.
    pub fn with(mut self, signal: Signal, value: f64) -> Signals {
        self.set(signal, value);
        self
    }

    /// Whether `signal` came.
    pub fn has(&self, signal: Signal) -> bool {
        self.get(signal).is_some()
    }

    /// These with the gaps filled from older ones.
    pub fn merged_over(&self, older: &Signals) -> Signals {
        Signals {
            values: std::array::from_fn(|i| self.values[i].or(older.values[i])),
        }
    }

    /// 6064h, 0.1°
    pub fn position(&self) -> Option<f64> {
        self.get(Signal::Position)
    }

    /// 606Ch, rpm
    pub fn velocity(&self) -> Option<f64> {
        self.get(Signal::Velocity)
    }

    /// Whether the motor stands still (606Ch under [`AT_REST_RPM`]); `None` while 606Ch
    /// is unknown.
    pub fn at_rest(&self) -> Option<bool> {
        self.velocity().map(|v| v.abs() < AT_REST_RPM)
    }

    /// 6077h, ‰ of rated torque
    pub fn torque(&self) -> Option<f64> {
        self.get(Signal::Torque)
    }

    /// 60F4h, 0.1°
    pub fn following_error(&self) -> Option<f64> {
        self.get(Signal::FollowingError)
    }

    /// 3220h:01, raw
    pub fn analog_input(&self) -> Option<f64> {
        self.get(Signal::AnalogInput)
    }

    /// 6041h
    pub fn statusword(&self) -> Option<u16> {
        self.get(Signal::Statusword).map(|v| v as u16)
    }

    /// 60FDh
    pub fn digital_inputs(&self) -> Option<u32> {
        self.get(Signal::DigitalInputs).map(|v| v as u32)
    }

    /// 6061h
    pub fn mode(&self) -> Option<i8> {
        self.get(Signal::Mode).map(|v| v as i8)
    }

    /// The signals that came, with their values.
    pub fn iter(&self) -> impl Iterator<Item = (Signal, f64)> + '_ {
        Signal::ALL
            .into_iter()
            .filter_map(|s| self.get(s).map(|v| (s, v)))
    }
}

/// Objects a watch list may name besides the signals (sampled every cycle with them).
pub const MAX_WATCHED: usize = 8;

/// Below this speed (rpm) the motor counts as standing still: the window's state tile,
/// the disconnect question and the command line's reports all draw the line here.
pub const AT_REST_RPM: f64 = 0.5;

/// One sample of the drive, taken at the worker.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sample {
    /// Seconds on the worker's clock (from its first connection, going on across
    /// reconnects), when the worker received the image.
    pub t: f64,
    pub tx: TxImage,
    /// The signals measured in this cycle.
    pub signals: Signals,
    /// The watched objects, in the order asked, where read this cycle.
    pub watched: [Option<f64>; MAX_WATCHED],
}

/// A sample reads like its signals: `sample.position()`, `sample.get(Signal::Torque)`.
impl std::ops::Deref for Sample {
    type Target = Signals;

    fn deref(&self) -> &Signals {
        &self.signals
    }
}

impl Sample {
    /// This sample with the gaps filled from an older one: the newest known value of every
    /// signal (a link may bring some signals only every few cycles). Time and PDI image are
    /// this sample's.
    pub fn merged_over(&self, older: &Sample) -> Sample {
        Sample {
            t: self.t,
            tx: self.tx,
            signals: self.signals.merged_over(&older.signals),
            watched: std::array::from_fn(|i| self.watched[i].or(older.watched[i])),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_is_in_the_order_of_the_enum_and_addresses_are_unique() {
        for (i, signal) in Signal::ALL.into_iter().enumerate() {
            assert_eq!(TABLE[i].signal, signal);
            assert_eq!(Signal::of_address(signal.address()), Some(signal));
        }
        assert_eq!(Signal::of_address(Address::new(0x6064, 1)), None);
    }

    #[test]
    fn raw_values_take_the_sign_of_the_type() {
        assert_eq!(Signal::Torque.from_raw(0xFFFF, 16), -1.0);
        assert_eq!(Signal::Statusword.from_raw(0xFFFF, 16), 65535.0);
        assert_eq!(Signal::Mode.from_raw(0xFF, 8), -1.0);
        assert_eq!(Signal::Position.from_raw(0xFFFF_FFFE, 32), -2.0);
        assert_eq!(
            Signal::DigitalInputs.from_raw(0x8000_0000, 32),
            2_147_483_648.0
        );
    }

    #[test]
    fn a_merge_keeps_the_newest_of_each() {
        let older = Signals::default()
            .with(Signal::Position, 1.0)
            .with(Signal::Velocity, 2.0);
        let newer = Signals::default().with(Signal::Position, 5.0);
        let merged = newer.merged_over(&older);
        assert_eq!(merged.get(Signal::Position), Some(5.0));
        assert_eq!(merged.get(Signal::Velocity), Some(2.0));
        assert_eq!(merged.get(Signal::Torque), None);
        assert_eq!(merged.iter().count(), 2);
    }
}
