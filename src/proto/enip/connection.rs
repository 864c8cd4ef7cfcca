//! Opening and closing CIP connections (protocol notes §3.4): Forward_Open (54h),
//! Large_Forward_Open (5Bh) and Forward_Close (4Eh) to the Connection Manager, class 06h
//! instance 1, with their replies and extended status codes.

use std::time::Duration;

use super::wire::{DecodeError, Put, Reader};

/// How a connection is addressed on the network.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ConnectionType {
    Null,
    Multicast,
    PointToPoint,
    Reserved,
}

/// Transmission priority.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Priority {
    Low,
    High,
    Scheduled,
    Urgent,
}

/// The network connection parameters of one direction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NetworkParams {
    pub redundant_owner: bool,
    pub kind: ConnectionType,
    pub priority: Priority,
    /// Variable (true) or fixed (false) size.
    pub variable: bool,
    /// Bytes per packet, with the class 1 sequence count and the run/idle header.
    pub size: u16,
}

impl NetworkParams {
    /// Point-to-point, scheduled, fixed: what drivedeck asks for both directions of I/O.
    pub fn point_to_point(size: u16) -> NetworkParams {
        NetworkParams {
            redundant_owner: false,
            kind: ConnectionType::PointToPoint,
            priority: Priority::Scheduled,
            variable: false,
            size,
        }
    }

    fn fields(self) -> (u32, u32, u32, u32) {
        let kind = match self.kind {
            ConnectionType::Null => 0,
            ConnectionType::Multicast => 1,
            ConnectionType::PointToPoint => 2,
            ConnectionType::Reserved => 3,
        };
        let priority = match self.priority {
            Priority::Low => 0,
            Priority::High => 1,
            Priority::Scheduled => 2,
            Priority::Urgent => 3,
        };
        (
            u32::from(self.redundant_owner),
            kind,
            priority,
            u32::from(self.variable),
        )
    }

    fn from_fields(owner: u32, kind: u32, priority: u32, variable: u32, size: u16) -> Self {
        NetworkParams {
            redundant_owner: owner != 0,
            kind: match kind & 3 {
                0 => ConnectionType::Null,
                1 => ConnectionType::Multicast,
                2 => ConnectionType::PointToPoint,
                _ => ConnectionType::Reserved,
            },
            priority: match priority & 3 {
                0 => Priority::Low,
                1 => Priority::High,
                2 => Priority::Scheduled,
                _ => Priority::Urgent,
            },
            variable: variable != 0,
            size,
        }
    }

    /// The 16-bit form of Forward_Open: size in bits 8-0.
    pub fn to_u16(self) -> u16 {
        let (owner, kind, priority, variable) = self.fields();
        (owner << 15 | kind << 13 | priority << 10 | variable << 9 | u32::from(self.size & 0x1FF))
            as u16
    }

    pub fn from_u16(v: u16) -> NetworkParams {
        let v = u32::from(v);
        Self::from_fields(v >> 15, v >> 13, v >> 10, (v >> 9) & 1, (v & 0x1FF) as u16)
    }

    /// The 32-bit form of Large_Forward_Open: size in bits 15-0.
    pub fn to_u32(self) -> u32 {
        let (owner, kind, priority, variable) = self.fields();
        owner << 31 | kind << 29 | priority << 26 | variable << 25 | u32::from(self.size)
    }

    pub fn from_u32(v: u32) -> NetworkParams {
        Self::from_fields(
            v >> 31,
            v >> 29,
            v >> 26,
            (v >> 25) & 1,
            (v & 0xFFFF) as u16,
        )
    }
}

/// The transport class and trigger byte: class 1 cyclic is 01h.
pub const TRANSPORT_CLASS1_CYCLIC: u8 = 0x01;

