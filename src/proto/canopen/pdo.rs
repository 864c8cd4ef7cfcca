//! PDOs (CiA 301; protocol notes §2.3): mapping entries, packing values into a PDO payload
//! and back, communication parameters, and the SDO writes that configure a PDO in the order
//! CiA 301 prescribes. Sans-IO: the caller performs the writes with its SDO client.
//!
//! ```text
//! mapping entry (16xxh/1Axxh:01..)   IIII SS LL   index, sub-index, length in bits
//! RPDO n: 1400h+n-1 communication, 1600h+n-1 mapping
//! TPDO n: 1800h+n-1 communication, 1A00h+n-1 mapping
//! ```
//!
//! Values are packed little-endian, one after the other, in mapping order (protocol notes §2.3).
//! drivedeck maps whole bytes only (lengths 8, 16, …, 64 bits) and at most 64 bits in all
//! (a classic CAN frame).

use std::fmt;

use super::nmt::cob;
use crate::pdi::{ImageObject, RX_OBJECTS, TX_OBJECTS};

/// The most bits a classic CAN PDO carries.
pub const MAX_BITS: u32 = 64;

/// COB-ID bit 31: the PDO is invalid (does not exist / disabled) (CiA 301).
pub const COB_INVALID: u32 = 1 << 31;
/// COB-ID bit 30: no RTR allowed on this PDO (CiA 301).
pub const COB_NO_RTR: u32 = 1 << 30;
/// COB-ID bit 29: 29-bit identifier.
pub const COB_EXTENDED: u32 = 1 << 29;

/// One mapping entry: which object, and how many of its bits, go into the PDO.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MappedObject {
    pub index: u16,
    pub sub: u8,
    pub bits: u8,
}

impl MappedObject {
    pub const fn new(index: u16, sub: u8, bits: u8) -> Self {
        Self { index, sub, bits }
    }

    /// A PDI image object as a mapping entry.
    pub const fn of(object: ImageObject) -> Self {
        Self::new(object.index, object.sub, object.bits)
    }

    /// The entry as written to 16xxh/1Axxh: `IIIISSLL`.
    pub const fn to_u32(self) -> u32 {
        ((self.index as u32) << 16) | ((self.sub as u32) << 8) | self.bits as u32
    }

    pub const fn from_u32(raw: u32) -> Self {
        Self {
            index: (raw >> 16) as u16,
            sub: (raw >> 8) as u8,
            bits: raw as u8,
        }
    }

    /// The number of whole bytes the entry takes (its bits rounded down).
    pub const fn bytes(self) -> usize {
        self.bits as usize / 8
    }
}

impl From<u32> for MappedObject {
    fn from(raw: u32) -> Self {
        Self::from_u32(raw)
    }
}

impl From<MappedObject> for u32 {
    fn from(entry: MappedObject) -> Self {
        entry.to_u32()
    }
}

/// `2291h:01h (32 bits)`.
impl fmt::Display for MappedObject {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{:04X}h:{:02X}h ({} bits)",
            self.index, self.sub, self.bits
        )
    }
}

/// The RX PDO the PDI needs (PDI spec §3): its RX image's objects, SetValue1 i32,
/// SetValue2 i16, SetValue3 i8, PDI-Cmd — 8 bytes, master → drive.
pub const PDI_RX: [MappedObject; 4] = [
    MappedObject::of(RX_OBJECTS[0]),
    MappedObject::of(RX_OBJECTS[1]),
    MappedObject::of(RX_OBJECTS[2]),
    MappedObject::of(RX_OBJECTS[3]),
];

/// The TX PDO the PDI needs (PDI spec §3): its TX image's objects, PDI-Status, error
/// code 603Fh, PDI-ReturnValue — 8 bytes, drive → master.
pub const PDI_TX: [MappedObject; 3] = [
    MappedObject::of(TX_OBJECTS[0]),
    MappedObject::of(TX_OBJECTS[1]),
    MappedObject::of(TX_OBJECTS[2]),
];

/// Receive (RPDO, master → node) or transmit (TPDO, node → master), seen from the node.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PdoKind {
    Receive,
    Transmit,
}

