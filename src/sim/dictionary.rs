//! The simulated drive's object storage: every catalog entry with a live value, and the
//! access rules a real drive enforces, answered with CiA 301 abort codes.

use std::collections::{BTreeMap, HashMap};
use std::hash::{BuildHasherDefault, Hasher};

use crate::cia::AbortCode;
use crate::od::{Address, Catalog, DataType, Entry, Value};

/// One stored object.
#[derive(Clone, Debug)]
struct Slot {
    entry: Entry,
    value: Value,
}

/// Object storage. `read`/`write` are the outside world's view (access rights, types and
/// limits checked); `get`/`set` are the drive's own.
///
/// The objects are kept in address order (FC 101 and the servers walk them in order) with
/// a hash index beside them: every server request and every tick of the drive looks up a
/// few dozen objects (the drive publishing its state, a process image packed), and a B-tree
/// walk for each was most of what the simulated drive's Modbus TCP server spent per request.
#[derive(Clone, Debug, Default)]
pub struct Dictionary {
    /// Every object, in address order.
    slots: Vec<Slot>,
    /// Where each address is in `slots`.
    at: HashMap<Address, usize, BuildHasherDefault<AddressHasher>>,
    /// How many values were set from outside the drive's own cycle (see `changes`).
    changes: u64,
}

/// A hasher for the 24 bits of an address: a multiply whose high half is folded into the
/// low bits (the table's bucket comes from the low bits). Addresses come from the catalog,
/// not from an adversary, so no SipHash.
#[derive(Default)]
struct AddressHasher(u64);

impl Hasher for AddressHasher {
    fn write(&mut self, bytes: &[u8]) {
        for byte in bytes {
            self.0 = (self.0 << 8) | u64::from(*byte);
        }
    }

    fn write_u8(&mut self, n: u8) {
        self.0 = (self.0 << 8) | u64::from(n);
    }

    fn write_u16(&mut self, n: u16) {
        self.0 = (self.0 << 16) | u64::from(n);
    }

    fn finish(&self) -> u64 {
        let h = self.0.wrapping_mul(0x9E37_79B9_7F4A_7C15);
        h ^ (h >> 29)
    }
}

impl Dictionary {
    /// Every catalog entry, holding its default (or zero).
    pub fn from_catalog(catalog: &Catalog) -> Self {
        // Through a map: in address order, one slot per address (the last entry wins).
        let ordered: BTreeMap<Address, Slot> = catalog
            .entries()
            .map(|entry| {
                let value = entry
                    .default
                    .clone()
                    .unwrap_or_else(|| Value::zero(entry.dtype));
                (
                    entry.address,
                    Slot {
                        entry: entry.clone(),
                        value,
                    },
                )
            })
            .collect();
        let slots: Vec<Slot> = ordered.into_values().collect();
        let at = slots
            .iter()
            .enumerate()
            .map(|(i, slot)| (slot.entry.address, i))
            .collect();
        Self {
            slots,
            at,
            changes: 0,
        }
    }

    /// Counts every `set` (a master's write, a server configuring an object), not the
    /// drive's own `set_int` of its state: while it stands still, no mapping or setting
    /// changed, so a server may keep what it built from them (a process image's layout).
    pub fn changes(&self) -> u64 {
        self.changes
    }

    fn slot(&self, address: Address) -> Option<&Slot> {
        self.at.get(&address).and_then(|&i| self.slots.get(i))
    }

    fn slot_mut(&mut self, address: Address) -> Option<&mut Slot> {
        self.at.get(&address).and_then(|&i| self.slots.get_mut(i))
    }

    pub fn entry(&self, address: Address) -> Option<&Entry> {
        self.slot(address).map(|s| &s.entry)
    }

