//! Where the PDI and the process images sit in a Nanotec drive's Modbus register space, and
//! how values are packed into registers (protocol notes §1.1 to §1.3). This is the one place for
//! Modbus byte and word order.
//!
//! The mapped objects form a byte stream, each object big-endian, without gaps; register n
//! holds stream bytes 2n (high byte) and 2n+1 (low byte). So a 32-bit object has its high
//! word at the lower address, and in register 5999 SetValue3 (stream byte 6) is the high
//! byte and PDI-Cmd (stream byte 7) the low byte.
//!
//! The word order is \[M\] (one public script used low word first, protocol notes §5.12),
//! so it is a setting (`WordOrder`), tested both ways; the default follows Nanotec's
//! "big-endian".

use std::fmt;

use serde::{Deserialize, Serialize};

use crate::od::Address;
use crate::pdi::{RxImage, SetValues, Status, TxImage};

/// PDI RX (master → drive): SetValue1 hi, SetValue1 lo, SetValue2, SetValue3|Cmd.
pub const PDI_RX: u16 = 5996;
/// PDI TX (drive → master): Status, 603Fh, ReturnValue hi, ReturnValue lo.
pub const PDI_TX: u16 = 4996;
/// Registers in each PDI block.
pub const PDI_REGISTERS: u16 = 4;
/// The default TX process image (3602h) starts here, right after the PDI TX block.
pub const TX_IMAGE: u16 = 5000;
/// The default RX process image (3502h) starts here, right after the PDI RX block.
pub const RX_IMAGE: u16 = 6000;
/// The factory TX process image (3602h defaults, NT-3602; protocol notes §1.3): 6041h,
/// dummy 8 bit, 6061h, 6064h, 6044h, 60FDh.
pub const FACTORY_TX_MAP: [u32; 6] = [
    0x6041_0010,
    0x0005_0008,
    0x6061_0008,
    0x6064_0020,
    0x6044_0010,
    0x60FD_0020,
];
/// NanoJ outputs 2500h:01..20h, 32 × i32, read only (N5/CL4-E numbering, protocol notes §5.15).
pub const NANOJ_OUTPUTS: u16 = 2000;
/// NanoJ inputs 2400h:01..20h, 32 × i32, write only.
pub const NANOJ_INPUTS: u16 = 3000;
/// Registers of each NanoJ block (32 values of 2 registers).
pub const NANOJ_REGISTERS: u16 = 64;

/// Which half of a 32-bit value comes first.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum WordOrder {
    /// High word at the lower address (Nanotec: big-endian).
    #[default]
    High,
    /// Low word at the lower address (some gateways and scripts).
    Low,
}

impl WordOrder {
    pub fn name(self) -> &'static str {
        match self {
            WordOrder::High => "high",
            WordOrder::Low => "low",
        }
    }
}

impl fmt::Display for WordOrder {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A 32-bit value as two registers, in address order.
pub fn u32_to_registers(value: u32, order: WordOrder) -> [u16; 2] {
    let (high, low) = ((value >> 16) as u16, value as u16);
    match order {
        WordOrder::High => [high, low],
        WordOrder::Low => [low, high],
    }
}

/// Two registers, in address order, as a 32-bit value.
pub fn registers_to_u32(registers: [u16; 2], order: WordOrder) -> u32 {
    let (high, low) = match order {
        WordOrder::High => (registers[0], registers[1]),
        WordOrder::Low => (registers[1], registers[0]),
    };
    (u32::from(high) << 16) | u32::from(low)
}

/// The PDI RX image as registers 5996..5999.
pub fn rx_to_registers(rx: &RxImage, order: WordOrder) -> [u16; 4] {
    let [a, b] = u32_to_registers(rx.values.value1 as u32, order);
    [
        a,
        b,
        rx.values.value2 as u16,
        (u16::from(rx.values.value3 as u8) << 8) | u16::from(rx.cmd),
    ]
}

/// Registers 5996..5999 as the PDI RX image.
pub fn registers_to_rx(registers: [u16; 4], order: WordOrder) -> RxImage {
    RxImage {
        values: SetValues {
            value1: registers_to_u32([registers[0], registers[1]], order) as i32,
            value2: registers[2] as i16,
            value3: (registers[3] >> 8) as u8 as i8,
        },
        cmd: registers[3] as u8,
    }
}

/// The PDI TX image as registers 4996..4999.
pub fn tx_to_registers(tx: &TxImage, order: WordOrder) -> [u16; 4] {
    let [c, d] = u32_to_registers(tx.return_value as u32, order);
    [tx.status.0, tx.error_code, c, d]
}

/// Registers 4996..4999 as the PDI TX image.
pub fn registers_to_tx(registers: [u16; 4], order: WordOrder) -> TxImage {
    TxImage {
        status: Status(registers[0]),
        error_code: registers[1],
        return_value: registers_to_u32([registers[2], registers[3]], order) as i32,
    }
}

/// One entry of a Modbus process-image mapping (3502h/3602h), `IIIISSLL`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Mapped {
    pub address: Address,
    /// Length in bits: 8, 16 or 32.
    pub bits: u8,
}