impl PdoKind {
    /// "RPDO" or "TPDO".
    pub fn name(self) -> &'static str {
        match self {
            PdoKind::Receive => "RPDO",
            PdoKind::Transmit => "TPDO",
        }
    }

    /// The communication parameter object of PDO `n` (1..=512): 1400h+n-1 / 1800h+n-1.
    pub fn comm_index(self, n: u16) -> Result<u16, PdoError> {
        let base = match self {
            PdoKind::Receive => 0x1400,
            PdoKind::Transmit => 0x1800,
        };
        Ok(base + check_number(n)? - 1)
    }

    /// The mapping parameter object of PDO `n` (1..=512): 1600h+n-1 / 1A00h+n-1.
    pub fn mapping_index(self, n: u16) -> Result<u16, PdoError> {
        let base = match self {
            PdoKind::Receive => 0x1600,
            PdoKind::Transmit => 0x1A00,
        };
        Ok(base + check_number(n)? - 1)
    }

    /// The COB-ID of the predefined connection set for PDO 1..=4 of a node (protocol notes §2.3).
    pub fn predefined_cob_id(self, n: u16, node: u8) -> Option<u16> {
        let n = u8::try_from(n).ok()?;
        match self {
            PdoKind::Receive => cob::rpdo(n, node),
            PdoKind::Transmit => cob::tpdo(n, node),
        }
    }
}

impl fmt::Display for PdoKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

fn check_number(n: u16) -> Result<u16, PdoError> {
    if (1..=512).contains(&n) {
        Ok(n)
    } else {
        Err(PdoError::Number(n))
    }
}

/// A PDO mapping or payload that cannot be.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum PdoError {
    #[error(
        "{0}: mapped lengths must be whole bytes (8, 16, 24, 32 … 64 bits); drivedeck does not map single bits"
    )]
    NotWholeBytes(MappedObject),
    #[error("the mapping holds {bits} bits; a CAN PDO carries at most {MAX_BITS} bits (8 bytes)")]
    TooLong { bits: u32 },
    #[error("{values} values for {entries} mapped objects")]
    ValueCount { values: usize, entries: usize },
    #[error("{object}: {got} bytes given, the mapping takes {expected}")]
    FieldLength {
        object: MappedObject,
        expected: usize,
        got: usize,
    },
    #[error("{object}: {value} does not fit {} bits", object.bits)]
    OutOfRange { object: MappedObject, value: i128 },
    #[error("the PDO carries {got} bytes, its mapping needs {expected}")]
    ShortPayload { expected: usize, got: usize },
    #[error("PDO number {0} is outside 1..=512")]
    Number(u16),
    #[error(
        "{kind}{n} has no predefined COB-ID (only PDOs 1 to 4 do); give one in the communication parameters"
    )]
    NoCobId { kind: PdoKind, n: u16 },
}

/// Check a mapping and give its length in bytes: whole bytes, at most 64 bits in all.
pub fn mapping_bytes(entries: &[MappedObject]) -> Result<usize, PdoError> {
    let mut bits: u32 = 0;
    for entry in entries {
        if entry.bits == 0 || !entry.bits.is_multiple_of(8) || u32::from(entry.bits) > MAX_BITS {
            return Err(PdoError::NotWholeBytes(*entry));
        }
        bits = bits.saturating_add(u32::from(entry.bits));
    }
    if bits > MAX_BITS {
        return Err(PdoError::TooLong { bits });
    }
    Ok(bits as usize / 8)
}

/// Pack each object's little-endian bytes (exactly `bits / 8` of them) into a payload.
pub fn pack(entries: &[MappedObject], fields: &[&[u8]]) -> Result<Vec<u8>, PdoError> {
    let len = mapping_bytes(entries)?;
    if fields.len() != entries.len() {
        return Err(PdoError::ValueCount {
            values: fields.len(),
            entries: entries.len(),
        });
    }
    let mut out = Vec::with_capacity(len);
    for (entry, field) in entries.iter().zip(fields) {
        if field.len() != entry.bytes() {
            return Err(PdoError::FieldLength {
                object: *entry,
                expected: entry.bytes(),
                got: field.len(),
            });
        }
        out.extend_from_slice(field);
    }
    Ok(out)
}

/// Pack integers, each little-endian in its mapped width. A value must fit the width as a
/// signed or an unsigned number (e.g. -128..=255 for 8 bits); nothing is truncated silently.
pub fn pack_integers(entries: &[MappedObject], values: &[i128]) -> Result<Vec<u8>, PdoError> {
    mapping_bytes(entries)?;
    if values.len() != entries.len() {
        return Err(PdoError::ValueCount {
            values: values.len(),
            entries: entries.len(),
        });
    }
    let mut fields = Vec::with_capacity(entries.len());
    for (entry, &value) in entries.iter().zip(values) {
        let bits = u32::from(entry.bits);
        let min = -(1i128 << (bits - 1));
        let max = (1i128 << bits) - 1;
        if !(min..=max).contains(&value) {
            return Err(PdoError::OutOfRange {
                object: *entry,
                value,
            });
        }
        // Two's complement, low bytes first.
        let bytes = (value as u64).to_le_bytes();
        fields.push(bytes[..entry.bytes()].to_vec());
    }
    let fields: Vec<&[u8]> = fields.iter().map(Vec::as_slice).collect();
    pack(entries, &fields)
}

