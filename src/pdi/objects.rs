//! The PDI images as objects of the drive's dictionary (PDI spec §3): the RX image is
//! 2291h "PDI input" sub 01..04 (SetValue1 i32, SetValue2 i16, SetValue3 i8, PDI-Cmd), the TX
//! image 2292h:01 "PDI-Status", 603Fh "error code" and 2292h:02 "PDI-ReturnValue". The
//! CANopen PDO mapping, the explicit EtherNet/IP and SDO paths and the simulated drive all
//! take the layout from here.

use std::ops::Range;

use super::{RxImage, TxImage};

/// 2291h, PDI input: the RX image (set values and command) as objects.
pub const PDI_INPUT: u16 = 0x2291;
/// 2292h, PDI output: the TX image's status and return value as objects.
pub const PDI_OUTPUT: u16 = 0x2292;

/// One field of an 8-byte PDI image as an object.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageObject {
    pub index: u16,
    pub sub: u8,
    /// Its width: 8, 16 or 32 bits.
    pub bits: u8,
    pub signed: bool,
    /// Where it starts in the image (little-endian, as in PDOs and assemblies).
    pub offset: usize,
    pub name: &'static str,
}

impl ImageObject {
    /// Its bytes in the image.
    pub fn bytes(self) -> Range<usize> {
        self.offset..self.offset + usize::from(self.bits / 8)
    }

    /// Its value in `image`, sign-extended where it is signed.
    pub fn value_in(self, image: &[u8; 8]) -> i64 {
        let mut raw = [0u8; 4];
        let bytes = &image[self.bytes()];
        raw[..bytes.len()].copy_from_slice(bytes);
        let unsigned = u32::from_le_bytes(raw);
        match (self.signed, self.bits) {
            (true, 8) => i64::from(unsigned as u8 as i8),
            (true, 16) => i64::from(unsigned as u16 as i16),
            (true, _) => i64::from(unsigned as i32),
            (false, _) => i64::from(unsigned),
        }
    }

    /// Put `value` (cut to its width) into `image`.
    pub fn put_in(self, image: &mut [u8; 8], value: i64) {
        let bytes = (value as u32).to_le_bytes();
        let range = self.bytes();
        let len = range.len();
        image[range].copy_from_slice(&bytes[..len]);
    }
}

const fn object(
    index: u16,
    sub: u8,
    bits: u8,
    signed: bool,
    offset: usize,
    name: &'static str,
) -> ImageObject {
    ImageObject {
        index,
        sub,
        bits,
        signed,
        offset,
        name,
    }
}

/// The RX image, master → drive, in image order. The command byte goes last on purpose:
/// written on its own (SDO, explicit messages), it is what starts the command.
pub const RX_OBJECTS: [ImageObject; 4] = [
    object(PDI_INPUT, 0x01, 32, true, 0, "SetValue1"),
    object(PDI_INPUT, 0x02, 16, true, 4, "SetValue2"),
    object(PDI_INPUT, 0x03, 8, true, 6, "SetValue3"),
    object(PDI_INPUT, 0x04, 8, true, 7, "PDI-Cmd"),
];

/// The TX image, drive → master, in image order.
pub const TX_OBJECTS: [ImageObject; 3] = [
    object(PDI_OUTPUT, 0x01, 16, true, 0, "PDI-Status"),
    object(0x603F, 0x00, 16, false, 2, "error code"),
    object(PDI_OUTPUT, 0x02, 32, true, 4, "PDI-ReturnValue"),
];

impl RxImage {
    /// Each RX object with its value in this image.
    pub fn object_values(&self) -> [(ImageObject, i64); 4] {
        let bytes = self.to_bytes();
        RX_OBJECTS.map(|o| (o, o.value_in(&bytes)))
    }

    /// The image the RX objects' values make (each cut to its width).
    pub fn from_object_values(mut value: impl FnMut(ImageObject) -> i64) -> RxImage {
        let mut bytes = [0u8; 8];
        for o in RX_OBJECTS {
            o.put_in(&mut bytes, value(o));
        }
        // Eight bytes always make an RX image.
        RxImage::from_bytes(&bytes).unwrap_or_default()
    }
}

impl TxImage {
    /// Each TX object with its value in this image.
    pub fn object_values(&self) -> [(ImageObject, i64); 3] {
        let bytes = self.to_bytes();
        TX_OBJECTS.map(|o| (o, o.value_in(&bytes)))
    }

    /// The image the TX objects' values make (each cut to its width).
    pub fn from_object_values(mut value: impl FnMut(ImageObject) -> i64) -> TxImage {
        let mut bytes = [0u8; 8];
        for o in TX_OBJECTS {
            o.put_in(&mut bytes, value(o));
        }
        TxImage::from_bytes(&bytes).unwrap_or_default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pdi::{Command, Opcode, SetValues, Status};

    #[test]
    fn the_objects_tile_the_images() {
        for objects in [&RX_OBJECTS[..], &TX_OBJECTS[..]] {
            let mut next = 0;
            for o in objects {
                assert_eq!(o.offset, next, "{o:?}");
                next = o.bytes().end;
            }
            assert_eq!(next, 8);
        }
    }

    #[test]
    fn images_round_trip_through_their_objects() {
        let rx = RxImage::new(
            SetValues {
                value1: -2000,
                value2: -300,
                value3: -5,
            },
            Command {
                opcode: Opcode::MoveRelative,
                halt: true,
                toggle: true,
            },
        );
        let values = rx.object_values();
        assert_eq!(values[0].1, -2000);
        assert_eq!(values[1].1, -300);
        assert_eq!(values[2].1, -5);
        assert_eq!(values[3].1, i64::from(rx.cmd as i8));
        assert_eq!(
            RxImage::from_object_values(|o| values[usize::from(o.sub) - 1].1),
            rx
        );
        let tx = TxImage {
            status: Status(0x8421),
            error_code: 0xFF01,
            return_value: -7,
        };
        let values = tx.object_values();
        assert_eq!(values[1].1, 0xFF01);
        assert_eq!(values[2].1, -7);
        let mut iter = values.iter();
        assert_eq!(
            TxImage::from_object_values(|_| iter.next().map_or(0, |v| v.1)),
            tx
        );
    }
}
