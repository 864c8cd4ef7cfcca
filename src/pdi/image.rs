//! The two 8-byte PDI process images of spec section 3, in the little-endian byte order of
//! CANopen PDOs and EtherNet/IP assemblies. (Modbus packs the same fields into big-endian
//! registers; that codec lives with the Modbus link.)
//!
//! ```text
//! RX (master → drive): | SetValue1 i32 | SetValue2 i16 | SetValue3 i8 | Cmd i8 |
//! TX (drive → master): | Status i16    | 603Fh u16     | ReturnValue i32      |
//! ```

use super::{Command, Error, SetValues, Status};

/// The RX process image: 2291h:01..04.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct RxImage {
    pub values: SetValues,
    /// The raw PDI-Cmd byte; decode it with [`RxImage::command`].
    pub cmd: u8,
}

impl RxImage {
    pub const LEN: usize = 8;

    pub fn new(values: SetValues, command: Command) -> Self {
        Self {
            values,
            cmd: command.to_byte(),
        }
    }

    pub fn command(&self) -> Result<Command, Error> {
        Command::from_byte(self.cmd)
    }

    pub fn to_bytes(&self) -> [u8; 8] {
        let mut out = [0u8; 8];
        out[0..4].copy_from_slice(&self.values.value1.to_le_bytes());
        out[4..6].copy_from_slice(&self.values.value2.to_le_bytes());
        out[6] = self.values.value3 as u8;
        out[7] = self.cmd;
        out
    }

    pub fn from_bytes(bytes: &[u8]) -> Result<Self, Error> {
        let b: &[u8; 8] = bytes.try_into().map_err(|_| Error::ImageLength {
            image: "RX",
            got: bytes.len(),
        })?;
        Ok(Self {
            values: SetValues {
                value1: i32::from_le_bytes([b[0], b[1], b[2], b[3]]),
                value2: i16::from_le_bytes([b[4], b[5]]),
                value3: b[6] as i8,
            },
            cmd: b[7],
        })
    }
}

/// The TX process image: 2292h:01, 603Fh, 2292h:02.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct TxImage {
    pub status: Status,
    /// 603Fh: the code of the active fault or warning (0 = none).
    pub error_code: u16,
    /// PDI-ReturnValue: the mode's actual value, an OD-Read result or an error code.
    pub return_value: i32,
}

impl TxImage {
    pub const LEN: usize = 8;

    pub fn to_bytes(&self) -> [u8; 8] {
        let mut out = [0u8; 8];
        out[0..2].copy_from_slice(&self.status.0.to_le_bytes());
        out[2..4].copy_from_slice(&self.error_code.to_le_bytes());
        out[4..8].copy_from_slice(&self.return_value.to_le_bytes());
        out
    }

    pub fn from_bytes(bytes: &[u8]) -> Result<Self, Error> {
        let b: &[u8; 8] = bytes.try_into().map_err(|_| Error::ImageLength {
            image: "TX",
            got: bytes.len(),
        })?;
        Ok(Self {
            status: Status(u16::from_le_bytes([b[0], b[1]])),
            error_code: u16::from_le_bytes([b[2], b[3]]),
            return_value: i32::from_le_bytes([b[4], b[5], b[6], b[7]]),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pdi::{Opcode, StatusBit};
    use proptest::prelude::*;

    #[test]
    fn rx_image_of_the_absolute_move_example() {
        // Spec 2.2.10: position 2000, speed 200, command 20.
        let image = RxImage::new(
            SetValues {
                value1: 2000,
                value2: 200,
                value3: 0,
            },
            Command::new(Opcode::MoveAbsolute),
        );
        assert_eq!(image.to_bytes(), [0xD0, 0x07, 0, 0, 0xC8, 0, 0, 20]);
    }

    #[test]
    fn rx_image_of_the_od_read_example() {
        // Spec 2.2.5: 3320h:01h, command 14.
        let image = RxImage {
            values: SetValues {
                value1: 0,
                value2: 0x3320,
                value3: 1,
            },
            cmd: 14,
        };
        assert_eq!(image.to_bytes(), [0, 0, 0, 0, 0x20, 0x33, 0x01, 0x0E]);
    }

    #[test]
    fn tx_image_is_little_endian() {
        let image = TxImage {
            status: Status(0).with(StatusBit::AutosetupDone, true),
            error_code: 0x8611,
            return_value: -2,
        };
        // Autosetup = bit 12 = bit 4 of byte 1 (as EIP-IO reads it).
        assert_eq!(
            image.to_bytes(),
            [0x00, 0x10, 0x11, 0x86, 0xFE, 0xFF, 0xFF, 0xFF]
        );
    }

    #[test]
    fn wrong_lengths_are_errors() {
        assert_eq!(
            RxImage::from_bytes(&[0; 7]),
            Err(Error::ImageLength {
                image: "RX",
                got: 7
            })
        );
        assert_eq!(
            TxImage::from_bytes(&[0; 9]),
            Err(Error::ImageLength {
                image: "TX",
                got: 9
            })
        );
    }

    proptest! {
        #[test]
        fn rx_bytes_round_trip(bytes in proptest::array::uniform8(any::<u8>())) {
            let image = RxImage::from_bytes(&bytes).unwrap();
            prop_assert_eq!(image.to_bytes(), bytes);
        }

        #[test]
        fn tx_bytes_round_trip(bytes in proptest::array::uniform8(any::<u8>())) {
            let image = TxImage::from_bytes(&bytes).unwrap();
            prop_assert_eq!(image.to_bytes(), bytes);
        }

        #[test]
        fn decoders_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..32)) {
            let _ = RxImage::from_bytes(&bytes);
            let _ = TxImage::from_bytes(&bytes);
            if let Some(b) = bytes.first() {
                let _ = Command::from_byte(*b);
            }
        }
    }
}