/// Split a payload into each object's little-endian bytes. A payload longer than the mapping
/// is tolerated (CiA 301 uses the first bytes); a shorter one is an error.
pub fn unpack<'a>(entries: &[MappedObject], payload: &'a [u8]) -> Result<Vec<&'a [u8]>, PdoError> {
    let len = mapping_bytes(entries)?;
    if payload.len() < len {
        return Err(PdoError::ShortPayload {
            expected: len,
            got: payload.len(),
        });
    }
    let mut fields = Vec::with_capacity(entries.len());
    let mut offset = 0;
    for entry in entries {
        let end = offset + entry.bytes();
        fields.push(&payload[offset..end]);
        offset = end;
    }
    Ok(fields)
}

/// Unpack the objects as unsigned integers.
pub fn unpack_unsigned(entries: &[MappedObject], payload: &[u8]) -> Result<Vec<u64>, PdoError> {
    Ok(unpack(entries, payload)?
        .into_iter()
        .map(|field| {
            let mut bytes = [0u8; 8];
            bytes[..field.len()].copy_from_slice(field);
            u64::from_le_bytes(bytes)
        })
        .collect())
}

/// Unpack the objects as signed integers (sign-extended from their width).
pub fn unpack_signed(entries: &[MappedObject], payload: &[u8]) -> Result<Vec<i64>, PdoError> {
    let raw = unpack_unsigned(entries, payload)?;
    Ok(entries
        .iter()
        .zip(raw)
        .map(|(entry, value)| {
            let shift = 64 - u32::from(entry.bits);
            ((value << shift) as i64) >> shift
        })
        .collect())
}

/// The communication parameters 14xxh/18xxh (CiA 301, protocol notes §2.3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PdoComm {
    /// :01, bit 31 = invalid, bit 30 = no RTR. The 11-bit identifier 0 means "the predefined
    /// connection set's COB-ID" in [`configure`] (a PDO can never use 000h, the NMT COB-ID).
    pub cob_id: u32,
    /// :02, 0 = acyclic synchronous, 1-240 = every n-th SYNC, 254/255 = event-driven.
    pub transmission: u8,
    /// :03, in multiples of 100 µs (100 = 10 ms). Only writable while the PDO is invalid.
    pub inhibit_100us: u16,
    /// :05, in ms, 0 = off.
    pub event_ms: u16,
}

impl PdoComm {
    /// Event-driven (255) on the predefined COB-ID: what PDI spec §3.1 recommends for the
    /// PDI, "acyclic with a realistic inhibit time".
    pub fn event_driven(inhibit_100us: u16, event_ms: u16) -> Self {
        Self {
            cob_id: 0,
            transmission: 255,
            inhibit_100us,
            event_ms,
        }
    }

    pub fn is_valid(&self) -> bool {
        self.cob_id & COB_INVALID == 0
    }
}

/// What a transmission type means (CiA 301).
pub fn transmission_text(transmission: u8) -> String {
    match transmission {
        0 => "acyclic synchronous".into(),
        1 => "every SYNC".into(),
        2..=240 => {
            let suffix = match (transmission % 10, transmission % 100) {
                (1, x) if x != 11 => "st",
                (2, x) if x != 12 => "nd",
                (3, x) if x != 13 => "rd",
                _ => "th",
            };
            format!("every {transmission}{suffix} SYNC")
        }
        241..=251 => "reserved".into(),
        252 => "synchronous, RTR only".into(),
        253 => "asynchronous, RTR only".into(),
        254 => "event-driven (manufacturer-specific)".into(),
        255 => "event-driven (device profile)".into(),
    }
}

/// One object write of a configuration procedure, value little-endian.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct SdoWrite {
    pub index: u16,
    pub sub: u8,
    pub data: Vec<u8>,
}

impl SdoWrite {
    pub fn u8(index: u16, sub: u8, value: u8) -> Self {
        Self {
            index,
            sub,
            data: vec![value],
        }
    }

