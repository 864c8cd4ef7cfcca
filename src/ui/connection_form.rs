//! The connection bar's fields and the `LinkSpec` they describe.
//!
//! The form holds what the user edits (the boxes' text, the parity and I/O set picked) and
//! builds a `LinkSpec` from it, box by box, with an error that names the box. It never
//! writes or reads connection-string text: `LinkSpec` does (`crate::link::spec`), and the
//! ranges the boxes are checked against are its own. What the bar has no box for
//! (`words=low`, `keep_pdo=1`, `udp=0`) is kept as query text that `LinkSpec` writes
//! (`query_beyond`) and reads back whole (`with_query`).

use std::fmt::Display;
use std::ops::RangeInclusive;

use serde::{Deserialize, Serialize};

use crate::link::spec::{self, BadNumber, CAN_BITRATES, EnipOptions, SerialLine, WordOrder};
use crate::link::{CanopenOptions, EnipIo, LinkSpec, Parity};

/// The bus picked in the connection bar.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Bus {
    Sim,
    ModbusTcp,
    ModbusRtu,
    CanopenSocketcan,
    CanopenSlcan,
    CanopenSim,
    Enip,
}

impl Bus {
    pub const ALL: [Bus; 7] = [
        Bus::Sim,
        Bus::ModbusTcp,
        Bus::ModbusRtu,
        Bus::CanopenSocketcan,
        Bus::CanopenSlcan,
        Bus::CanopenSim,
        Bus::Enip,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Bus::Sim => "Simulated drive",
            Bus::ModbusTcp => "Modbus TCP",
            Bus::ModbusRtu => "Modbus RTU",
            Bus::CanopenSocketcan => "CANopen (SocketCAN)",
            Bus::CanopenSlcan => "CANopen (slcan)",
            Bus::CanopenSim => "CANopen (simulated bus)",
            Bus::Enip => "EtherNet/IP",
        }
    }

    /// The scheme of its connection strings (`LinkSpec::scheme`).
    pub fn scheme(self) -> &'static str {
        match self {
            Bus::Sim => "sim",
            Bus::ModbusTcp => "modbus-tcp",
            Bus::ModbusRtu => "modbus-rtu",
            Bus::CanopenSocketcan => "canopen+socketcan",
            Bus::CanopenSlcan => "canopen+slcan",
            Bus::CanopenSim => "canopen+sim",
            Bus::Enip => "enip",
        }
    }

    /// The bus a spec is on.
    pub fn of(spec: &LinkSpec) -> Bus {
        match spec {
            LinkSpec::Sim => Bus::Sim,
            LinkSpec::ModbusTcp { .. } => Bus::ModbusTcp,
            LinkSpec::ModbusRtu { .. } => Bus::ModbusRtu,
            LinkSpec::CanopenSocketcan { .. } => Bus::CanopenSocketcan,
            LinkSpec::CanopenSlcan { .. } => Bus::CanopenSlcan,
            LinkSpec::CanopenSim { .. } => Bus::CanopenSim,
            LinkSpec::Enip { .. } => Bus::Enip,
        }
    }
}

/// Why the connection bar describes no connection.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum FormError {
    /// A box holds what its bus cannot take.
    #[error("{field}: {problem}")]
    Field {
        /// The box's label in the bar.
        field: &'static str,
        problem: String,
    },
    /// The options the bar has no box for (`modbus_more`, `can_more`, `enip_more` in the
    /// saved settings) do not read as this bus's.
    #[error("options '{text}': {reason}")]
    Options { text: String, reason: String },
    /// The whole cannot be written as a connection string.
    #[error("{0}")]
    Spec(String),
}

fn field_error(field: &'static str, problem: impl Into<String>) -> FormError {
    FormError::Field {
        field,
        problem: problem.into(),
    }
}

