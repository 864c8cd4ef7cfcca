//! Connection strings for every bus, parsed in one place.
//!
//! ```text
//! sim
//! modbus-tcp://HOST:PORT?unit=0
//! modbus-rtu://PATH?baud=19200&parity=even&stop=1&slave=5
//! canopen+socketcan://IFACE?node=1
//! canopen+slcan://PATH?bitrate=1000000&node=1
//! enip://HOST:PORT?io=pdi&rpi=10
//! ```

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

pub use crate::proto::modbus::registers::WordOrder;

/// Every form, for error messages and `--help`.
pub const FORMS: &str = "sim | modbus-tcp://HOST:PORT?unit=0[&words=low] | modbus-rtu://PATH?baud=19200&parity=even&stop=1&slave=5[&words=low] | canopen+socketcan://IFACE?node=1[&pdo=1&keep_pdo=1&self_start=1] | canopen+slcan://PATH?bitrate=1000000&node=1 | canopen+sim://?node=1 | enip://HOST:PORT?io=pdi&rpi=10[&cmd_at=8&config=100&udp=2222]";

mod options;
mod text;

pub use options::{CanopenOptions, EnipIo, EnipOptions, Parity, SerialLine};
pub use text::{
    BAUDS, BadNumber, CAN_BITRATES, NODES, PDOS, PORTS, RPI_MS, SLAVES, STOP_BITS, UNITS, number,
    parse_host,
};
use text::{Param, Query, host_port, host_text};

/// A parsed connection string.
#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(tag = "bus", rename_all = "kebab-case")]
pub enum LinkSpec {
    /// The built-in simulated drive, in-process.
    Sim,
    ModbusTcp {
        host: String,
        port: u16,
        unit: u8,
        /// Which half of 32-bit register pairs comes first (protocol notes §5.12: high, \[M\]).
        #[serde(default)]
        words: WordOrder,
    },
    ModbusRtu {
        path: String,
        baud: u32,
        parity: Parity,
        stop_bits: u8,
        slave: u8,
        #[serde(default)]
        words: WordOrder,
    },
    CanopenSocketcan {
        iface: String,
        #[serde(flatten)]
        can: CanopenOptions,
    },
    CanopenSlcan {
        path: String,
        bitrate: u32,
        #[serde(flatten)]
        can: CanopenOptions,
    },
    /// The built-in simulated drive as a CANopen node on an in-memory CAN bus.
    CanopenSim {
        #[serde(flatten)]
        can: CanopenOptions,
    },
    Enip {
        host: String,
        port: u16,
        #[serde(flatten)]
        enip: EnipOptions,
    },
}

/// A connection string that could not be parsed.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("'{input}' is not a connection string: {reason}.\nForms: {FORMS}")]
pub struct SpecError {
    pub input: String,
    pub reason: String,
}

