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

pub use super::modbus::registers::WordOrder;

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
    fn query(&self) -> String {
        let mut q = format!("io={}&rpi={}", self.io.name(), self.rpi_ms);
        if self.cmd_at != default_cmd_at() {
            q.push_str(&format!("&cmd_at={}", self.cmd_at));
        }
        if self.config != default_config() {
            q.push_str(&format!("&config={}", self.config));
        }
        if let Some(udp) = self.udp {
            q.push_str(&format!("&udp={udp}"));
        }
        q
    }

    fn parse(q: &mut Query) -> Result<Self, String> {
        let io = match q.take("io").as_deref() {
            None | Some("pdi") => EnipIo::Pdi,
            Some("common") => EnipIo::Common,
            Some("explicit") | Some("none") => EnipIo::Explicit,
            Some(other) => return Err(format!("io='{other}': use pdi, common or explicit")),
        };
        let rpi_ms = q.number("rpi", 10, 1, 10_000)? as u32;
        let cmd_at = q.number("cmd_at", 7, 7, 8)? as u8;
        let config = q.number("config", 0x64, 0, 0xFFFF)? as u16;
        let udp = match q.take("udp").as_deref() {
            None | Some("auto") => None,
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
    fn query(&self) -> String {
        let mut q = format!("node={}", self.node);
        if self.pdo != 1 {
            q.push_str(&format!("&pdo={}", self.pdo));
        }
        if self.keep_pdo {
            q.push_str("&keep_pdo=1");
        }
        if self.self_start {
            q.push_str("&self_start=1");
        }
        q
    }

    fn parse(q: &mut Query) -> Result<Self, String> {
        let node = q.number("node", 1, 1, 127)? as u8;
        let pdo = q.number("pdo", 1, 1, 4)? as u8;
        let keep_pdo = q.number("keep_pdo", 0, 0, 1)? == 1;
        let self_start = q.number("self_start", 0, 0, 1)? == 1;
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

    /// Defaults that match the hardware (protocol notes §1.6, §1.7, §2.1, §3.1).
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
                path: default_serial_port().into(),
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
                path: default_serial_port().into(),
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
}

fn default_serial_port() -> &'static str {
    if cfg!(windows) {
        "COM3"
    } else {
        "/dev/ttyUSB0"
    }
}

impl fmt::Display for LinkSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LinkSpec::Sim => f.write_str("sim"),
            LinkSpec::ModbusTcp {
                host,
                port,
                unit,
                words,
            } => write!(
                f,
                "modbus-tcp://{}:{port}?unit={unit}{}",
                host_text(host),
                words_suffix(*words)
            ),
            LinkSpec::ModbusRtu {
                path,
                baud,
                parity,
                stop_bits,
                slave,
                words,
            } => write!(
                f,
                "modbus-rtu://{path}?baud={baud}&parity={}&stop={stop_bits}&slave={slave}{}",
                parity.name(),
                words_suffix(*words)
            ),
            LinkSpec::CanopenSocketcan { iface, can } => {
                write!(f, "canopen+socketcan://{iface}?{}", can.query())
            }
            LinkSpec::CanopenSlcan { path, bitrate, can } => {
                write!(
                    f,
                    "canopen+slcan://{path}?bitrate={bitrate}&{}",
                    can.query()
                )
            }
            LinkSpec::CanopenSim { can } => write!(f, "canopen+sim://?{}", can.query()),
            LinkSpec::Enip { host, port, enip } => {
                write!(f, "enip://{}:{port}?{}", host_text(host), enip.query())
            }
        }
    }
}

/// `words=` only when it differs from the default, so the usual strings stay short.
fn words_suffix(words: WordOrder) -> String {
    match words {
        WordOrder::High => String::new(),
        WordOrder::Low => "&words=low".into(),
    }
}