/// The connection bar's fields, one set per bus, so switching buses loses nothing.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ConnectionForm {
    pub bus: Bus,
    pub tcp_host: String,
    pub tcp_port: String,
    pub unit: String,
    pub rtu_path: String,
    pub baud: String,
    pub parity: Parity,
    pub stop_bits: String,
    pub slave: String,
    pub can_iface: String,
    pub slcan_path: String,
    pub bitrate: String,
    pub node: String,
    pub pdo: String,
    pub enip_host: String,
    pub enip_port: String,
    pub enip_io: EnipIo,
    pub rpi: String,
    /// Query parameters of the Modbus string the bar has no box for (`words=low`), as
    /// `LinkSpec` writes them; read back whole by `LinkSpec::with_query` (a leading `&`,
    /// as earlier versions saved them, is fine).
    pub modbus_more: String,
    /// The same for CANopen (`keep_pdo=1`).
    pub can_more: String,
    /// The same for EtherNet/IP (`cmd_at=8&udp=0`).
    pub enip_more: String,
    /// The interface EtherNet/IP discovery broadcasts on (name or IP; empty: all).
    pub discover_interface: String,
}

impl Default for ConnectionForm {
    /// Every bus at `LinkSpec`'s defaults (the hardware's), the simulated drive picked.
    fn default() -> Self {
        let blank = Self {
            bus: Bus::Sim,
            tcp_host: String::new(),
            tcp_port: String::new(),
            unit: String::new(),
            rtu_path: String::new(),
            baud: String::new(),
            parity: Parity::Even,
            stop_bits: String::new(),
            slave: String::new(),
            can_iface: String::new(),
            slcan_path: String::new(),
            bitrate: String::new(),
            node: String::new(),
            pdo: String::new(),
            enip_host: String::new(),
            enip_port: String::new(),
            enip_io: EnipIo::Pdi,
            rpi: String::new(),
            modbus_more: String::new(),
            can_more: String::new(),
            enip_more: String::new(),
            discover_interface: String::new(),
        };
        // The simulated drive last, so that it is the bus picked.
        Bus::ALL
            .iter()
            .rev()
            .filter_map(|bus| LinkSpec::default_for(bus.scheme()))
            .fold(blank, |form, spec| ConnectionForm::from_spec(&spec, form))
    }
}

impl ConnectionForm {
    /// The connection the fields describe: each box checked on its own, the options
    /// without a box read by `LinkSpec`, and the whole checked by `LinkSpec`.
    pub fn spec(&self) -> Result<LinkSpec, FormError> {
        let boxes = self.boxes()?;
        let Some(more) = self.more() else {
            return Ok(boxes);
        };
        let options = |reason: String| FormError::Options {
            text: more.trim().to_owned(),
            reason,
        };
        let spec = boxes.with_query(more).map_err(options)?;
        // The options fill in what no box shows; what a box shows is the box's.
        if ConnectionForm::from_spec(&spec, self.clone())
            .boxes()
            .as_ref()
            != Ok(&boxes)
        {
            return Err(options(
                "they set a value the bar has a box for; set it in the box and take it out of the options".into(),
            ));
        }
        spec.check().map_err(FormError::Spec)?;
        Ok(spec)
    }

    /// The form filled from a connection, keeping `base`'s fields for other buses.
    pub fn from_spec(spec: &LinkSpec, base: ConnectionForm) -> ConnectionForm {
        let mut form = base;
        form.bus = Bus::of(spec);
        match spec {
            LinkSpec::Sim => {}
            LinkSpec::ModbusTcp {
                host, port, unit, ..
            } => {
                form.tcp_host = host.clone();
                form.tcp_port = port.to_string();
                form.unit = unit.to_string();
            }
            LinkSpec::ModbusRtu { .. } => {
                if let Some(line) = spec.serial_line() {
                    form.fill_serial(line);
                }
            }
            LinkSpec::CanopenSocketcan { iface, can } => {
                form.can_iface = iface.clone();
                form.fill_can(can);
            }
            LinkSpec::CanopenSim { can } => form.fill_can(can),
            LinkSpec::CanopenSlcan { path, bitrate, can } => {
                form.slcan_path = path.clone();
                form.bitrate = bitrate.to_string();
                form.fill_can(can);
            }
            LinkSpec::Enip { host, port, enip } => {
                form.enip_host = host.clone();
                form.enip_port = port.to_string();
                form.enip_io = enip.io;
                form.rpi = enip.rpi_ms.to_string();
            }
        }
        // What no box shows rides along as the query text that turns the boxes' spec into
        // this one.
        if let Ok(boxes) = form.boxes() {
            let beyond = spec.query_beyond(&boxes);
            if let Some(more) = form.more_mut() {
                *more = beyond;
            }
        }
        form
    }