impl LinkSpec {
    /// The scheme word, e.g. `modbus-tcp`.
    pub fn scheme(&self) -> &'static str {
        self.names().0
    }

    /// The bus in words, for the UI.
    pub fn bus_name(&self) -> &'static str {
        self.names().1
    }

    /// The scheme word and the bus in words.
    fn names(&self) -> (&'static str, &'static str) {
        match self {
            LinkSpec::Sim => ("sim", "Simulated drive"),
            LinkSpec::ModbusTcp { .. } => ("modbus-tcp", "Modbus TCP"),
            LinkSpec::ModbusRtu { .. } => ("modbus-rtu", "Modbus RTU"),
            LinkSpec::CanopenSocketcan { .. } => ("canopen+socketcan", "CANopen (SocketCAN)"),
            LinkSpec::CanopenSlcan { .. } => ("canopen+slcan", "CANopen (slcan)"),
            LinkSpec::CanopenSim { .. } => ("canopen+sim", "CANopen (simulated bus)"),
            LinkSpec::Enip { .. } => ("enip", "EtherNet/IP"),
        }
    }

    /// The serial line of a Modbus RTU spec; `None` on the other buses.
    pub fn serial_line(&self) -> Option<SerialLine> {
        match self.clone() {
            LinkSpec::ModbusRtu {
                path,
                baud,
                parity,
                stop_bits,
                slave,
                ..
            } => Some(SerialLine {
                path,
                baud,
                parity,
                stop_bits,
                slave,
            }),
            _ => None,
        }
    }

    /// Defaults that match the drives as they ship (Modbus TCP port 502 unit 0; RTU
    /// 19200 baud 8E1 slave 5; CANopen node 1 at 1 Mbit/s; EtherNet/IP port 44818 with
    /// the PDI assemblies); a string leaves out what it keeps at these. The serial ports
    /// are the names a USB-RS485 adapter and a CANable-style slcan adapter usually get (protocol notes §1.6, §1.7, §2.1, §3.1).
    pub fn default_for(scheme: &str) -> Option<LinkSpec> {
        Some(match scheme {
            "sim" => LinkSpec::Sim,
            "modbus-tcp" => LinkSpec::ModbusTcp {
                host: "192.168.2.100".into(),
                port: 502,
                unit: 0,
                words: WordOrder::High,
            },
            "modbus-rtu" => LinkSpec::ModbusRtu {
                path: serial_port("COM3", "/dev/ttyUSB0"),
                baud: 19_200,
                parity: Parity::Even,
                stop_bits: 1,
                slave: 5,
                words: WordOrder::High,
            },
            "canopen+socketcan" => LinkSpec::CanopenSocketcan {
                iface: "can0".into(),
                can: CanopenOptions::default(),
            },
            "canopen+slcan" => LinkSpec::CanopenSlcan {
                path: serial_port("COM4", "/dev/ttyACM0"),
                bitrate: 1_000_000,
                can: CanopenOptions::default(),
            },
            "canopen+sim" => LinkSpec::CanopenSim {
                can: CanopenOptions::default(),
            },
            "enip" => LinkSpec::Enip {
                host: "192.168.2.100".into(),
                port: 44818,
                enip: EnipOptions::default(),
            },
            _ => return None,
        })
    }

    /// This spec with the query parameters in `query` (`key=value&…`, as after the `?` of
    /// a connection string; a leading `&` is fine) replacing its values, read by the same
    /// rules as a whole string. A key this bus does not take is an error.
    pub fn with_query(&self, query: &str) -> Result<LinkSpec, String> {
        let mut q = Query::parse(query)?;
        self.clone().with_params(&mut q)
    }

    /// The query parameters in which this spec differs from `base` (`keep_pdo=1&udp=0`),
    /// so that `base.with_query(&that)` gives this spec back when both are the same bus
    /// with the same target; empty when they agree.
    pub fn query_beyond(&self, base: &LinkSpec) -> String {
        let theirs = base.params();
        self.params()
            .into_iter()
            .filter(|p| !theirs.iter().any(|t| t.key == p.key && t.value == p.value))
            .map(|p| format!("{}={}", p.key, p.value))
            .collect::<Vec<_>>()
            .join("&")
    }

    /// Whether a spec built in code (the connection bar builds one) is one a connection
    /// string can carry: its string reads back as itself, so every value is in range and
    /// the target can be written.
    pub fn check(&self) -> Result<(), String> {
        let text = self.to_string();
        match parse(&text) {
            Ok(back) if back == *self => Ok(()),
            Ok(back) => Err(format!(
                "{} cannot be written as a connection string: '{text}' reads back as '{back}'",
                self.bus_name()
            )),
            Err(reason) => Err(reason),
        }
    }

    /// Every query parameter, in the order strings write them.
    fn params(&self) -> Vec<Param> {
        match self {
            LinkSpec::Sim => vec![],
            LinkSpec::ModbusTcp { unit, words, .. } => vec![
                Param::always("unit", unit),
                Param::when_set("words", words.name()),
            ],
            LinkSpec::ModbusRtu {
                baud,
                parity,
                stop_bits,
                slave,
                words,
                ..
            } => vec![
                Param::always("baud", baud),
                Param::always("parity", parity.name()),
                Param::always("stop", stop_bits),
                Param::always("slave", slave),
                Param::when_set("words", words.name()),
            ],
            LinkSpec::CanopenSocketcan { can, .. } | LinkSpec::CanopenSim { can } => can.params(),
            LinkSpec::CanopenSlcan { bitrate, can, .. } => {
                let mut params = vec![Param::always("bitrate", bitrate)];
                params.extend(can.params());
                params
            }
            LinkSpec::Enip { enip, .. } => enip.params(),
        }
    }

    /// What comes between `://` and `?`.
    fn target(&self) -> String {
        match self {
            LinkSpec::Sim | LinkSpec::CanopenSim { .. } => String::new(),
            LinkSpec::ModbusTcp { host, port, .. } | LinkSpec::Enip { host, port, .. } => {
                format!("{}:{port}", host_text(host))
            }
            LinkSpec::ModbusRtu { path, .. } | LinkSpec::CanopenSlcan { path, .. } => path.clone(),
            LinkSpec::CanopenSocketcan { iface, .. } => iface.clone(),
        }
    }

    /// This spec with the target of a string in place of its own.
    fn with_target(mut self, target: &str) -> Result<LinkSpec, String> {
        match &mut self {
            LinkSpec::Sim => no_target(target, "the simulator takes no target")?,
            LinkSpec::ModbusTcp { host, port, .. } | LinkSpec::Enip { host, port, .. } => {
                (*host, *port) = host_port(target, *port)?;
            }
            LinkSpec::ModbusRtu { path, .. } => {
                *path = serial_path(target, "modbus-rtu:///dev/ttyUSB0")?;
            }
            LinkSpec::CanopenSocketcan { iface, .. } => {
                if target.is_empty() || target.contains('/') {
                    return Err(
                        "the CAN interface name is missing (e.g. canopen+socketcan://can0)".into(),
                    );
                }
                *iface = target.to_owned();
            }
            LinkSpec::CanopenSlcan { path, .. } => {
                *path = serial_path(target, "canopen+slcan:///dev/ttyACM0")?;
            }
            LinkSpec::CanopenSim { .. } => no_target(
                target,
                "the simulated CAN bus takes no target (canopen+sim://?node=1)",
            )?,
        }
        Ok(self)
    }

    /// This spec with what `q` gives replacing its values; anything left in `q` is an
    /// error.
    fn with_params(mut self, q: &mut Query) -> Result<LinkSpec, String> {
        match &mut self {
            LinkSpec::Sim => {}
            LinkSpec::ModbusTcp { unit, words, .. } => {
                *unit = q.number("unit", *unit, UNITS)?;
                *words = q.words(*words)?;
            }
            LinkSpec::ModbusRtu {
                baud,
                parity,
                stop_bits,
                slave,
                words,
                ..
            } => {
                *baud = q.number("baud", *baud, BAUDS)?;
                *parity = parity_param(q, *parity)?;
                *stop_bits = q.number("stop", *stop_bits, STOP_BITS)?;
                *slave = q.number("slave", *slave, SLAVES)?;
                *words = q.words(*words)?;
            }
            LinkSpec::CanopenSocketcan { can, .. } | LinkSpec::CanopenSim { can } => {
                *can = can.with_params(q)?;
            }
            LinkSpec::CanopenSlcan { bitrate, can, .. } => {
                *bitrate = q.number("bitrate", *bitrate, 10_000..=1_000_000)?;
                if !CAN_BITRATES.contains(bitrate) {
                    return Err(format!(
                        "bitrate={bitrate} is not a CAN bit rate slcan adapters support ({})",
                        CAN_BITRATES.map(|b| b.to_string()).join(", ")
                    ));
                }
                *can = can.with_params(q)?;
            }
            LinkSpec::Enip { enip, .. } => *enip = enip.with_params(q)?,
        }
        let keys: Vec<&str> = self.params().iter().map(|p| p.key).collect();
        q.finish(&keys)?;
        Ok(self)
    }
}