/// Forward_Open or Large_Forward_Open request data.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ForwardOpen {
    pub large: bool,
    /// Priority and time tick (03h: 8 ms ticks).
    pub tick: u8,
    pub timeout_ticks: u8,
    /// Proposed by the originator; the target picks its own for point-to-point O→T.
    pub ot_connection: u32,
    pub to_connection: u32,
    pub serial: u16,
    pub vendor: u16,
    pub originator_serial: u32,
    pub timeout_multiplier: u8,
    pub ot_rpi_us: u32,
    pub ot_params: NetworkParams,
    pub to_rpi_us: u32,
    pub to_params: NetworkParams,
    pub transport: u8,
    /// The connection path, padded EPATH bytes.
    pub path: Vec<u8>,
}

impl ForwardOpen {
    pub fn service(&self) -> u8 {
        if self.large {
            super::cip::service::LARGE_FORWARD_OPEN
        } else {
            super::cip::service::FORWARD_OPEN
        }
    }

    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(48 + self.path.len());
        out.put_u8(self.tick);
        out.put_u8(self.timeout_ticks);
        out.put_u32(self.ot_connection);
        out.put_u32(self.to_connection);
        out.put_u16(self.serial);
        out.put_u16(self.vendor);
        out.put_u32(self.originator_serial);
        out.put_u8(self.timeout_multiplier);
        out.extend_from_slice(&[0, 0, 0]);
        out.put_u32(self.ot_rpi_us);
        if self.large {
            out.put_u32(self.ot_params.to_u32());
        } else {
            out.put_u16(self.ot_params.to_u16());
        }
        out.put_u32(self.to_rpi_us);
        if self.large {
            out.put_u32(self.to_params.to_u32());
        } else {
            out.put_u16(self.to_params.to_u16());
        }
        out.put_u8(self.transport);
        out.put_u8((self.path.len() / 2) as u8);
        out.extend_from_slice(&self.path);
        out
    }

    pub fn decode(large: bool, data: &[u8]) -> Result<ForwardOpen, DecodeError> {
        let what = if large {
            "Large_Forward_Open request"
        } else {
            "Forward_Open request"
        };
        let mut r = Reader::new(what, data);
        let tick = r.u8("priority/time tick")?;
        let timeout_ticks = r.u8("timeout ticks")?;
        let ot_connection = r.u32("O→T connection id")?;
        let to_connection = r.u32("T→O connection id")?;
        let serial = r.u16("connection serial number")?;
        let vendor = r.u16("originator vendor id")?;
        let originator_serial = r.u32("originator serial number")?;
        let timeout_multiplier = r.u8("connection timeout multiplier")?;
        r.take(3, "reserved")?;
        let ot_rpi_us = r.u32("O→T RPI")?;
        let ot_params = if large {
            NetworkParams::from_u32(r.u32("O→T network parameters")?)
        } else {
            NetworkParams::from_u16(r.u16("O→T network parameters")?)
        };
        let to_rpi_us = r.u32("T→O RPI")?;
        let to_params = if large {
            NetworkParams::from_u32(r.u32("T→O network parameters")?)
        } else {
            NetworkParams::from_u16(r.u16("T→O network parameters")?)
        };
        let transport = r.u8("transport type/trigger")?;
        let words = usize::from(r.u8("connection path size")?);
        let path = r.take(words * 2, "connection path")?.to_vec();
        r.end()?;
        Ok(ForwardOpen {
            large,
            tick,
            timeout_ticks,
            ot_connection,
            to_connection,
            serial,
            vendor,
            originator_serial,
            timeout_multiplier,
            ot_rpi_us,
            ot_params,
            to_rpi_us,
            to_params,
            transport,
            path,
        })
    }

    /// The connection triad that names this connection to the target.
    pub fn triad(&self) -> Triad {
        Triad {
            serial: self.serial,
            vendor: self.vendor,
            originator_serial: self.originator_serial,
        }
    }

    /// How long the consumer waits for a packet before it gives the connection up.
    pub fn ot_timeout(&self) -> Duration {
        timeout(self.ot_rpi_us, self.timeout_multiplier)
    }

    pub fn to_timeout(&self) -> Duration {
        timeout(self.to_rpi_us, self.timeout_multiplier)
    }
}