impl Mapped {
    pub fn from_entry(entry: u32) -> Option<Mapped> {
        let bits = entry as u8;
        matches!(bits, 8 | 16 | 32).then_some(Mapped {
            address: Address::new((entry >> 16) as u16, (entry >> 8) as u8),
            bits,
        })
    }

    pub fn to_entry(self) -> u32 {
        (u32::from(self.address.index) << 16)
            | (u32::from(self.address.sub) << 8)
            | u32::from(self.bits)
    }

    /// Dummy objects 0002h..0007h fill gaps and carry nothing.
    pub fn is_dummy(self) -> bool {
        (0x0002..=0x0007).contains(&self.address.index)
    }

    pub fn bytes(self) -> usize {
        usize::from(self.bits / 8)
    }
}

/// A process image laid out by a mapping: where each object's bytes sit in the stream.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ImageLayout {
    pub entries: Vec<Mapped>,
}

impl ImageLayout {
    /// The layout of mapping entries (sub 01.. of 3502h/3602h, the first `count`).
    /// Entries that are not 8, 16 or 32 bits wide end the layout.
    pub fn from_entries(entries: &[u32]) -> ImageLayout {
        ImageLayout {
            entries: entries
                .iter()
                .map_while(|e| Mapped::from_entry(*e))
                .collect(),
        }
    }

    pub fn byte_len(&self) -> usize {
        self.entries.iter().map(|e| e.bytes()).sum()
    }

    /// Registers the image occupies (an odd byte count rounds up).
    pub fn register_len(&self) -> usize {
        self.byte_len().div_ceil(2)
    }

    /// Pack object values (raw, as unsigned bits of their width) into registers.
    /// `value_of` gives each mapped object's value; dummies are zero.
    pub fn pack(&self, value_of: impl FnMut(Address) -> u32, order: WordOrder) -> Vec<u16> {
        let mut out = Vec::with_capacity(self.register_len());
        self.pack_into(value_of, order, &mut out);
        out
    }

    /// [`ImageLayout::pack`] onto the end of `out`, allocating nothing else: the simulated
    /// drive's server packs an image on every request. Bytes pair into registers as they
    /// come (an 8-bit object may leave half a register for the next one); an odd byte count
    /// ends with a zero byte.
    pub fn pack_into(
        &self,
        mut value_of: impl FnMut(Address) -> u32,
        order: WordOrder,
        out: &mut Vec<u16>,
    ) {
        let mut half: Option<u8> = None;
        let mut put = |byte: u8, out: &mut Vec<u16>| match half.take() {
            Some(high) => out.push(u16::from_be_bytes([high, byte])),
            None => half = Some(byte),
        };
        for entry in &self.entries {
            let value = if entry.is_dummy() {
                0
            } else {
                value_of(entry.address)
            };
            match entry.bits {
                8 => put(value as u8, out),
                16 => (value as u16)
                    .to_be_bytes()
                    .into_iter()
                    .for_each(|b| put(b, out)),
                _ => {
                    // A 32-bit object: its two words in the configured order.
                    for word in u32_to_registers(value, order) {
                        word.to_be_bytes().into_iter().for_each(|b| put(b, out));
                    }
                }
            }
        }
        if let Some(high) = half {
            out.push(u16::from_be_bytes([high, 0]));
        }
    }

