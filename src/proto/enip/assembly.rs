//! The drive's static assemblies (EtherNet/IP chapter, "Assembly objects";
//! protocol notes §3.7): the PDI set
//! (O→T 105, T→O 104, 8 bytes each) and the Common set (O→T 101, T→O 100, 128 bytes).
//! The two cannot be open at once.
//!
//! The spec's PDI O→T table puts PDI-Cmd at offset 8 after an 8-bit SetValue3 at offset 6,
//! which leaves byte 7 empty and makes the assembly 9 bytes (protocol notes §5.1). The
//! Common table, the "without gaps" rule and the public working code put it at offset 7 in
//! 8 bytes.
//! drivedeck uses offset 7 and keeps offset 8 as an option (`cmd_at=8` in the connection
//! string); the simulated adapter accepts either, told apart by the connection size.

use super::wire::{DecodeError, Reader};
use crate::pdi::{RxImage, TxImage};

/// Which producer/consumer pair carries the process data.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum AssemblySet {
    Pdi,
    Common,
}

/// Where the PDI set's O→T assembly has PDI-Cmd.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum CmdOffset {
    /// Byte 7 of 8: the Common table, the public code (default).
    #[default]
    Seven,
    /// Byte 8 of 9, byte 7 zero: the spec's PDI table as printed.
    Eight,
}

impl CmdOffset {
    pub fn byte(self) -> usize {
        match self {
            CmdOffset::Seven => 7,
            CmdOffset::Eight => 8,
        }
    }
}

pub const PDI_OT: u16 = 105;
pub const PDI_TO: u16 = 104;
pub const COMMON_OT: u16 = 101;
pub const COMMON_TO: u16 = 100;
/// The configuration instance in the connection path. The drive has no configuration
/// assembly (spec); public Nanotec code sends 64h (protocol notes §5.18).
pub const DEFAULT_CONFIG_INSTANCE: u16 = 0x64;
/// The Common assemblies' size.
pub const COMMON_LEN: usize = 128;
pub const NANOJ_OUTPUTS: usize = 23;
pub const NANOJ_INPUTS: usize = 27;

impl AssemblySet {
    /// Consumed by the drive (O→T).
    pub fn ot_instance(self) -> u16 {
        match self {
            AssemblySet::Pdi => PDI_OT,
            AssemblySet::Common => COMMON_OT,
        }
    }

    /// Produced by the drive (T→O).
    pub fn to_instance(self) -> u16 {
        match self {
            AssemblySet::Pdi => PDI_TO,
            AssemblySet::Common => COMMON_TO,
        }
    }

    pub fn ot_len(self, cmd: CmdOffset) -> usize {
        match (self, cmd) {
            (AssemblySet::Pdi, CmdOffset::Seven) => 8,
            (AssemblySet::Pdi, CmdOffset::Eight) => 9,
            (AssemblySet::Common, _) => COMMON_LEN,
        }
    }

    pub fn to_len(self) -> usize {
        match self {
            AssemblySet::Pdi => 8,
            AssemblySet::Common => COMMON_LEN,
        }
    }

    /// The set a pair of connection points names.
    pub fn from_points(ot: u16, to: u16) -> Option<AssemblySet> {
        match (ot, to) {
            (PDI_OT, PDI_TO) => Some(AssemblySet::Pdi),
            (COMMON_OT, COMMON_TO) => Some(AssemblySet::Common),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            AssemblySet::Pdi => "PDI set (assemblies 105/104)",
            AssemblySet::Common => "Common set (assemblies 101/100)",
        }
    }
}

/// The PDI set's O→T assembly.
pub fn encode_pdi_ot(rx: &RxImage, cmd: CmdOffset) -> Vec<u8> {
    let image = rx.to_bytes();
    match cmd {
        CmdOffset::Seven => image.to_vec(),
        CmdOffset::Eight => {
            let mut out = image[..7].to_vec();
            out.push(0);
            out.push(image[7]);
            out
        }
    }
}

pub fn decode_pdi_ot(bytes: &[u8], cmd: CmdOffset) -> Result<RxImage, DecodeError> {
    let want = AssemblySet::Pdi.ot_len(cmd);
    if bytes.len() != want {
        return Err(DecodeError::invalid(
            "PDI O→T assembly",
            format!("{} bytes, {want} expected", bytes.len()),
        ));
    }
    let mut image = [0u8; 8];
    image[..7].copy_from_slice(&bytes[..7]);
    image[7] = bytes[cmd.byte()];
    RxImage::from_bytes(&image).map_err(|e| DecodeError::invalid("PDI O→T assembly", e))
}