/// Connection timeout: RPI × 4 << multiplier (multiplier 0 to 7).
pub fn timeout(rpi_us: u32, multiplier: u8) -> Duration {
    Duration::from_micros(u64::from(rpi_us) * u64::from(timeout_factor(multiplier)))
}

/// How many RPIs the connection timeout is: 4 << multiplier (multiplier 0 to 7).
pub fn timeout_factor(multiplier: u8) -> u32 {
    4 << multiplier.min(7)
}

/// Serial, vendor and originator serial: what Forward_Close and duplicate checks compare.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Triad {
    pub serial: u16,
    pub vendor: u16,
    pub originator_serial: u32,
}

impl Triad {
    fn encode_into(&self, out: &mut Vec<u8>) {
        out.put_u16(self.serial);
        out.put_u16(self.vendor);
        out.put_u32(self.originator_serial);
    }

    fn decode(r: &mut Reader<'_>) -> Result<Triad, DecodeError> {
        Ok(Triad {
            serial: r.u16("connection serial number")?,
            vendor: r.u16("originator vendor id")?,
            originator_serial: r.u32("originator serial number")?,
        })
    }
}

/// A successful Forward_Open reply.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ForwardOpenReply {
    pub ot_connection: u32,
    pub to_connection: u32,
    pub triad: Triad,
    /// The actual packet intervals, µs.
    pub ot_api_us: u32,
    pub to_api_us: u32,
    pub application: Vec<u8>,
}

impl ForwardOpenReply {
    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(26 + self.application.len());
        out.put_u32(self.ot_connection);
        out.put_u32(self.to_connection);
        self.triad.encode_into(&mut out);
        out.put_u32(self.ot_api_us);
        out.put_u32(self.to_api_us);
        out.put_u8((self.application.len() / 2) as u8);
        out.put_u8(0);
        out.extend_from_slice(&self.application);
        out
    }

    pub fn decode(data: &[u8]) -> Result<ForwardOpenReply, DecodeError> {
        let mut r = Reader::new("Forward_Open reply", data);
        let ot_connection = r.u32("O→T connection id")?;
        let to_connection = r.u32("T→O connection id")?;
        let triad = Triad::decode(&mut r)?;
        let ot_api_us = r.u32("O→T API")?;
        let to_api_us = r.u32("T→O API")?;
        let words = usize::from(r.u8("application reply size")?);
        r.u8("reserved")?;
        let application = r.take(words * 2, "application reply")?.to_vec();
        Ok(ForwardOpenReply {
            ot_connection,
            to_connection,
            triad,
            ot_api_us,
            to_api_us,
            application,
        })
    }
}

/// The data of a failed Forward_Open (or Forward_Close) reply.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ForwardOpenFailure {
    pub triad: Triad,
    /// Words of the connection path not consumed (routing errors).
    pub remaining_path: u8,
}

impl ForwardOpenFailure {
    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(10);
        self.triad.encode_into(&mut out);
        out.put_u8(self.remaining_path);
        out.put_u8(0);
        out
    }
}

/// Forward_Close request data.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ForwardClose {
    pub tick: u8,
    pub timeout_ticks: u8,
    pub triad: Triad,
    pub path: Vec<u8>,
}

impl ForwardClose {
    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(12 + self.path.len());
        out.put_u8(self.tick);
        out.put_u8(self.timeout_ticks);
        self.triad.encode_into(&mut out);
        out.put_u8((self.path.len() / 2) as u8);
        out.put_u8(0);
        out.extend_from_slice(&self.path);
        out
    }

    pub fn decode(data: &[u8]) -> Result<ForwardClose, DecodeError> {
        let mut r = Reader::new("Forward_Close request", data);
        let tick = r.u8("priority/time tick")?;
        let timeout_ticks = r.u8("timeout ticks")?;
        let triad = Triad::decode(&mut r)?;
        let words = usize::from(r.u8("connection path size")?);
        r.u8("reserved")?;
        let path = r.take(words * 2, "connection path")?.to_vec();
        Ok(ForwardClose {
            tick,
            timeout_ticks,
            triad,
            path,
        })
    }
}