    /// The objects a register write covers: each mapped object whose bytes lie wholly in
    /// `first..first+registers.len()` (registers counted from the image start), with its
    /// value. Partly covered objects are not written (Nanotec asks for aligned access).
    pub fn unpack(&self, first: usize, registers: &[u16], order: WordOrder) -> Vec<(Mapped, u32)> {
        let from = first * 2;
        let to = from + registers.len() * 2;
        let byte_at = |offset: usize| -> u8 {
            let i = offset - from;
            let word = registers[i / 2];
            if i.is_multiple_of(2) {
                (word >> 8) as u8
            } else {
                word as u8
            }
        };
        let mut out = vec![];
        let mut offset = 0;
        for entry in &self.entries {
            let end = offset + entry.bytes();
            if offset >= from && end <= to && !entry.is_dummy() {
                let value = match entry.bits {
                    8 => u32::from(byte_at(offset)),
                    16 => u32::from(u16::from_be_bytes([byte_at(offset), byte_at(offset + 1)])),
                    _ => {
                        let w0 = u16::from_be_bytes([byte_at(offset), byte_at(offset + 1)]);
                        let w1 = u16::from_be_bytes([byte_at(offset + 2), byte_at(offset + 3)]);
                        registers_to_u32([w0, w1], order)
                    }
                };
                out.push((*entry, value));
            }
            offset = end;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pdi::{Action, Command, Opcode};
    use proptest::prelude::*;

    #[test]
    fn od_read_of_3320h_01h_packs_as_the_spec_example() {
        // Protocol notes §1.2 (PDI spec §2.2.5): FC 16 to 5996, 4 registers: 0000 0000 3320 010E.
        let action = Action::OdRead {
            index: 0x3320,
            sub: 1,
        };
        let rx = RxImage::new(action.set_values(), Command::new(Opcode::OdRead));
        assert_eq!(
            rx_to_registers(&rx, WordOrder::High),
            [0x0000, 0x0000, 0x3320, 0x010E]
        );
        // The next OD access needs the toggle: 5999 = 018Eh.
        let again = RxImage { cmd: 0x8E, ..rx };
        assert_eq!(rx_to_registers(&again, WordOrder::High)[3], 0x018E);
    }

    #[test]
    fn set_value1_has_its_high_word_first_by_default() {
        let rx = RxImage::new(
            SetValues {
                value1: 0x0001_86A0, // 100000
                value2: -1,
                value3: -128,
            },
            Command::new(Opcode::MoveAbsolute),
        );
        assert_eq!(
            rx_to_registers(&rx, WordOrder::High),
            [0x0001, 0x86A0, 0xFFFF, 0x8014]
        );
        assert_eq!(
            rx_to_registers(&rx, WordOrder::Low),
            [0x86A0, 0x0001, 0xFFFF, 0x8014]
        );
        for order in [WordOrder::High, WordOrder::Low] {
            assert_eq!(registers_to_rx(rx_to_registers(&rx, order), order), rx);
        }
    }

    #[test]
    fn tx_registers_carry_status_603fh_and_return_value() {
        let tx = registers_to_tx([0x4009, 0x8611, 0xFFFF, 0xFFFE], WordOrder::High);
        assert_eq!(tx.status, Status(0x4009));
        assert_eq!(tx.error_code, 0x8611);
        assert_eq!(tx.return_value, -2);
        assert_eq!(
            tx_to_registers(&tx, WordOrder::High),
            [0x4009, 0x8611, 0xFFFF, 0xFFFE]
        );
        let low = registers_to_tx([0, 0, 0x0000, 0x0001], WordOrder::Low);
        assert_eq!(low.return_value, 0x0001_0000);
    }

    /// 3602h defaults.
    fn default_tx_layout() -> ImageLayout {
        ImageLayout::from_entries(&FACTORY_TX_MAP)
    }

    #[test]
    fn the_default_tx_image_lays_out_as_3602h_says() {
        let layout = default_tx_layout();
        assert_eq!(layout.register_len(), 7);
        let regs = layout.pack(
            |a| match a.index {
                0x6041 => 0x0637,
                0x6061 => 0x01,
                0x6064 => 0x1234_5678,
                0x6044 => 0xFFFF,
                0x60FD => 0x0001_0004,
                _ => 0xEE,
            },
            WordOrder::High,
        );
        // 5000 = 6041h, 5001 = dummy | 6061h (low byte), 5002-5003 = 6064h, 5004 = 6044h,
        // 5005-5006 = 60FDh.
        assert_eq!(
            regs,
            [0x0637, 0x0001, 0x1234, 0x5678, 0xFFFF, 0x0001, 0x0004]
        );
    }

    #[test]
    fn unpack_takes_only_objects_the_write_covers() {
        let layout = default_tx_layout();
        let regs = [0x1234, 0x5678, 0xBEEF];
        let got = layout.unpack(2, &regs, WordOrder::High);
        assert_eq!(
            got,
            vec![
                (Mapped::from_entry(0x6064_0020).unwrap(), 0x1234_5678),
                (Mapped::from_entry(0x6044_0010).unwrap(), 0xBEEF),
            ]
        );
        // A write of one register into the middle of 6064h writes nothing.
        assert!(layout.unpack(3, &[1], WordOrder::High).is_empty());
    }

    proptest! {
        #[test]
        fn pdi_registers_round_trip(regs in proptest::array::uniform4(any::<u16>()), low in any::<bool>()) {
            let order = if low { WordOrder::Low } else { WordOrder::High };
            prop_assert_eq!(rx_to_registers(&registers_to_rx(regs, order), order), regs);
            prop_assert_eq!(tx_to_registers(&registers_to_tx(regs, order), order), regs);
        }

        #[test]
        fn images_round_trip(values in proptest::collection::vec(any::<u32>(), 6), low in any::<bool>()) {
            let order = if low { WordOrder::Low } else { WordOrder::High };
            let layout = default_tx_layout();
            let masked: Vec<u32> = layout
                .entries
                .iter()
                .zip(&values)
                .map(|(e, v)| if e.bits == 32 { *v } else { v & ((1 << e.bits) - 1) })
                .collect();
            let regs = layout.pack(
                |a| layout.entries.iter().position(|e| e.address == a).map_or(0, |i| masked[i]),
                order,
            );
            let back = layout.unpack(0, &regs, order);
            for (entry, value) in back {
                let i = layout.entries.iter().position(|e| *e == entry).unwrap();
                prop_assert_eq!(value, masked[i]);
            }
        }
    }
}
