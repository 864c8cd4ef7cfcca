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
use std::ops::RangeInclusive;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

pub use crate::proto::modbus::registers::WordOrder;

/// Every form, for error messages and `--help`.
pub const FORMS: &str = "sim | modbus-tcp://HOST:PORT?unit=0[&words=low] | modbus-rtu://PATH?baud=19200&parity=even&stop=1&slave=5[&words=low] | canopen+socketcan://IFACE?node=1[&pdo=1&keep_pdo=1&self_start=1] | canopen+slcan://PATH?bitrate=1000000&node=1 | canopen+sim://?node=1 | enip://HOST:PORT?io=pdi&rpi=10[&cmd_at=8&config=100&udp=2222]";

/// Serial parity.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Parity {
    None,
    Even,
    Odd,
}

impl Parity {
    pub fn name(self) -> &'static str {
        match self {
            Parity::None => "none",
            Parity::Even => "even",
            Parity::Odd => "odd",
        }
    }
}

/// Which EtherNet/IP I/O connection carries the PDI.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum EnipIo {
    /// Assemblies 105 (O→T) / 104 (T→O), 8 bytes each.
    Pdi,
    /// Assemblies 101 / 100, 128 bytes with the extra process values.
    Common,
    /// No I/O connection: the PDI over explicit 2291h/2292h access.
    Explicit,
}

impl EnipIo {
    pub fn name(self) -> &'static str {
        match self {
            EnipIo::Pdi => "pdi",
            EnipIo::Common => "common",
            EnipIo::Explicit => "explicit",
        }
    }
}

/// What an EtherNet/IP connection string carries besides the host.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct EnipOptions {
    /// Which I/O connection carries the PDI.
    pub io: EnipIo,
    /// Requested packet interval of the I/O connection, ms.
    pub rpi_ms: u32,
    /// Where the PDI set's O→T assembly has PDI-Cmd: 7 (8 bytes, default) or 8 (9 bytes,
    /// as the spec's table is printed; protocol notes §5.1).
    #[serde(default = "default_cmd_at")]
    pub cmd_at: u8,
    /// The configuration instance in the Forward_Open path (the drive has none; public
    /// code sends 64h).
    #[serde(default = "default_config")]
    pub config: u16,
    /// The local UDP port for the drive's I/O packets. `None`: 2222 when free, else any
    /// free port, announced to the adapter in a T→O sockaddr item. `Some(0)`: always any
    /// port with the item; `Some(n)`: exactly n, no item.
    #[serde(default)]
    pub udp: Option<u16>,
}

fn default_cmd_at() -> u8 {
    7
}

fn default_config() -> u16 {
    0x64
}

impl Default for EnipOptions {
    fn default() -> Self {
        Self {
            io: EnipIo::Pdi,
            rpi_ms: 10,
            cmd_at: default_cmd_at(),
            config: default_config(),
            udp: None,
        }
    }
}

impl EnipOptions {
    /// Its query parameters, in the order strings write them; `io` and `rpi` always.
    fn params(&self) -> Vec<Param> {
        vec![
            Param::always("io", self.io.name()),
            Param::always("rpi", self.rpi_ms),
            Param::when_set("cmd_at", self.cmd_at),
            Param::when_set("config", self.config),
            Param::when_set("udp", self.udp.map_or("auto".to_owned(), |p| p.to_string())),
        ]
    }

    /// These options with what `q` gives replacing them.
    fn with_params(self, q: &mut Query) -> Result<Self, String> {
        let io = match q.take("io").as_deref() {
            None => self.io,
            Some("pdi") => EnipIo::Pdi,
            Some("common") => EnipIo::Common,
            Some("explicit") | Some("none") => EnipIo::Explicit,
            Some(other) => return Err(format!("io='{other}': use pdi, common or explicit")),
        };
        let rpi_ms = q.number("rpi", self.rpi_ms, RPI_MS)?;
        let cmd_at = q.number("cmd_at", self.cmd_at, 7..=8)?;
        let config = q.number("config", self.config, 0..=0xFFFF)?;
        let udp = match q.take("udp").as_deref() {
            None => self.udp,
            Some("auto") => None,
            Some(text) => Some(
                crate::number::parse_integer(text, false)
                    .and_then(|v| u16::try_from(v).ok())
                    .ok_or_else(|| {
                        format!("udp='{text}': give a port from 0 (any) to 65535, or auto")
                    })?,
            ),
        };
        Ok(Self {
            io,
            rpi_ms,
            cmd_at,
            config,
            udp,
        })
    }
}

