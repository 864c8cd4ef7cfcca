//! The options a connection string carries per bus: serial parity, the EtherNet/IP I/O
//! set and interval, the CANopen node and PDO settings.

use serde::{Deserialize, Serialize};

use super::text::{NODES, PDOS, Param, Query, RPI_MS};

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

/// A Modbus RTU spec's serial line: the port, its framing, and the slave on it.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct SerialLine {
    pub path: String,
    pub baud: u32,
    pub parity: Parity,
    pub stop_bits: u8,
    pub slave: u8,
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

pub(super) fn default_cmd_at() -> u8 {
    7
}

pub(super) fn default_config() -> u16 {
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
    pub(super) fn params(&self) -> Vec<Param> {
        vec![
            Param::always("io", self.io.name()),
            Param::always("rpi", self.rpi_ms),
            Param::when_set("cmd_at", self.cmd_at),
            Param::when_set("config", self.config),
            Param::when_set("udp", self.udp.map_or("auto".to_owned(), |p| p.to_string())),
        ]
    }

    /// These options with what `q` gives replacing them.
    pub(super) fn with_params(self, q: &mut Query) -> Result<Self, String> {
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

pub(super) fn default_pdo() -> u8 {
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
    pub(super) fn params(&self) -> Vec<Param> {
        vec![
            Param::always("node", self.node),
            Param::when_set("pdo", self.pdo),
            Param::when_set("keep_pdo", u8::from(self.keep_pdo)),
            Param::when_set("self_start", u8::from(self.self_start)),
        ]
    }

    /// These options with what `q` gives replacing them.
    pub(super) fn with_params(self, q: &mut Query) -> Result<Self, String> {
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
