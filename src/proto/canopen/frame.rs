//! A classic CAN frame, as every bus back end carries it.

use std::fmt;

/// A CAN 2.0 frame: 11-bit (or 29-bit extended) identifier, up to 8 data bytes.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct CanFrame {
    id: u32,
    extended: bool,
    rtr: bool,
    len: u8,
    data: [u8; 8],
}

/// A frame that cannot exist.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    #[error("CAN identifier {id:X}h does not fit {bits} bits")]
    Identifier { id: u32, bits: u8 },
    #[error("a CAN frame carries at most 8 data bytes, not {0}")]
    TooLong(usize),
}

impl CanFrame {
    /// A data frame with an 11-bit identifier (all of CANopen).
    pub fn new(id: u16, data: &[u8]) -> Result<CanFrame, FrameError> {
        Self::with(u32::from(id), false, false, data)
    }

    /// A standard data frame that cannot be refused: the identifier is masked to 11 bits and
    /// at most the first 8 bytes are taken. For frames built from constants and node ids.
    pub fn standard(id: u16, data: &[u8]) -> CanFrame {
        let data = &data[..data.len().min(8)];
        let mut bytes = [0u8; 8];
        bytes[..data.len()].copy_from_slice(data);
        CanFrame {
            id: u32::from(id & 0x7FF),
            extended: false,
            rtr: false,
            len: data.len() as u8,
            data: bytes,
        }
    }

    /// Any frame.
    pub fn with(id: u32, extended: bool, rtr: bool, data: &[u8]) -> Result<CanFrame, FrameError> {
        let bits = if extended { 29 } else { 11 };
        if id >> bits != 0 {
            return Err(FrameError::Identifier { id, bits });
        }
        if data.len() > 8 {
            return Err(FrameError::TooLong(data.len()));
        }
        let mut bytes = [0u8; 8];
        if !rtr {
            // A remote frame carries no data: nothing hidden may make two of them differ.
            bytes[..data.len()].copy_from_slice(data);
        }
        Ok(CanFrame {
            id,
            extended,
            rtr,
            len: data.len() as u8,
            data: bytes,
        })
    }

    /// A remote request frame asking for `len` bytes.
    pub fn remote(id: u16, len: u8) -> Result<CanFrame, FrameError> {
        if len > 8 {
            return Err(FrameError::TooLong(usize::from(len)));
        }
        let mut frame = Self::with(u32::from(id), false, true, &[])?;
        frame.len = len;
        Ok(frame)
    }

    pub fn id(&self) -> u32 {
        self.id
    }

    /// The 11-bit CANopen COB-ID, or `None` for an extended frame.
    pub fn cob_id(&self) -> Option<u16> {
        (!self.extended).then_some(self.id as u16)
    }

    pub fn is_extended(&self) -> bool {
        self.extended
    }

    pub fn is_remote(&self) -> bool {
        self.rtr
    }

    /// The data length code (for a remote frame: the length asked for).
    pub fn len(&self) -> usize {
        usize::from(self.len)
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The data bytes (empty for a remote frame).
    pub fn data(&self) -> &[u8] {
        if self.rtr {
            &[]
        } else {
            &self.data[..usize::from(self.len)]
        }
    }
}

impl fmt::Debug for CanFrame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{self}")
    }
}

/// candump style: `601#4018100100000000`, `123#R2`, `12345678#00`.
impl fmt::Display for CanFrame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.extended {
            write!(f, "{:08X}#", self.id)?;
        } else {
            write!(f, "{:03X}#", self.id)?;
        }
        if self.rtr {
            return write!(f, "R{}", self.len);
        }
        for b in self.data() {
            write!(f, "{b:02X}")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_check_their_limits() {
        assert!(CanFrame::new(0x7FF, &[0; 8]).is_ok());
        assert_eq!(
            CanFrame::with(0x800, false, false, &[]),
            Err(FrameError::Identifier {
                id: 0x800,
                bits: 11
            })
        );
        assert_eq!(CanFrame::new(1, &[0; 9]), Err(FrameError::TooLong(9)));
        assert!(CanFrame::with(0x1FFF_FFFF, true, false, &[1]).is_ok());
    }

    #[test]
    fn a_standard_frame_masks_and_truncates_like_new_would_refuse() {
        assert_eq!(
            CanFrame::standard(0x601, &[1, 2]),
            CanFrame::new(0x601, &[1, 2]).unwrap()
        );
        let masked = CanFrame::standard(0xF81, &[0; 10]);
        assert_eq!(masked.cob_id(), Some(0x781));
        assert_eq!(masked.data(), &[0; 8]);
    }

    #[test]
    fn frames_print_as_candump() {
        let sdo = CanFrame::new(0x601, &[0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0]).unwrap();
        assert_eq!(sdo.to_string(), "601#4018100100000000");
        assert_eq!(CanFrame::remote(0x181, 8).unwrap().to_string(), "181#R8");
        assert_eq!(sdo.cob_id(), Some(0x601));
        assert_eq!(sdo.data(), &[0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0]);
    }
}