/// What every CANopen connection string carries besides the bus.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct CanopenOptions {
    /// The drive's node id, 1 to 127.
    pub node: u8,
    /// Which RPDO/TPDO pair carries the PDI (1 to 4).
    #[serde(default = "default_pdo")]
    pub pdo: u8,
    /// Leave the PDO mapping as drivedeck set it when disconnecting (default: restore).
    #[serde(default)]
    pub keep_pdo: bool,
    /// Master-less setup: set 1F80h = 08h so the node starts by itself after a reset
    /// (spec 3.1), besides the NMT start now. Put back on disconnect unless `keep_pdo`.
    #[serde(default)]
    pub self_start: bool,
}

fn default_pdo() -> u8 {
    1
}

impl Default for CanopenOptions {
    fn default() -> Self {
        Self {
            node: 1,
            pdo: 1,
            keep_pdo: false,
            self_start: false,
        }
    }
}

impl CanopenOptions {
    /// Its query parameters, in the order strings write them; `node` always.
    fn params(&self) -> Vec<Param> {
        vec![
            Param::always("node", self.node),
            Param::when_set("pdo", self.pdo),
            Param::when_set("keep_pdo", u8::from(self.keep_pdo)),
            Param::when_set("self_start", u8::from(self.self_start)),
        ]
    }

    /// These options with what `q` gives replacing them.
    fn with_params(self, q: &mut Query) -> Result<Self, String> {
        let node = q.number("node", self.node, NODES)?;
        let pdo = q.number("pdo", self.pdo, PDOS)?;
        let keep_pdo = q.number("keep_pdo", u8::from(self.keep_pdo), 0..=1)? == 1;
        let self_start = q.number("self_start", u8::from(self.self_start), 0..=1)? == 1;
        Ok(Self {
            node,
            pdo,
            keep_pdo,
            self_start,
        })
    }
}

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

/// The CAN bit rates slcan adapters support (S0..S8).
pub const CAN_BITRATES: [u32; 9] = [
    10_000, 20_000, 50_000, 100_000, 125_000, 250_000, 500_000, 800_000, 1_000_000,
];

/// The TCP ports a host can be reached at.
pub const PORTS: RangeInclusive<u16> = 1..=65535;
/// Modbus TCP unit ids.
pub const UNITS: RangeInclusive<u8> = 0..=255;
/// Modbus RTU baud rates.
pub const BAUDS: RangeInclusive<u32> = 1_200..=4_000_000;
/// Modbus RTU stop bits.
pub const STOP_BITS: RangeInclusive<u8> = 1..=2;
/// Modbus RTU slave addresses (0 is the broadcast, which nothing answers).
pub const SLAVES: RangeInclusive<u8> = 1..=247;
/// CANopen node ids.
pub const NODES: RangeInclusive<u8> = 1..=127;
/// The RPDO/TPDO pair that carries the PDI.
pub const PDOS: RangeInclusive<u8> = 1..=4;
/// EtherNet/IP requested packet intervals, ms.
pub const RPI_MS: RangeInclusive<u32> = 1..=10_000;

/// Why a number given for a connection was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BadNumber {
    /// Not an integer (decimal, or hex as `0x1F` or `1Fh`).
    NotANumber,
    /// An integer outside the range.
    OutOfRange(i64),
}

/// A number as connection strings take them (decimal, or hex as `0x1F` or `1Fh`; `_`
/// between digits), within `range`.
pub fn number<T>(text: &str, range: &RangeInclusive<T>) -> Result<T, BadNumber>
where
    T: Copy + PartialOrd + TryFrom<i64>,
{
    let value = crate::number::parse_integer(text, false)
        .and_then(|v| i64::try_from(v).ok())
        .ok_or(BadNumber::NotANumber)?;
    T::try_from(value)
        .ok()
        .filter(|v| range.contains(v))
        .ok_or(BadNumber::OutOfRange(value))
}

/// A host given alone, as connection strings carry it: a name, an IPv4 address or an
/// IPv6 address (in brackets or not).
pub fn parse_host(text: &str) -> Result<String, String> {
    let text = text.trim();
    let host = match text.strip_prefix('[') {
        Some(rest) => rest
            .strip_suffix(']')
            .ok_or("an IPv6 host needs a closing ']'")?,
        None => text,
    };
    check_host(host)
}