    fn fill_serial(&mut self, line: SerialLine) {
        self.rtu_path = line.path;
        self.baud = line.baud.to_string();
        self.parity = line.parity;
        self.stop_bits = line.stop_bits.to_string();
        self.slave = line.slave.to_string();
    }

    fn fill_can(&mut self, can: &CanopenOptions) {
        self.node = can.node.to_string();
        self.pdo = can.pdo.to_string();
    }

    /// The spec the boxes give, what they have no box for at its default.
    fn boxes(&self) -> Result<LinkSpec, FormError> {
        Ok(match self.bus {
            Bus::Sim => LinkSpec::Sim,
            Bus::ModbusTcp => LinkSpec::ModbusTcp {
                host: host(&self.tcp_host)?,
                port: number("Port", "a port", &self.tcp_port, spec::PORTS)?,
                unit: number("Unit", "a unit id", &self.unit, spec::UNITS)?,
                words: WordOrder::default(),
            },
            Bus::ModbusRtu => LinkSpec::ModbusRtu {
                path: named("Port", "pick or type the serial port", &self.rtu_path)?,
                baud: number("Baud", "a baud rate", &self.baud, spec::BAUDS)?,
                parity: self.parity,
                stop_bits: number(
                    "Stop",
                    "a number of stop bits",
                    &self.stop_bits,
                    spec::STOP_BITS,
                )?,
                slave: number("Slave", "a slave address", &self.slave, spec::SLAVES)?,
                words: WordOrder::default(),
            },
            Bus::CanopenSocketcan => LinkSpec::CanopenSocketcan {
                iface: named(
                    "Interface",
                    "give the CAN interface, e.g. can0",
                    &self.can_iface,
                )?,
                can: self.can()?,
            },
            Bus::CanopenSlcan => LinkSpec::CanopenSlcan {
                path: named("Port", "pick or type the serial port", &self.slcan_path)?,
                bitrate: bitrate(&self.bitrate)?,
                can: self.can()?,
            },
            Bus::CanopenSim => LinkSpec::CanopenSim { can: self.can()? },
            Bus::Enip => LinkSpec::Enip {
                host: host(&self.enip_host)?,
                port: number("Port", "a port", &self.enip_port, spec::PORTS)?,
                enip: EnipOptions {
                    io: self.enip_io,
                    rpi_ms: number("RPI", "an interval in ms", &self.rpi, spec::RPI_MS)?,
                    ..EnipOptions::default()
                },
            },
        })
    }

    fn can(&self) -> Result<CanopenOptions, FormError> {
        Ok(CanopenOptions {
            node: number("Node", "a node id", &self.node, spec::NODES)?,
            pdo: number("PDO", "a PDO number", &self.pdo, spec::PDOS)?,
            ..CanopenOptions::default()
        })
    }

    /// The options without a box, for the bus picked.
    fn more(&self) -> Option<&String> {
        match self.bus {
            Bus::Sim => None,
            Bus::ModbusTcp | Bus::ModbusRtu => Some(&self.modbus_more),
            Bus::CanopenSocketcan | Bus::CanopenSlcan | Bus::CanopenSim => Some(&self.can_more),
            Bus::Enip => Some(&self.enip_more),
        }
    }