    pub fn u16(index: u16, sub: u8, value: u16) -> Self {
        Self {
            index,
            sub,
            data: value.to_le_bytes().to_vec(),
        }
    }

    pub fn u32(index: u16, sub: u8, value: u32) -> Self {
        Self {
            index,
            sub,
            data: value.to_le_bytes().to_vec(),
        }
    }
}

/// `1A00h:01h = 22920110h`.
impl fmt::Display for SdoWrite {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:04X}h:{:02X}h = ", self.index, self.sub)?;
        for b in self.data.iter().rev() {
            write!(f, "{b:02X}")?;
        }
        f.write_str("h")
    }
}

/// The writes that configure PDO `n` of a node, in the CiA 301 order (protocol notes §2.3):
///
/// 1. COB-ID with bit 31 set (invalid),
/// 2. mapping :00 = 0,
/// 3. the entries :01..,
/// 4. mapping :00 = number of entries,
/// 5. transmission type :02, inhibit time :03, event timer :05 (while invalid),
/// 6. COB-ID with bit 31 cleared.
///
/// When `comm.cob_id` has identifier 0, the predefined COB-ID of `n` and `node` is used (with
/// bit 30 kept from `comm`); Nanotec fixes PDOs 1-4 to it anyway (protocol notes §2.3,
/// \[M\]). The node still has to be started (NMT start, or 1F80h = 08h) before PDOs flow.
pub fn configure(
    kind: PdoKind,
    n: u16,
    node: u8,
    comm: &PdoComm,
    entries: &[MappedObject],
) -> Result<Vec<SdoWrite>, PdoError> {
    mapping_bytes(entries)?;
    let comm_index = kind.comm_index(n)?;
    let mapping_index = kind.mapping_index(n)?;
    let cob_id = if comm.cob_id & (COB_EXTENDED | 0x1FFF_FFFF) == 0 {
        let id = kind
            .predefined_cob_id(n, node)
            .ok_or(PdoError::NoCobId { kind, n })?;
        (comm.cob_id & COB_NO_RTR) | u32::from(id)
    } else {
        comm.cob_id
    };
    // At most 8 entries of whole bytes in 64 bits, so the count fits a u8.
    let count = entries.len() as u8;
    let mut writes = Vec::with_capacity(entries.len() + 7);
    writes.push(SdoWrite::u32(comm_index, 1, cob_id | COB_INVALID));
    writes.push(SdoWrite::u8(mapping_index, 0, 0));
    for (sub, entry) in (1u8..).zip(entries) {
        writes.push(SdoWrite::u32(mapping_index, sub, entry.to_u32()));
    }
    writes.push(SdoWrite::u8(mapping_index, 0, count));
    writes.push(SdoWrite::u8(comm_index, 2, comm.transmission));
    writes.push(SdoWrite::u16(comm_index, 3, comm.inhibit_100us));
    writes.push(SdoWrite::u16(comm_index, 5, comm.event_ms));
    writes.push(SdoWrite::u32(comm_index, 1, cob_id & !COB_INVALID));
    Ok(writes)
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;
    use crate::pdi::{RxImage, SetValues, TxImage};

    #[test]
    fn entries_are_iiiissll() {
        let entry = MappedObject::new(0x6040, 0x00, 16);
        assert_eq!(entry.to_u32(), 0x6040_0010);
        assert_eq!(
            MappedObject::from(0x6060_0008),
            MappedObject::new(0x6060, 0, 8)
        );
        assert_eq!(u32::from(PDI_RX[0]), 0x2291_0120);
        assert_eq!(PDI_TX[1].to_u32(), 0x603F_0010);
        assert_eq!(entry.to_string(), "6040h:00h (16 bits)");
    }

    #[test]
    fn the_pdi_pdos_are_8_bytes_each() {
        assert_eq!(mapping_bytes(&PDI_RX), Ok(8));
        assert_eq!(mapping_bytes(&PDI_TX), Ok(8));
    }

    #[test]
    fn packing_matches_the_pdi_images() {
        let rx = RxImage {
            values: SetValues {
                value1: -2000,
                value2: 0x203B,
                value3: -1,
            },
            cmd: 0x94,
        };
        let packed = pack_integers(&PDI_RX, &[-2000, 0x203B, -1, 0x94]).unwrap();
        assert_eq!(packed, rx.to_bytes());
        assert_eq!(
            unpack_signed(&PDI_RX, &packed).unwrap(),
            vec![-2000, 0x203B, -1, -108]
        );
        assert_eq!(
            unpack_unsigned(&PDI_RX, &packed).unwrap(),
            vec![0xFFFF_F830, 0x203B, 0xFF, 0x94]
        );

        let tx_bytes = [0x37, 0x82, 0x00, 0x23, 0x11, 0x00, 0x09, 0x06];
        let tx = TxImage::from_bytes(&tx_bytes).unwrap();
        assert_eq!(tx.to_bytes(), tx_bytes);
        let fields = unpack(&PDI_TX, &tx_bytes).unwrap();
        assert_eq!(
            fields,
            vec![&[0x37, 0x82][..], &[0x00, 0x23], &[0x11, 0x00, 0x09, 0x06]]
        );
        assert_eq!(pack(&PDI_TX, &fields).unwrap(), tx_bytes);
    }

    #[test]
    fn limits_are_errors_that_name_them() {
        let odd = MappedObject::new(0x6041, 0, 12);
        let err = mapping_bytes(&[odd]).unwrap_err();
        assert_eq!(err, PdoError::NotWholeBytes(odd));
        assert!(err.to_string().contains("whole bytes"), "{err}");
        assert!(mapping_bytes(&[MappedObject::new(0x6041, 0, 0)]).is_err());
        let too_long = [
            MappedObject::new(0x607A, 0, 32),
            MappedObject::new(0x6081, 0, 32),
            MappedObject::new(0x6040, 0, 16),
        ];
        let err = mapping_bytes(&too_long).unwrap_err();
        assert_eq!(err, PdoError::TooLong { bits: 80 });
        assert!(err.to_string().contains("at most 64 bits"), "{err}");
        assert_eq!(
            pack_integers(&PDI_RX, &[0, 0, 0, 256]),
            Err(PdoError::OutOfRange {
                object: PDI_RX[3],
                value: 256
            })
        );
        assert_eq!(
            pack_integers(&PDI_RX, &[0, -32769, 0, 0])
                .unwrap_err()
                .to_string(),
            "2291h:02h (16 bits): -32769 does not fit 16 bits"
        );
        assert!(pack_integers(&PDI_RX, &[0, 65535, -128, 255]).is_ok());
        assert!(matches!(
            pack_integers(&PDI_RX, &[0, 0]),
            Err(PdoError::ValueCount {
                values: 2,
                entries: 4
            })
        ));
        assert!(matches!(
            pack(&PDI_RX, &[&[0; 4], &[0; 2], &[0], &[0, 0]]),
            Err(PdoError::FieldLength {
                expected: 1,
                got: 2,
                ..
            })
        ));
        assert_eq!(
            unpack(&PDI_TX, &[0; 7]),
            Err(PdoError::ShortPayload {
                expected: 8,
                got: 7
            })
        );
        // Longer payloads: the first bytes count.
        assert_eq!(unpack_unsigned(&PDI_TX[..1], &[1, 0, 9]).unwrap(), vec![1]);
        // 64-bit objects.
        let wide = [MappedObject::new(0x2000, 1, 64)];
        assert_eq!(
            pack_integers(&wide, &[i128::from(u64::MAX)]).unwrap(),
            vec![0xFF; 8]
        );
        assert_eq!(unpack_signed(&wide, &[0xFF; 8]).unwrap(), vec![-1]);
    }

    #[test]
    fn object_indices() {
        assert_eq!(PdoKind::Receive.comm_index(1), Ok(0x1400));
        assert_eq!(PdoKind::Receive.mapping_index(4), Ok(0x1603));
        assert_eq!(PdoKind::Transmit.comm_index(2), Ok(0x1801));
        assert_eq!(PdoKind::Transmit.mapping_index(512), Ok(0x1BFF));
        assert_eq!(PdoKind::Transmit.comm_index(0), Err(PdoError::Number(0)));
        assert_eq!(
            PdoKind::Receive.mapping_index(513),
            Err(PdoError::Number(513))
        );
        assert_eq!(PdoKind::Receive.predefined_cob_id(1, 1), Some(0x201));
        assert_eq!(PdoKind::Transmit.predefined_cob_id(3, 1), Some(0x381));
        assert_eq!(PdoKind::Transmit.predefined_cob_id(5, 1), None);
    }

    #[test]
    fn configure_follows_the_cia_301_order() {
        let comm = PdoComm::event_driven(100, 0);
        let writes = configure(PdoKind::Transmit, 1, 1, &comm, &PDI_TX).unwrap();
        let text: Vec<String> = writes.iter().map(ToString::to_string).collect();
        assert_eq!(
            text,
            [
                "1800h:01h = 80000181h",
                "1A00h:00h = 00h",
                "1A00h:01h = 22920110h",
                "1A00h:02h = 603F0010h",
                "1A00h:03h = 22920220h",
                "1A00h:00h = 03h",
                "1800h:02h = FFh",
                "1800h:03h = 0064h",
                "1800h:05h = 0000h",
                "1800h:01h = 00000181h",
            ]
        );
        assert_eq!(writes[0].data, vec![0x81, 0x01, 0x00, 0x80]);

        let writes = configure(PdoKind::Receive, 1, 3, &comm, &PDI_RX).unwrap();
        assert_eq!(writes[0], SdoWrite::u32(0x1400, 1, 0x8000_0203));
        assert_eq!(writes[2], SdoWrite::u32(0x1600, 1, 0x2291_0120));
        assert_eq!(writes[6], SdoWrite::u8(0x1600, 0, 4));
        assert_eq!(writes.last(), Some(&SdoWrite::u32(0x1400, 1, 0x203)));

        // An explicit COB-ID with bit 30 is kept; PDO 5 needs one.
        let explicit = PdoComm {
            cob_id: COB_NO_RTR | 0x1A5,
            transmission: 1,
            inhibit_100us: 0,
            event_ms: 10,
        };
        let writes = configure(PdoKind::Transmit, 5, 1, &explicit, &[]).unwrap();
        assert_eq!(writes[0], SdoWrite::u32(0x1804, 1, 0xC000_01A5));
        assert_eq!(writes[1], SdoWrite::u8(0x1A04, 0, 0));
        assert_eq!(writes[2], SdoWrite::u8(0x1A04, 0, 0));
        assert_eq!(writes.last(), Some(&SdoWrite::u32(0x1804, 1, 0x4000_01A5)));
        assert_eq!(
            configure(PdoKind::Transmit, 5, 1, &comm, &PDI_TX),
            Err(PdoError::NoCobId {
                kind: PdoKind::Transmit,
                n: 5
            })
        );
        assert!(
            configure(
                PdoKind::Transmit,
                1,
                1,
                &comm,
                &[MappedObject::new(0x6041, 0, 7)]
            )
            .is_err()
        );
    }

    #[test]
    fn transmission_types_have_names() {
        assert_eq!(transmission_text(0), "acyclic synchronous");
        assert_eq!(transmission_text(5), "every 5th SYNC");
        assert_eq!(transmission_text(2), "every 2nd SYNC");
        assert_eq!(transmission_text(12), "every 12th SYNC");
        assert_eq!(transmission_text(23), "every 23rd SYNC");
        assert_eq!(transmission_text(255), "event-driven (device profile)");
    }

    proptest! {
        #[test]
        fn pack_and_unpack_round_trip(
            widths in proptest::collection::vec(1u8..=8, 0..=8),
            seed: [u8; 8],
        ) {
            let mut total = 0;
            let entries: Vec<MappedObject> = widths
                .into_iter()
                .take_while(|w| { total += usize::from(*w); total <= 8 })
                .enumerate()
                .map(|(i, w)| MappedObject::new(0x2000, i as u8, w * 8))
                .collect();
            let len = mapping_bytes(&entries).unwrap();
            let payload = &seed[..len];
            let raw = unpack_unsigned(&entries, payload).unwrap();
            let values: Vec<i128> = raw.iter().map(|v| i128::from(*v)).collect();
            prop_assert_eq!(pack_integers(&entries, &values).unwrap(), payload.to_vec());
            let signed: Vec<i128> = unpack_signed(&entries, payload).unwrap().into_iter().map(i128::from).collect();
            prop_assert_eq!(pack_integers(&entries, &signed).unwrap(), payload.to_vec());
        }

        #[test]
        fn nothing_panics(raw in proptest::collection::vec(any::<u32>(), 0..12), payload in proptest::collection::vec(any::<u8>(), 0..12), values in proptest::collection::vec(any::<i128>(), 0..12)) {
            let entries: Vec<MappedObject> = raw.into_iter().map(MappedObject::from).collect();
            let _ = unpack_signed(&entries, &payload);
            let _ = pack_integers(&entries, &values);
            let _ = configure(PdoKind::Receive, 1, 1, &PdoComm::event_driven(0, 0), &entries);
        }
    }
}