/// A successful Forward_Close reply: the triad and no application data.
pub fn encode_forward_close_reply(triad: &Triad) -> Vec<u8> {
    let mut out = Vec::with_capacity(10);
    triad.encode_into(&mut out);
    out.put_u8(0);
    out.put_u8(0);
    out
}

/// Connection Manager extended status codes (general status 01h).
pub mod extended {
    pub const CONNECTION_IN_USE: u16 = 0x0100;
    pub const TRANSPORT_NOT_SUPPORTED: u16 = 0x0103;
    pub const OWNERSHIP_CONFLICT: u16 = 0x0106;
    pub const CONNECTION_NOT_FOUND: u16 = 0x0107;
    pub const INVALID_CONNECTION_TYPE: u16 = 0x0108;
    pub const INVALID_CONNECTION_SIZE: u16 = 0x0109;
    pub const RPI_NOT_SUPPORTED: u16 = 0x0111;
    pub const OUT_OF_CONNECTIONS: u16 = 0x0113;
    pub const VENDOR_OR_PRODUCT_MISMATCH: u16 = 0x0114;
    pub const DEVICE_TYPE_MISMATCH: u16 = 0x0115;
    pub const REVISION_MISMATCH: u16 = 0x0116;
    pub const INVALID_CONNECTION_POINT: u16 = 0x0117;
    pub const INVALID_CONFIGURATION_PATH: u16 = 0x0118;
    pub const CONNECTION_TIMED_OUT: u16 = 0x0203;
    pub const UNCONNECTED_TIMED_OUT: u16 = 0x0204;
    pub const INVALID_OT_SIZE: u16 = 0x0127;
    pub const INVALID_TO_SIZE: u16 = 0x0128;
    pub const INVALID_SEGMENT: u16 = 0x0315;
}