    fn more_mut(&mut self) -> Option<&mut String> {
        match self.bus {
            Bus::Sim => None,
            Bus::ModbusTcp | Bus::ModbusRtu => Some(&mut self.modbus_more),
            Bus::CanopenSocketcan | Bus::CanopenSlcan | Bus::CanopenSim => Some(&mut self.can_more),
            Bus::Enip => Some(&mut self.enip_more),
        }
    }
}

/// A number box, within `range` (`LinkSpec`'s).
fn number<T>(
    field: &'static str,
    what: &str,
    text: &str,
    range: RangeInclusive<T>,
) -> Result<T, FormError>
where
    T: Copy + PartialOrd + TryFrom<i64> + Display,
{
    let within = format!("{what} {}–{}", range.start(), range.end());
    let text = text.trim();
    if text.is_empty() {
        return Err(field_error(field, format!("empty; give {within}")));
    }
    spec::number(text, &range).map_err(|bad| match bad {
        BadNumber::NotANumber => {
            field_error(field, format!("'{text}' is not a number; give {within}"))
        }
        BadNumber::OutOfRange(value) => field_error(field, format!("{value} is not {within}")),
    })
}

/// The slcan bit rate box: one of the rates the adapters support.
fn bitrate(text: &str) -> Result<u32, FormError> {
    let rate = number("Bit rate", "a bit rate", text, 1..=u32::MAX)?;
    if CAN_BITRATES.contains(&rate) {
        Ok(rate)
    } else {
        Err(field_error(
            "Bit rate",
            format!(
                "{rate} is not a CAN bit rate slcan adapters support ({})",
                CAN_BITRATES.map(|b| b.to_string()).join(", ")
            ),
        ))
    }
}

/// A host box: a name or address, an IPv6 address with or without brackets.
fn host(text: &str) -> Result<String, FormError> {
    if text.trim().is_empty() {
        return Err(field_error(
            "Host",
            "empty; give the drive's IP address or host name",
        ));
    }
    spec::parse_host(text).map_err(|reason| field_error("Host", reason))
}