/// The usual name of a serial port: on Windows, elsewhere.
fn serial_port(windows: &str, elsewhere: &str) -> String {
    if cfg!(windows) { windows } else { elsewhere }.into()
}

/// A target where the bus takes none: an error saying `why` unless it is empty.
fn no_target(target: &str, why: &str) -> Result<(), String> {
    if target.is_empty() {
        Ok(())
    } else {
        Err(why.into())
    }
}

/// A serial port path, which a string must name (`example` shows how).
fn serial_path(target: &str, example: &str) -> Result<String, String> {
    if target.is_empty() {
        return Err(format!("the serial port path is missing (e.g. {example})"));
    }
    Ok(target.to_owned())
}

/// `parity=`: none, even or odd (or their first letters).
fn parity_param(q: &mut Query, current: Parity) -> Result<Parity, String> {
    Ok(match q.take("parity").as_deref() {
        None => current,
        Some("even") | Some("e") => Parity::Even,
        Some("none") | Some("n") => Parity::None,
        Some("odd") | Some("o") => Parity::Odd,
        Some(other) => return Err(format!("parity='{other}': use none, even or odd")),
    })
}

impl fmt::Display for LinkSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if *self == LinkSpec::Sim {
            return f.write_str("sim");
        }
        let defaults = LinkSpec::default_for(self.scheme())
            .map(|d| d.params())
            .unwrap_or_default();
        let query = self
            .params()
            .into_iter()
            .filter(|p| {
                p.always
                    || !defaults
                        .iter()
                        .any(|d| d.key == p.key && d.value == p.value)
            })
            .map(|p| format!("{}={}", p.key, p.value))
            .collect::<Vec<_>>()
            .join("&");
        write!(f, "{}://{}?{query}", self.scheme(), self.target())
    }
}

impl FromStr for LinkSpec {
    type Err = SpecError;

    fn from_str(input: &str) -> Result<Self, SpecError> {
        parse(input.trim()).map_err(|reason| SpecError {
            input: input.trim().to_owned(),
            reason,
        })
    }
}

fn parse(input: &str) -> Result<LinkSpec, String> {
    if input.is_empty() {
        return Err("it is empty".into());
    }
    if input == "sim" {
        return Ok(LinkSpec::Sim);
    }
    let (scheme, rest) = input
        .split_once("://")
        .ok_or("it has no scheme (e.g. 'modbus-tcp://')")?;
    let scheme = scheme.to_ascii_lowercase();
    let (target, query) = rest.split_once('?').unwrap_or((rest, ""));
    let mut q = Query::parse(query)?;
    // A string leaves out what it keeps at the defaults.
    LinkSpec::default_for(&scheme)
        .ok_or_else(|| format!("unknown scheme '{scheme}'"))?
        .with_target(target)?
        .with_params(&mut q)
}

#[cfg(test)]
mod tests;