/// The Common set's T→O assembly (assembly 100): what the drive reports.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CommonIn {
    /// Offsets 0 to 7: 2292h:01, 603Fh, 2292h:02.
    pub tx: TxImage,
    /// 8: 6064h Position Actual Value
    pub position: i32,
    /// 12: 606Ch Velocity Actual Value
    pub velocity: i32,
    /// 16: 60FDh Digital Inputs
    pub digital_inputs: u32,
    /// 20: 6077h Torque Actual Value
    pub torque: i16,
    /// 22: 3220h:01 Analog Input 1
    pub analog_input: i16,
    /// 24: 60F4h Following Error Actual Value
    pub following_error: i32,
    /// 28 to 116: 2500h:01 to 2500h:17h, NanoJ outputs #1 to #23
    pub nanoj_outputs: [i32; NANOJ_OUTPUTS],
}

impl CommonIn {
    pub fn encode(&self) -> [u8; COMMON_LEN] {
        let mut out = [0u8; COMMON_LEN];
        out[0..8].copy_from_slice(&self.tx.to_bytes());
        out[8..12].copy_from_slice(&self.position.to_le_bytes());
        out[12..16].copy_from_slice(&self.velocity.to_le_bytes());
        out[16..20].copy_from_slice(&self.digital_inputs.to_le_bytes());
        out[20..22].copy_from_slice(&self.torque.to_le_bytes());
        out[22..24].copy_from_slice(&self.analog_input.to_le_bytes());
        out[24..28].copy_from_slice(&self.following_error.to_le_bytes());
        for (i, v) in self.nanoj_outputs.iter().enumerate() {
            out[28 + 4 * i..32 + 4 * i].copy_from_slice(&v.to_le_bytes());
        }
        out
    }

    pub fn decode(bytes: &[u8]) -> Result<CommonIn, DecodeError> {
        if bytes.len() != COMMON_LEN {
            return Err(DecodeError::invalid(
                "Common T→O assembly",
                format!("{} bytes, {COMMON_LEN} expected", bytes.len()),
            ));
        }
        let tx = TxImage::from_bytes(&bytes[0..8])
            .map_err(|e| DecodeError::invalid("Common T→O assembly", e))?;
        let mut r = Reader::new("Common T→O assembly", &bytes[8..]);
        let position = r.i32("6064h")?;
        let velocity = r.i32("606Ch")?;
        let digital_inputs = r.u32("60FDh")?;
        let torque = r.i16("6077h")?;
        let analog_input = r.i16("3220h:01")?;
        let following_error = r.i32("60F4h")?;
        let mut nanoj_outputs = [0i32; NANOJ_OUTPUTS];
        for v in nanoj_outputs.iter_mut() {
            *v = r.i32("2500h")?;
        }
        Ok(CommonIn {
            tx,
            position,
            velocity,
            digital_inputs,
            torque,
            analog_input,
            following_error,
            nanoj_outputs,
        })
    }
}

/// The Common set's O→T assembly (assembly 101): what the scanner commands.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CommonOut {
    /// Offsets 0 to 7: 2291h:01 to :04.
    pub rx: RxImage,
    /// 8: 60FEh:01 Digital Outputs
    pub digital_outputs: u32,
    /// 12 to 116: 2400h:01 to 2400h:1Bh, NanoJ inputs #1 to #27
    pub nanoj_inputs: [i32; NANOJ_INPUTS],
}

impl CommonOut {
    pub fn encode(&self) -> [u8; COMMON_LEN] {
        let mut out = [0u8; COMMON_LEN];
        out[0..8].copy_from_slice(&self.rx.to_bytes());
        out[8..12].copy_from_slice(&self.digital_outputs.to_le_bytes());
        for (i, v) in self.nanoj_inputs.iter().enumerate() {
            out[12 + 4 * i..16 + 4 * i].copy_from_slice(&v.to_le_bytes());
        }
        out
    }