/// A serial port or interface box.
fn named(field: &'static str, hint: &str, text: &str) -> Result<String, FormError> {
    let text = text.trim();
    if text.is_empty() {
        return Err(field_error(field, format!("empty; {hint}")));
    }
    Ok(text.to_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn form_on(bus: Bus) -> ConnectionForm {
        ConnectionForm {
            bus,
            ..ConnectionForm::default()
        }
    }

    /// The form describes no connection, and the reason says `part`.
    #[track_caller]
    fn assert_problem_says(form: &ConnectionForm, part: &str) {
        let problem = problem(form);
        assert!(problem.contains(part), "{problem}");
    }

    /// The connection string the form describes (the test fails where it describes none).
    fn string_of(form: &ConnectionForm) -> String {
        match form.spec() {
            Ok(spec) => spec.to_string(),
            Err(e) => panic!("{form:?}: {e}"),
        }
    }

    fn problem(form: &ConnectionForm) -> String {
        match form.spec() {
            Ok(spec) => panic!("{form:?} gave {spec}"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn every_bus_starts_at_the_links_defaults() {
        for bus in Bus::ALL {
            assert_eq!(
                form_on(bus).spec().ok(),
                LinkSpec::default_for(bus.scheme()),
                "{bus:?}"
            );
            assert_eq!(Bus::of(&form_on(bus).spec().expect("valid")), bus);
        }
        assert_eq!(ConnectionForm::default().bus, Bus::Sim);
    }

    #[test]
    fn a_box_that_holds_what_its_bus_cannot_take_is_named() {
        let mut tcp = form_on(Bus::ModbusTcp);
        tcp.tcp_port = "70000".into();
        assert_eq!(problem(&tcp), "Port: 70000 is not a port 1–65535");
        tcp.tcp_port = "0".into();
        assert_eq!(problem(&tcp), "Port: 0 is not a port 1–65535");
        tcp.tcp_port = "5o2".into();
        assert_eq!(
            problem(&tcp),
            "Port: '5o2' is not a number; give a port 1–65535"
        );
        tcp.tcp_port = " ".into();
        assert_eq!(problem(&tcp), "Port: empty; give a port 1–65535");
        tcp.tcp_port = "1502".into();
        tcp.unit = "256".into();
        assert_eq!(problem(&tcp), "Unit: 256 is not a unit id 0–255");
        tcp.unit = "0".into();
        tcp.tcp_host = String::new();
        assert_eq!(
            problem(&tcp),
            "Host: empty; give the drive's IP address or host name"
        );
        tcp.tcp_host = "my drive".into();
        assert_eq!(problem(&tcp), "Host: 'my drive' is not a host name");
        tcp.tcp_host = "[::1".into();
        assert_eq!(problem(&tcp), "Host: an IPv6 host needs a closing ']'");

        let mut rtu = form_on(Bus::ModbusRtu);
        rtu.baud = "300".into();
        assert_eq!(problem(&rtu), "Baud: 300 is not a baud rate 1200–4000000");
        rtu.baud = "19200".into();
        rtu.stop_bits = "3".into();
        assert_eq!(problem(&rtu), "Stop: 3 is not a number of stop bits 1–2");
        rtu.stop_bits = "1".into();
        rtu.slave = "0".into();
        assert_eq!(problem(&rtu), "Slave: 0 is not a slave address 1–247");
        rtu.slave = "5".into();
        rtu.rtu_path = "  ".into();
        assert_eq!(problem(&rtu), "Port: empty; pick or type the serial port");

        let mut slcan = form_on(Bus::CanopenSlcan);
        slcan.bitrate = "300000".into();
        assert!(
            problem(&slcan).starts_with(
                "Bit rate: 300000 is not a CAN bit rate slcan adapters support (10000, 20000,"
            ),
            "{}",
            problem(&slcan)
        );
        slcan.bitrate = "1000000".into();
        slcan.node = "128".into();
        assert_eq!(problem(&slcan), "Node: 128 is not a node id 1–127");
        slcan.node = "1".into();
        slcan.pdo = "5".into();
        assert_eq!(problem(&slcan), "PDO: 5 is not a PDO number 1–4");

        let mut can = form_on(Bus::CanopenSocketcan);
        can.can_iface = String::new();
        assert_eq!(
            problem(&can),
            "Interface: empty; give the CAN interface, e.g. can0"
        );

        let mut enip = form_on(Bus::Enip);
        enip.rpi = "0".into();
        assert_eq!(problem(&enip), "RPI: 0 is not an interval in ms 1–10000");
        enip.rpi = "10".into();
        enip.enip_port = "-1".into();
        assert_eq!(problem(&enip), "Port: -1 is not a port 1–65535");
    }

    #[test]
    fn boxes_take_numbers_and_hosts_the_way_strings_do() {
        let mut form = form_on(Bus::ModbusTcp);
        form.tcp_host = " [::1] ".into();
        form.tcp_port = "0x5DE".into();
        form.unit = " 3 ".into();
        assert_eq!(
            form.spec(),
            Ok("modbus-tcp://[::1]:1502?unit=3".parse().expect("valid"))
        );
        form.tcp_host = "::1".into();
        assert_eq!(string_of(&form), "modbus-tcp://[::1]:1502?unit=3");
    }

    #[test]
    fn the_options_without_a_box_are_read_whole_by_the_link_spec() {
        let mut enip = form_on(Bus::Enip);
        // As earlier versions saved them, with the leading '&'.
        enip.enip_more = "&udp=0&cmd_at=8".into();
        assert_eq!(
            string_of(&enip),
            "enip://192.168.2.100:44818?io=pdi&rpi=10&cmd_at=8&udp=0"
        );
        enip.enip_more = "cmd_at=9".into();
        assert_eq!(
            problem(&enip),
            "options 'cmd_at=9': cmd_at=9 is out of range 7 … 8"
        );
        enip.enip_more = "udp".into();
        assert_problem_says(&enip, "has no value");
        enip.enip_more = "node=3".into();
        assert_problem_says(&enip, "unknown parameter 'node' (this bus takes io, rpi,");

        let mut modbus = form_on(Bus::ModbusRtu);
        modbus.rtu_path = "COM3".into();
        modbus.modbus_more = "words=low".into();
        assert_eq!(
            string_of(&modbus),
            "modbus-rtu://COM3?baud=19200&parity=even&stop=1&slave=5&words=low"
        );
    }

    #[test]
    fn options_may_not_change_what_a_box_shows() {
        let mut can = form_on(Bus::CanopenSim);
        can.can_more = "node=3&keep_pdo=1".into();
        assert_eq!(
            problem(&can),
            "options 'node=3&keep_pdo=1': they set a value the bar has a box for; set it in the box and take it out of the options"
        );
        // The same value as the box's is no conflict.
        can.node = "3".into();
        assert_eq!(string_of(&can), "canopen+sim://?node=3&keep_pdo=1");
    }

    #[test]
    fn what_a_string_cannot_carry_is_refused_as_a_whole() {
        let mut can = form_on(Bus::CanopenSocketcan);
        can.can_iface = "vcan/0".into();
        assert_problem_says(&can, "the CAN interface name is missing");
    }

    #[test]
    fn the_options_a_string_brings_are_the_ones_no_box_shows() {
        let spec: LinkSpec = "canopen+slcan://COM5?bitrate=500000&node=9&pdo=2&self_start=1"
            .parse()
            .expect("valid");
        let form = ConnectionForm::from_spec(&spec, ConnectionForm::default());
        assert_eq!(form.can_more, "self_start=1");
        assert_eq!((form.node.as_str(), form.pdo.as_str()), ("9", "2"));
        // Other buses keep theirs.
        let base = ConnectionForm {
            enip_more: "udp=0".into(),
            ..ConnectionForm::default()
        };
        let form = ConnectionForm::from_spec(&spec, base);
        assert_eq!(form.enip_more, "udp=0");
    }

    /// Settings saved by the version before the form built `LinkSpec`s itself: the same
    /// fields, the options with a leading '&'.
    #[test]
    fn a_form_saved_by_an_earlier_version_still_loads() {
        let saved = r#"{
            "bus": "Enip",
            "tcp_host": "192.168.2.100", "tcp_port": "502", "unit": "0",
            "rtu_path": "/dev/ttyUSB0", "baud": "19200", "parity": "even",
            "stop_bits": "1", "slave": "5", "can_iface": "can0",
            "slcan_path": "/dev/ttyACM0", "bitrate": "1000000", "node": "4", "pdo": "2",
            "enip_host": "10.0.0.7", "enip_port": "44818", "enip_io": "common",
            "rpi": "4", "modbus_more": "&words=low", "can_more": "&keep_pdo=1",
            "enip_more": "&cmd_at=8&config=0&udp=0", "discover_interface": "eth1"
        }"#;
        let mut form: ConnectionForm = serde_json::from_str(saved).expect("loads");
        assert_eq!(
            string_of(&form),
            "enip://10.0.0.7:44818?io=common&rpi=4&cmd_at=8&config=0&udp=0"
        );
        form.bus = Bus::CanopenSocketcan;
        assert_eq!(
            string_of(&form),
            "canopen+socketcan://can0?node=4&pdo=2&keep_pdo=1"
        );
        form.bus = Bus::ModbusTcp;
        assert_eq!(
            string_of(&form),
            "modbus-tcp://192.168.2.100:502?unit=0&words=low"
        );
        // A form saved with fewer fields takes the defaults for the rest.
        let form: ConnectionForm =
            serde_json::from_str(r#"{"bus": "Enip", "enip_host": "10.0.0.8"}"#).expect("loads");
        assert_eq!(string_of(&form), "enip://10.0.0.8:44818?io=pdi&rpi=10");
    }
}