fn check_host(host: &str) -> Result<String, String> {
    if host.is_empty() {
        return Err("the host is missing".into());
    }
    if host.contains(['/', ' ', '?', '#']) {
        return Err(format!("'{host}' is not a host name"));
    }
    Ok(host.to_owned())
}

/// One query parameter of a spec, as its string writes it.
struct Param {
    key: &'static str,
    value: String,
    /// Written even at its default (the usual strings stay short without the others).
    always: bool,
}

impl Param {
    fn always(key: &'static str, value: impl fmt::Display) -> Self {
        Self {
            key,
            value: value.to_string(),
            always: true,
        }
    }

    fn when_set(key: &'static str, value: impl fmt::Display) -> Self {
        Self {
            key,
            value: value.to_string(),
            always: false,
        }
    }
}

impl LinkSpec {
    /// The scheme word, e.g. `modbus-tcp`.
    pub fn scheme(&self) -> &'static str {
        match self {
            LinkSpec::Sim => "sim",
            LinkSpec::ModbusTcp { .. } => "modbus-tcp",
            LinkSpec::ModbusRtu { .. } => "modbus-rtu",
            LinkSpec::CanopenSocketcan { .. } => "canopen+socketcan",
            LinkSpec::CanopenSlcan { .. } => "canopen+slcan",
            LinkSpec::CanopenSim { .. } => "canopen+sim",
            LinkSpec::Enip { .. } => "enip",
        }
    }

    /// The bus in words, for the UI.
    pub fn bus_name(&self) -> &'static str {
        match self {
            LinkSpec::Sim => "Simulated drive",
            LinkSpec::ModbusTcp { .. } => "Modbus TCP",
            LinkSpec::ModbusRtu { .. } => "Modbus RTU",
            LinkSpec::CanopenSocketcan { .. } => "CANopen (SocketCAN)",
            LinkSpec::CanopenSlcan { .. } => "CANopen (slcan)",
            LinkSpec::CanopenSim { .. } => "CANopen (simulated bus)",
            LinkSpec::Enip { .. } => "EtherNet/IP",
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
                path: if cfg!(windows) {
                    "COM3"
                } else {
                    "/dev/ttyUSB0"
                }
                .into(),
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
                path: if cfg!(windows) {
                    "COM4"
                } else {
                    "/dev/ttyACM0"
                }
                .into(),
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
    fn with_target(self, target: &str) -> Result<LinkSpec, String> {
        Ok(match self {
            LinkSpec::Sim => {
                if !target.is_empty() {
                    return Err("the simulator takes no target".into());
                }
                LinkSpec::Sim
            }
            LinkSpec::ModbusTcp {
                port, unit, words, ..
            } => {
                let (host, port) = host_port(target, port)?;
                LinkSpec::ModbusTcp {
                    host,
                    port,
                    unit,
                    words,
                }
            }
            LinkSpec::ModbusRtu {
                baud,
                parity,
                stop_bits,
                slave,
                words,
                ..
            } => {
                if target.is_empty() {
                    return Err(
                        "the serial port path is missing (e.g. modbus-rtu:///dev/ttyUSB0)".into(),
                    );
                }
                LinkSpec::ModbusRtu {
                    path: target.to_owned(),
                    baud,
                    parity,
                    stop_bits,
                    slave,
                    words,
                }
            }
            LinkSpec::CanopenSocketcan { can, .. } => {
                if target.is_empty() || target.contains('/') {
                    return Err(
                        "the CAN interface name is missing (e.g. canopen+socketcan://can0)".into(),
                    );
                }
                LinkSpec::CanopenSocketcan {
                    iface: target.to_owned(),
                    can,
                }
            }
            LinkSpec::CanopenSlcan { bitrate, can, .. } => {
                if target.is_empty() {
                    return Err(
                        "the serial port path is missing (e.g. canopen+slcan:///dev/ttyACM0)"
                            .into(),
                    );
                }
                LinkSpec::CanopenSlcan {
                    path: target.to_owned(),
                    bitrate,
                    can,
                }
            }
            LinkSpec::CanopenSim { can } => {
                if !target.is_empty() {
                    return Err(
                        "the simulated CAN bus takes no target (canopen+sim://?node=1)".into(),
                    );
                }
                LinkSpec::CanopenSim { can }
            }
            LinkSpec::Enip { port, enip, .. } => {
                let (host, port) = host_port(target, port)?;
                LinkSpec::Enip { host, port, enip }
            }
        })
    }

    /// This spec with what `q` gives replacing its values; anything left in `q` is an
    /// error.
    fn with_params(self, q: &mut Query) -> Result<LinkSpec, String> {
        let spec = match self {
            LinkSpec::Sim => LinkSpec::Sim,
            LinkSpec::ModbusTcp {
                host,
                port,
                unit,
                words,
            } => LinkSpec::ModbusTcp {
                host,
                port,
                unit: q.number("unit", unit, UNITS)?,
                words: q.words(words)?,
            },
            LinkSpec::ModbusRtu {
                path,
                baud,
                parity,
                stop_bits,
                slave,
                words,
            } => LinkSpec::ModbusRtu {
                path,
                baud: q.number("baud", baud, BAUDS)?,
                parity: match q.take("parity").as_deref() {
                    None => parity,
                    Some("even") | Some("e") => Parity::Even,
                    Some("none") | Some("n") => Parity::None,
                    Some("odd") | Some("o") => Parity::Odd,
                    Some(other) => return Err(format!("parity='{other}': use none, even or odd")),
                },
                stop_bits: q.number("stop", stop_bits, STOP_BITS)?,
                slave: q.number("slave", slave, SLAVES)?,
                words: q.words(words)?,
            },
            LinkSpec::CanopenSocketcan { iface, can } => LinkSpec::CanopenSocketcan {
                iface,
                can: can.with_params(q)?,
            },
            LinkSpec::CanopenSlcan { path, bitrate, can } => {
                let bitrate = q.number("bitrate", bitrate, 10_000..=1_000_000)?;
                if !CAN_BITRATES.contains(&bitrate) {
                    return Err(format!(
                        "bitrate={bitrate} is not a CAN bit rate slcan adapters support ({})",
                        CAN_BITRATES.map(|b| b.to_string()).join(", ")
                    ));
                }
                LinkSpec::CanopenSlcan {
                    path,
                    bitrate,
                    can: can.with_params(q)?,
                }
            }
            LinkSpec::CanopenSim { can } => LinkSpec::CanopenSim {
                can: can.with_params(q)?,
            },
            LinkSpec::Enip { host, port, enip } => LinkSpec::Enip {
                host,
                port,
                enip: enip.with_params(q)?,
            },
        };
        let keys: Vec<&str> = spec.params().iter().map(|p| p.key).collect();
        q.finish(&keys)?;
        Ok(spec)
    }
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

fn host_text(host: &str) -> String {
    if host.contains(':') {
        format!("[{host}]")
    } else {
        host.to_owned()
    }
}

/// Query parameters, each used at most once; leftovers are an error.
struct Query {
    pairs: Vec<(String, String)>,
}

impl Query {
    fn parse(text: &str) -> Result<Self, String> {
        let mut pairs: Vec<(String, String)> = vec![];
        for part in text.split('&').filter(|p| !p.is_empty()) {
            let (key, value) = part
                .split_once('=')
                .ok_or_else(|| format!("parameter '{part}' has no value (write key=value)"))?;
            let key = key.trim().to_ascii_lowercase();
            if pairs.iter().any(|(k, _)| *k == key) {
                return Err(format!("parameter '{key}' is given twice"));
            }
            pairs.push((key, value.trim().to_owned()));
        }
        Ok(Self { pairs })
    }

    fn take(&mut self, key: &str) -> Option<String> {
        let at = self.pairs.iter().position(|(k, _)| k == key)?;
        Some(self.pairs.remove(at).1)
    }

    /// A numeric parameter within `range`; `current` when it is not given.
    fn number<T>(&mut self, key: &str, current: T, range: RangeInclusive<T>) -> Result<T, String>
    where
        T: Copy + PartialOrd + TryFrom<i64> + fmt::Display,
    {
        match self.take(key) {
            None => Ok(current),
            Some(text) => number(&text, &range).map_err(|bad| match bad {
                BadNumber::NotANumber => format!("{key}='{text}' is not a number"),
                BadNumber::OutOfRange(value) => format!(
                    "{key}={value} is out of range {}..={}",
                    range.start(),
                    range.end()
                ),
            }),
        }
    }

    fn words(&mut self, current: WordOrder) -> Result<WordOrder, String> {
        match self.take("words").as_deref() {
            None => Ok(current),
            Some("high") | Some("hi") => Ok(WordOrder::High),
            Some("low") | Some("lo") => Ok(WordOrder::Low),
            Some(other) => Err(format!(
                "words='{other}': use high (high word first, Nanotec) or low"
            )),
        }
    }

    fn finish(&self, allowed: &[&str]) -> Result<(), String> {
        match self.pairs.first() {
            None => Ok(()),
            Some((key, _)) => Err(format!(
                "unknown parameter '{key}' (this bus takes {})",
                if allowed.is_empty() {
                    "no parameters".to_owned()
                } else {
                    allowed.join(", ")
                }
            )),
        }
    }
}

/// `HOST[:PORT]`, with IPv6 hosts in brackets.
fn host_port(text: &str, default_port: u16) -> Result<(String, u16), String> {
    if text.is_empty() {
        return Err("the host is missing".into());
    }
    let (host, port) = if let Some(rest) = text.strip_prefix('[') {
        let (host, after) = rest
            .split_once(']')
            .ok_or("an IPv6 host needs a closing ']'")?;
        match after.strip_prefix(':') {
            Some(port) => (host, Some(port)),
            None if after.is_empty() => (host, None),
            None => return Err(format!("unexpected '{after}' after the host")),
        }
    } else {
        match text.rsplit_once(':') {
            Some((host, port)) if !host.contains(':') => (host, Some(port)),
            Some(_) => return Err("write an IPv6 host in brackets, e.g. [::1]:502".into()),
            None => (text, None),
        }
    };
    let host = check_host(host)?;
    let port = match port {
        None => default_port,
        Some(p) => p
            .parse::<u16>()
            .ok()
            .filter(|p| PORTS.contains(p))
            .ok_or_else(|| format!("port '{p}' is not a number from 1 to 65535"))?,
    };
    Ok((host, port))
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
mod tests {
    use super::*;

    fn ok(text: &str) -> LinkSpec {
        text.parse().unwrap_or_else(|e| panic!("{text}: {e}"))
    }

    fn err(text: &str) -> String {
        match text.parse::<LinkSpec>() {
            Ok(spec) => panic!("{text} parsed as {spec:?}"),
            Err(e) => e.reason,
        }
    }

    #[test]
    fn every_form_of_the_issue_parses_with_its_defaults() {
        assert_eq!(ok("sim"), LinkSpec::Sim);
        assert_eq!(ok("sim://"), LinkSpec::Sim);
        assert_eq!(
            ok("modbus-tcp://192.168.2.10"),
            LinkSpec::ModbusTcp {
                host: "192.168.2.10".into(),
                port: 502,
                unit: 0,
                words: WordOrder::High
            }
        );
        assert_eq!(
            ok("modbus-tcp://localhost:1502?unit=3"),
            LinkSpec::ModbusTcp {
                host: "localhost".into(),
                port: 1502,
                unit: 3,
                words: WordOrder::High
            }
        );
        assert_eq!(
            ok("modbus-tcp://[::1]:1502"),
            LinkSpec::ModbusTcp {
                host: "::1".into(),
                port: 1502,
                unit: 0,
                words: WordOrder::High
            }
        );
        assert_eq!(
            ok("modbus-rtu:///dev/ttyUSB0"),
            LinkSpec::ModbusRtu {
                path: "/dev/ttyUSB0".into(),
                baud: 19_200,
                parity: Parity::Even,
                stop_bits: 1,
                slave: 5,
                words: WordOrder::High
            }
        );
        assert_eq!(
            ok("modbus-rtu://COM3?baud=115200&parity=none&stop=2&slave=7&words=low"),
            LinkSpec::ModbusRtu {
                path: "COM3".into(),
                baud: 115_200,
                parity: Parity::None,
                stop_bits: 2,
                slave: 7,
                words: WordOrder::Low
            }
        );
        assert_eq!(
            ok("canopen+socketcan://can0?node=1"),
            LinkSpec::CanopenSocketcan {
                iface: "can0".into(),
                can: CanopenOptions::default()
            }
        );
        assert_eq!(
            ok("canopen+slcan:///dev/ttyACM0?bitrate=500000&node=127"),
            LinkSpec::CanopenSlcan {
                path: "/dev/ttyACM0".into(),
                bitrate: 500_000,
                can: CanopenOptions {
                    node: 127,
                    ..CanopenOptions::default()
                }
            }
        );
        assert_eq!(
            ok("enip://10.0.0.5?io=common&rpi=20"),
            LinkSpec::Enip {
                host: "10.0.0.5".into(),
                port: 44818,
                enip: EnipOptions {
                    io: EnipIo::Common,
                    rpi_ms: 20,
                    ..EnipOptions::default()
                }
            }
        );
    }

    #[test]
    fn display_round_trips() {
        for text in [
            "sim",
            "modbus-tcp://127.0.0.1:1502?unit=0",
            "modbus-tcp://[::1]:502?unit=9",
            "modbus-tcp://10.0.0.1:502?unit=0&words=low",
            "modbus-rtu:///dev/ttyUSB0?baud=19200&parity=even&stop=1&slave=5",
            "canopen+socketcan://can0?node=1",
            "canopen+slcan://COM4?bitrate=1000000&node=1",
            "canopen+slcan:///dev/ttyACM0?bitrate=500000&node=3&pdo=4&keep_pdo=1",
            "canopen+sim://?node=1",
            "canopen+sim://?node=2&self_start=1",
            "modbus-rtu://COM3?baud=115200&parity=none&stop=2&slave=7&words=low",
            "enip://127.0.0.1:44818?io=pdi&rpi=10",
            "enip://127.0.0.1:44818?io=pdi&rpi=4&cmd_at=8&config=0&udp=0",
            "enip://[::1]:2000?io=explicit&rpi=10&udp=2222",
        ] {
            assert_eq!(ok(text).to_string(), text);
            assert_eq!(ok(&ok(text).to_string()), ok(text));
        }
        for scheme in [
            "canopen+sim",
            "sim",
            "modbus-tcp",
            "modbus-rtu",
            "canopen+socketcan",
            "canopen+slcan",
            "enip",
        ] {
            let spec = LinkSpec::default_for(scheme).unwrap();
            assert_eq!(spec.scheme(), scheme);
            assert_eq!(ok(&spec.to_string()), spec);
        }
    }

    #[test]
    fn malformed_strings_say_what_is_wrong() {
        assert_eq!(err(""), "it is empty");
        assert!(err("modbus").contains("no scheme"));
        assert!(err("profibus://x").contains("unknown scheme 'profibus'"));
        assert!(err("modbus-tcp://").contains("host is missing"));
        assert!(err("modbus-tcp://h:99999").contains("port '99999'"));
        assert!(err("modbus-tcp://h?unit=300").contains("unit=300 is out of range 0..=255"));
        assert!(
            err("modbus-tcp://h?unti=3")
                .contains("unknown parameter 'unti' (this bus takes unit, words)")
        );
        assert!(err("modbus-tcp://h?words=middle").contains("use high"));
        assert!(err("modbus-tcp://h?unit").contains("has no value"));
        assert!(err("modbus-tcp://h?unit=1&unit=2").contains("given twice"));
        assert!(err("modbus-tcp://::1:502").contains("brackets"));
        assert!(err("modbus-rtu://?baud=9600").contains("serial port path is missing"));
        assert!(err("modbus-rtu://COM1?parity=mark").contains("use none, even or odd"));
        assert!(err("modbus-rtu://COM1?slave=0").contains("slave=0 is out of range 1..=247"));
        assert!(err("canopen+socketcan://can0?node=128").contains("node=128"));
        assert!(err("canopen+sim://?pdo=5").contains("pdo=5 is out of range 1..=4"));
        assert!(err("canopen+slcan://COM1?bitrate=300000").contains("not a CAN bit rate"));
        assert!(err("enip://h?io=both").contains("use pdi, common or explicit"));
        assert!(err("enip://h?cmd_at=9").contains("cmd_at=9 is out of range 7..=8"));
        assert!(err("enip://h?udp=x").contains("udp='x'"));
        assert!(err("sim://x").contains("no target"));
        let full = "x".parse::<LinkSpec>().unwrap_err().to_string();
        assert!(
            full.contains("Forms: sim | modbus-tcp://HOST:PORT?unit=0"),
            "{full}"
        );
    }

    #[test]
    fn a_query_replaces_what_it_names_by_the_rules_of_a_whole_string() {
        let base = ok("enip://10.0.0.5?io=common&rpi=20");
        assert_eq!(
            base.with_query("&udp=0&cmd_at=8").map(|s| s.to_string()),
            Ok("enip://10.0.0.5:44818?io=common&rpi=20&cmd_at=8&udp=0".to_owned())
        );
        assert_eq!(base.with_query(""), Ok(base.clone()));
        assert_eq!(
            base.with_query("cmd_at=9"),
            Err("cmd_at=9 is out of range 7..=8".to_owned())
        );
        assert_eq!(
            base.with_query("udp=1&udp=2"),
            Err("parameter 'udp' is given twice".to_owned())
        );
        assert!(
            base.with_query("node=2")
                .is_err_and(|e| e.contains("unknown parameter 'node'"))
        );
        assert!(
            LinkSpec::Sim
                .with_query("unit=1")
                .is_err_and(|e| e.contains("this bus takes no parameters"))
        );
    }

    #[test]
    fn the_query_beyond_a_base_gives_the_spec_back() {
        for (text, base) in [
            (
                "enip://h:1?io=common&rpi=4&cmd_at=8&config=0&udp=0",
                "enip://h:1?io=common&rpi=4",
            ),
            (
                "canopen+slcan://COM5?bitrate=500000&node=9&keep_pdo=1",
                "canopen+slcan://COM5?bitrate=500000&node=9",
            ),
            (
                "modbus-tcp://h:502?unit=3&words=low",
                "modbus-tcp://h:502?unit=3",
            ),
            // The base may differ from the defaults too: then the query says so.
            (
                "enip://h:1?io=pdi&rpi=10",
                "enip://h:1?io=pdi&rpi=10&udp=2222",
            ),
        ] {
            let (spec, base) = (ok(text), ok(base));
            let beyond = spec.query_beyond(&base);
            assert_eq!(
                base.with_query(&beyond),
                Ok(spec.clone()),
                "{text}: {beyond}"
            );
        }
        let spec = ok("canopen+sim://?node=2&pdo=3&self_start=1");
        assert_eq!(
            spec.query_beyond(&ok("canopen+sim://?node=2")),
            "pdo=3&self_start=1"
        );
        assert_eq!(spec.query_beyond(&spec), "");
        assert_eq!(
            ok("enip://h?udp=2222").query_beyond(&ok("enip://h")),
            "udp=2222"
        );
        assert_eq!(
            ok("enip://h").query_beyond(&ok("enip://h?udp=2222")),
            "udp=auto"
        );
    }

    #[test]
    fn a_spec_built_in_code_is_checked_by_reading_its_string_back() {
        assert_eq!(ok("canopen+sim://?node=5").check(), Ok(()));
        let zero = LinkSpec::CanopenSim {
            can: CanopenOptions {
                node: 0,
                ..CanopenOptions::default()
            },
        };
        assert_eq!(
            zero.check(),
            Err("node=0 is out of range 1..=127".to_owned())
        );
        let path = LinkSpec::CanopenSlcan {
            path: "COM5?x=1".into(),
            bitrate: 1_000_000,
            can: CanopenOptions::default(),
        };
        assert!(path.check().is_err());
        let bitrate = LinkSpec::CanopenSlcan {
            path: "COM5".into(),
            bitrate: 300_000,
            can: CanopenOptions::default(),
        };
        assert!(
            bitrate
                .check()
                .is_err_and(|e| e.contains("not a CAN bit rate"))
        );
    }

    #[test]
    fn hosts_and_numbers_are_read_alone_as_in_a_string() {
        assert_eq!(parse_host(" [fe80::1] "), Ok("fe80::1".to_owned()));
        assert_eq!(parse_host("::1"), Ok("::1".to_owned()));
        assert_eq!(parse_host("drive.local"), Ok("drive.local".to_owned()));
        assert_eq!(parse_host(""), Err("the host is missing".to_owned()));
        assert_eq!(parse_host("[]"), Err("the host is missing".to_owned()));
        assert_eq!(
            parse_host("a/b"),
            Err("'a/b' is not a host name".to_owned())
        );
        assert_eq!(number(" 0x10 ", &NODES), Ok(16u8));
        assert_eq!(number("1_000", &RPI_MS), Ok(1000u32));
        assert_eq!(number("128", &NODES), Err(BadNumber::OutOfRange(128)));
        assert_eq!(number("-1", &UNITS), Err(BadNumber::OutOfRange(-1)));
        assert_eq!(number("x", &UNITS), Err(BadNumber::NotANumber));
    }
}