    pub fn decode(bytes: &[u8]) -> Result<CommonOut, DecodeError> {
        if bytes.len() != COMMON_LEN {
            return Err(DecodeError::invalid(
                "Common O→T assembly",
                format!("{} bytes, {COMMON_LEN} expected", bytes.len()),
            ));
        }
        let rx = RxImage::from_bytes(&bytes[0..8])
            .map_err(|e| DecodeError::invalid("Common O→T assembly", e))?;
        let mut r = Reader::new("Common O→T assembly", &bytes[8..]);
        let digital_outputs = r.u32("60FEh:01")?;
        let mut nanoj_inputs = [0i32; NANOJ_INPUTS];
        for v in nanoj_inputs.iter_mut() {
            *v = r.i32("2400h")?;
        }
        Ok(CommonOut {
            rx,
            digital_outputs,
            nanoj_inputs,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pdi::{Command, Opcode, SetValues, Status};

    fn rx() -> RxImage {
        RxImage::new(
            SetValues {
                value1: 2000,
                value2: 200,
                value3: 0,
            },
            Command::new(Opcode::MoveAbsolute),
        )
    }

    #[test]
    fn the_pdi_ot_assembly_with_the_command_at_7_or_8() {
        let seven = encode_pdi_ot(&rx(), CmdOffset::Seven);
        assert_eq!(seven, [0xD0, 0x07, 0, 0, 0xC8, 0x00, 0x00, 0x14]);
        let eight = encode_pdi_ot(&rx(), CmdOffset::Eight);
        assert_eq!(eight, [0xD0, 0x07, 0, 0, 0xC8, 0x00, 0x00, 0x00, 0x14]);
        assert_eq!(decode_pdi_ot(&seven, CmdOffset::Seven), Ok(rx()));
        assert_eq!(decode_pdi_ot(&eight, CmdOffset::Eight), Ok(rx()));
        assert!(decode_pdi_ot(&seven, CmdOffset::Eight).is_err());
        assert_eq!(AssemblySet::from_points(105, 104), Some(AssemblySet::Pdi));
        assert_eq!(
            AssemblySet::from_points(101, 100),
            Some(AssemblySet::Common)
        );
        assert_eq!(AssemblySet::from_points(105, 100), None);
    }

    #[test]
    fn every_common_t_to_o_field_at_the_offset_the_spec_gives() {
        let mut nanoj_outputs = [0i32; NANOJ_OUTPUTS];
        for (i, v) in nanoj_outputs.iter_mut().enumerate() {
            *v = 0x0100 + i as i32;
        }
        let input = CommonIn {
            tx: TxImage {
                status: Status(0x1637),
                error_code: 0x3100,
                return_value: -5,
            },
            position: 0x0A0B_0C0D,
            velocity: -200,
            digital_inputs: 0x0003_0001,
            torque: -123,
            analog_input: 512,
            following_error: 17,
            nanoj_outputs,
        };
        let b = input.encode();
        let at = |o: usize, n: usize| b[o..o + n].to_vec();
        assert_eq!(at(0, 2), 0x1637u16.to_le_bytes());
        assert_eq!(at(2, 2), 0x3100u16.to_le_bytes());
        assert_eq!(at(4, 4), (-5i32).to_le_bytes());
        assert_eq!(at(8, 4), 0x0A0B_0C0Di32.to_le_bytes());
        assert_eq!(at(12, 4), (-200i32).to_le_bytes());
        assert_eq!(at(16, 4), 0x0003_0001u32.to_le_bytes());
        assert_eq!(at(20, 2), (-123i16).to_le_bytes());
        assert_eq!(at(22, 2), 512i16.to_le_bytes());
        assert_eq!(at(24, 4), 17i32.to_le_bytes());
        assert_eq!(at(28, 4), 0x0100i32.to_le_bytes(), "2500h:01 at 28");
        assert_eq!(at(116, 4), 0x0116i32.to_le_bytes(), "2500h:17h at 116");
        assert_eq!(at(120, 8), [0; 8], "reserved");
        assert_eq!(CommonIn::decode(&b), Ok(input));
        assert!(CommonIn::decode(&b[..127]).is_err());
    }

    #[test]
    fn every_common_o_to_t_field_at_the_offset_the_spec_gives() {
        let mut nanoj_inputs = [0i32; NANOJ_INPUTS];
        for (i, v) in nanoj_inputs.iter_mut().enumerate() {
            *v = -(i as i32) - 1;
        }
        let out = CommonOut {
            rx: rx(),
            digital_outputs: 0x0001_0000,
            nanoj_inputs,
        };
        let b = out.encode();
        assert_eq!(&b[0..8], &[0xD0, 0x07, 0, 0, 0xC8, 0x00, 0x00, 0x14]);
        assert_eq!(&b[8..12], &0x0001_0000u32.to_le_bytes());
        assert_eq!(&b[12..16], &(-1i32).to_le_bytes(), "2400h:01 at 12");
        assert_eq!(&b[116..120], &(-27i32).to_le_bytes(), "2400h:1Bh at 116");
        assert_eq!(&b[120..128], &[0; 8]);
        assert_eq!(CommonOut::decode(&b), Ok(out));
    }
}