    pub fn addresses(&self) -> impl Iterator<Item = Address> + '_ {
        self.slots.iter().map(|s| s.entry.address)
    }

    fn has_index(&self, index: u16) -> bool {
        let first = self
            .slots
            .partition_point(|s| s.entry.address < Address::new(index, 0));
        self.slots
            .get(first)
            .is_some_and(|s| s.entry.address.index == index)
    }

    fn locate(&self, address: Address) -> Result<&Slot, AbortCode> {
        self.slot(address).ok_or(if self.has_index(address.index) {
            AbortCode::NO_SUBINDEX
        } else {
            AbortCode::NO_OBJECT
        })
    }

    /// Read as a master would: write-only objects refuse.
    pub fn read(&self, address: Address) -> Result<Value, AbortCode> {
        let slot = self.locate(address)?;
        if !slot.entry.access.readable() {
            return Err(AbortCode::WRITE_ONLY);
        }
        Ok(slot.value.clone())
    }

    /// Write as a master would: read-only objects, wrong types and values outside the
    /// type or the entry's limits refuse. Does not run side effects; the drive does.
    pub fn check_write(&self, address: Address, value: &Value) -> Result<(), AbortCode> {
        let slot = self.locate(address)?;
        if !slot.entry.access.writable() {
            return Err(AbortCode::READ_ONLY);
        }
        slot.entry.check(value).map_err(|e| match e {
            crate::od::Error::TooHigh { .. } => AbortCode::VALUE_TOO_HIGH,
            crate::od::Error::TooLow { .. } => AbortCode::VALUE_TOO_LOW,
            crate::od::Error::TypeMismatch { .. } => AbortCode::TYPE_LENGTH_MISMATCH,
            _ => AbortCode::VALUE_RANGE,
        })
    }

    /// Write as a master would, after `check_write`.
    pub fn write(&mut self, address: Address, value: Value) -> Result<(), AbortCode> {
        self.check_write(address, &value)?;
        self.set(address, value);
        Ok(())
    }

    /// The drive's own read; `None` for an address the dictionary lacks.
    pub fn get(&self, address: Address) -> Option<&Value> {
        self.slot(address).map(|s| &s.value)
    }

    /// An integer object as i64 (0 when absent or not an integer).
    pub fn int(&self, index: u16, sub: u8) -> i64 {
        self.get(Address::new(index, sub))
            .and_then(Value::as_i128)
            .and_then(|v| i64::try_from(v).ok())
            .unwrap_or(0)
    }

    /// The drive's own write: no access check. Integers are wrapped into the entry's type;
    /// an address the dictionary lacks is ignored (the catalog decides what exists).
    pub fn set(&mut self, address: Address, value: Value) {
        self.changes = self.changes.wrapping_add(1);
        if let Some(slot) = self.slot_mut(address) {
            slot.value = value;
        }
    }

    /// Set an integer object from an i64, wrapped to the entry's width and signedness.
    pub fn set_int(&mut self, index: u16, sub: u8, value: i64) {
        let address = Address::new(index, sub);
        if let Some(slot) = self.slot_mut(address) {
            slot.value = wrap_integer(slot.entry.dtype, value);
        }
    }
}

/// An integer wrapped into a type the way a device register would hold it.
pub fn wrap_integer(dtype: DataType, value: i64) -> Value {
    match dtype {
        DataType::Boolean => Value::Bool(value != 0),
        DataType::Integer8 => Value::Int(i64::from(value as i8)),
        DataType::Integer16 => Value::Int(i64::from(value as i16)),
        DataType::Integer32 => Value::Int(i64::from(value as i32)),
        DataType::Integer64 => Value::Int(value),
        DataType::Unsigned8 => Value::Uint(u64::from(value as u8)),
        DataType::Unsigned16 => Value::Uint(u64::from(value as u16)),
        DataType::Unsigned32 => Value::Uint(u64::from(value as u32)),
        DataType::Unsigned64 => Value::Uint(value as u64),
        DataType::Real32 | DataType::Real64 => Value::Real(value as f64),
        _ => Value::zero(dtype),
    }
}