fn words(q: &mut Query) -> Result<WordOrder, String> {
    match q.take("words").as_deref() {
        None | Some("high") | Some("hi") => Ok(WordOrder::High),
        Some("low") | Some("lo") => Ok(WordOrder::Low),
        Some(other) => Err(format!(
            "words='{other}': use high (high word first, Nanotec) or low"
        )),
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

    /// A numeric parameter within `min..=max`; the caller narrows it (the range check
    /// makes that exact).
    fn number(&mut self, key: &str, default: i64, min: i64, max: i64) -> Result<i64, String> {
        match self.take(key) {
            None => Ok(default),
            Some(text) => {
                let value = crate::number::parse_integer(&text, false)
                    .and_then(|v| i64::try_from(v).ok())
                    .ok_or_else(|| format!("{key}='{text}' is not a number"))?;
                if value < min || value > max {
                    return Err(format!("{key}={value} is out of range {min}..={max}"));
                }
                Ok(value)
            }
        }
    }

    fn finish(self, allowed: &[&str]) -> Result<(), String> {
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
            Some(port) => (host.to_owned(), Some(port)),
            None if after.is_empty() => (host.to_owned(), None),
            None => return Err(format!("unexpected '{after}' after the host")),
        }
    } else {
        match text.rsplit_once(':') {
            Some((host, port)) if !host.contains(':') => (host.to_owned(), Some(port)),
            Some(_) => return Err("write an IPv6 host in brackets, e.g. [::1]:502".into()),
            None => (text.to_owned(), None),
        }
    };
    if host.is_empty() {
        return Err("the host is missing".into());
    }
    if host.contains(['/', ' ', '?', '#']) {
        return Err(format!("'{host}' is not a host name"));
    }
    let port = match port {
        None => default_port,
        Some(p) => p
            .parse::<u16>()
            .ok()
            .filter(|p| *p > 0)
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
    let spec = match scheme.as_str() {
        "sim" => {
            if !target.is_empty() {
                return Err("the simulator takes no target".into());
            }
            q.finish(&[])?;
            LinkSpec::Sim
        }
        "modbus-tcp" => {
            let (host, port) = host_port(target, 502)?;
            let unit = q.number("unit", 0, 0, 255)? as u8;
            let words = words(&mut q)?;
            q.finish(&["unit", "words"])?;
            LinkSpec::ModbusTcp {
                host,
                port,
                unit,
                words,
            }
        }
        "modbus-rtu" => {
            if target.is_empty() {
                return Err(
                    "the serial port path is missing (e.g. modbus-rtu:///dev/ttyUSB0)".into(),
                );
            }
            let baud = q.number("baud", 19_200, 1_200, 4_000_000)? as u32;
            let parity = match q.take("parity").as_deref() {
                None | Some("even") | Some("e") => Parity::Even,
                Some("none") | Some("n") => Parity::None,
                Some("odd") | Some("o") => Parity::Odd,
                Some(other) => return Err(format!("parity='{other}': use none, even or odd")),
            };
            let stop_bits = q.number("stop", 1, 1, 2)? as u8;
            let slave = q.number("slave", 5, 1, 247)? as u8;
            let words = words(&mut q)?;
            q.finish(&["baud", "parity", "stop", "slave", "words"])?;
            LinkSpec::ModbusRtu {
                path: target.to_owned(),
                baud,
                parity,
                stop_bits,
                slave,
                words,
            }
        }
        "canopen+socketcan" => {
            if target.is_empty() || target.contains('/') {
                return Err(
                    "the CAN interface name is missing (e.g. canopen+socketcan://can0)".into(),
                );
            }
            let can = CanopenOptions::parse(&mut q)?;
            q.finish(&["node", "pdo", "keep_pdo", "self_start"])?;
            LinkSpec::CanopenSocketcan {
                iface: target.to_owned(),
                can,
            }
        }
        "canopen+slcan" => {
            if target.is_empty() {
                return Err(
                    "the serial port path is missing (e.g. canopen+slcan:///dev/ttyACM0)".into(),
                );
            }
            let bitrate = q.number("bitrate", 1_000_000, 10_000, 1_000_000)? as u32;
            if !CAN_BITRATES.contains(&bitrate) {
                return Err(format!(
                    "bitrate={bitrate} is not a CAN bit rate slcan adapters support ({})",
                    CAN_BITRATES.map(|b| b.to_string()).join(", ")
                ));
            }
            let can = CanopenOptions::parse(&mut q)?;
            q.finish(&["bitrate", "node", "pdo", "keep_pdo", "self_start"])?;
            LinkSpec::CanopenSlcan {
                path: target.to_owned(),
                bitrate,
                can,
            }
        }
        "canopen+sim" => {
            if !target.is_empty() {
                return Err("the simulated CAN bus takes no target (canopen+sim://?node=1)".into());
            }
            let can = CanopenOptions::parse(&mut q)?;
            q.finish(&["node", "pdo", "keep_pdo", "self_start"])?;
            LinkSpec::CanopenSim { can }
        }
        "enip" => {
            let (host, port) = host_port(target, 44818)?;
            let enip = EnipOptions::parse(&mut q)?;
            q.finish(&["io", "rpi", "cmd_at", "config", "udp"])?;
            LinkSpec::Enip { host, port, enip }
        }
        other => return Err(format!("unknown scheme '{other}'")),
    };
    Ok(spec)
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
}