/// The text of a Connection Manager extended status.
pub fn extended_status_text(code: u16) -> &'static str {
    match code {
        0x0100 => "connection in use or duplicate Forward_Open",
        0x0103 => "transport class and trigger combination not supported",
        0x0106 => "ownership conflict",
        0x0107 => "target connection not found",
        0x0108 => "invalid network connection parameter",
        0x0109 => "invalid connection size",
        0x0110 => "target for connection not configured",
        0x0111 => "RPI not supported",
        0x0113 => "out of connections",
        0x0114 => "vendor id or product code mismatch",
        0x0115 => "device type mismatch",
        0x0116 => "revision mismatch",
        0x0117 => "invalid produced or consumed application path",
        0x0118 => "invalid or inconsistent configuration application path",
        0x0119 => "non-listen only connection not opened",
        0x011A => "target object out of connections",
        0x011B => "RPI is smaller than the production inhibit time",
        0x0126 => "invalid configuration size",
        0x0127 => "invalid O→T connection size",
        0x0128 => "invalid T→O connection size",
        0x0129 => "invalid configuration application path",
        0x012A => "invalid consuming application path",
        0x012B => "invalid producing application path",
        0x0203 => "connection timed out",
        0x0204 => "unconnected request timed out",
        0x0205 => "parameter error in unconnected request service",
        0x0206 => "message too large for unconnected send service",
        0x0301 => "no buffer memory available",
        0x0311 => "invalid port id in route path",
        0x0312 => "invalid link address in route path",
        0x0315 => "invalid segment in connection path",
        _ => "unknown extended status",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pdi_open(large: bool) -> ForwardOpen {
        ForwardOpen {
            large,
            tick: 0x03,
            timeout_ticks: 0xFA,
            ot_connection: 0,
            to_connection: 0x2000_0001,
            serial: 0x1234,
            vendor: 0x026C,
            originator_serial: 0xDD00_0001,
            timeout_multiplier: 3,
            ot_rpi_us: 10_000,
            ot_params: NetworkParams::point_to_point(14),
            to_rpi_us: 10_000,
            to_params: NetworkParams::point_to_point(10),
            transport: TRANSPORT_CLASS1_CYCLIC,
            path: vec![0x20, 0x04, 0x24, 0x64, 0x2C, 0x69, 0x2C, 0x68],
        }
    }

    #[test]
    fn network_parameters_as_eipscanner_and_pycomm3_write_them() {
        // Point-to-point, scheduled, fixed, 14 bytes: 0100 1000 0000 1110.
        assert_eq!(NetworkParams::point_to_point(14).to_u16(), 0x480E);
        // pycomm3's class 3 parameters 4200h + size: point-to-point, low, variable.
        let p = NetworkParams::from_u16(0x4200 | 504);
        assert_eq!(
            (p.kind, p.priority, p.variable, p.size),
            (ConnectionType::PointToPoint, Priority::Low, true, 504)
        );
        assert_eq!(p.to_u16(), 0x4200 | 504);
        let large = NetworkParams::point_to_point(1000);
        assert_eq!(large.to_u32(), 0x4800_03E8);
        assert_eq!(NetworkParams::from_u32(large.to_u32()), large);
    }

    #[test]
    fn forward_open_is_36_bytes_before_the_path() {
        let open = pdi_open(false);
        let bytes = open.encode();
        assert_eq!(bytes.len(), 36 + 8, "EIPScanner's size = 36");
        assert_eq!(bytes[18], 3, "timeout multiplier at 18");
        assert_eq!(&bytes[22..26], &10_000u32.to_le_bytes(), "O→T RPI at 22");
        assert_eq!(&bytes[26..28], &[0x0E, 0x48], "O→T parameters at 26");
        assert_eq!(bytes[34], 0x01, "class 1 cyclic");
        assert_eq!(bytes[35], 4, "path words");
        assert_eq!(ForwardOpen::decode(false, &bytes), Ok(open));
        let large = pdi_open(true);
        let bytes = large.encode();
        assert_eq!(bytes.len(), 40 + 8);
        assert_eq!(ForwardOpen::decode(true, &bytes), Ok(large));
        assert!(ForwardOpen::decode(false, &bytes[..30]).is_err());
    }

    #[test]
    fn timeouts_follow_the_multiplier() {
        assert_eq!(timeout(10_000, 0), Duration::from_millis(40));
        assert_eq!(timeout(10_000, 3), Duration::from_millis(320));
        assert_eq!(pdi_open(false).ot_timeout(), Duration::from_millis(320));
    }

    #[test]
    fn replies_round_trip() {
        let reply = ForwardOpenReply {
            ot_connection: 0x1000_0001,
            to_connection: 0x2000_0001,
            triad: pdi_open(false).triad(),
            ot_api_us: 10_000,
            to_api_us: 10_000,
            application: vec![],
        };
        let bytes = reply.encode();
        assert_eq!(bytes.len(), 26);
        assert_eq!(ForwardOpenReply::decode(&bytes), Ok(reply));
        let close = ForwardClose {
            tick: 3,
            timeout_ticks: 0xFA,
            triad: pdi_open(false).triad(),
            path: vec![0x20, 0x04, 0x24, 0x64, 0x2C, 0x69, 0x2C, 0x68],
        };
        assert_eq!(ForwardClose::decode(&close.encode()), Ok(close));
        assert_eq!(
            encode_forward_close_reply(&pdi_open(false).triad()).len(),
            10
        );
        assert_eq!(extended_status_text(0x0127), "invalid O→T connection size");
    }
}
