//! What the tool changed on a drive this session, with the values before, and the writes
//! that undo it: the old values, newest change first.
//!
//! A model: no egui here.

use crate::link::LinkSpec;
use crate::od::{Address, DataType, Value};
use crate::ui::panel::PanelModel;
use crate::worker::{Event, ObjectPath, Request};

/// The changes of one drive, and the link they belong to (another link starts a new list;
/// a reconnect to the same one keeps the values from before the first write).
#[derive(Clone, Debug, Default)]
pub struct Changes {
    pub entries: Vec<ChangeEntry>,
    pub link: Option<LinkSpec>,
}

/// The drive's news for the list: what the tool changed, and the link it is connected to
/// now (another link starts a new list; a reconnect to the same one keeps the values from
/// before the first write).
impl PanelModel for Changes {
    fn on_event(&mut self, event: &Event) {
        match event {
            Event::Connected(info) if self.link.as_ref() != Some(&info.spec) => {
                self.entries.clear();
                self.link = Some(info.spec.clone());
            }
            Event::Changed {
                address,
                dtype,
                before,
                after,
            } => note_change(
                &mut self.entries,
                ChangeEntry {
                    address: *address,
                    dtype: *dtype,
                    before: before.clone(),
                    after: after.clone(),
                },
            ),
            _ => {}
        }
    }
}

impl Changes {
    /// How many changes have an old value to write back.
    pub fn restorable(&self) -> usize {
        self.entries.iter().filter(|c| c.before.is_some()).count()
    }

    pub fn len(&self) -> usize {
        self.entries.len()
    }

    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    pub fn clear(&mut self) {
        self.entries.clear();
    }
}

/// One object the tool changed.
#[derive(Clone, Debug, PartialEq)]
pub struct ChangeEntry {
    pub address: Address,
    pub dtype: DataType,
    /// The value before the tool first wrote it (`None`: it could not be read first).
    pub before: Option<Value>,
    pub after: Value,
}

/// Take a change the worker reports: a new object goes to the end, a known one gets its
/// new value, and one written back to its old value is no longer a change.
pub fn note_change(changes: &mut Vec<ChangeEntry>, change: ChangeEntry) {
    match changes.iter().position(|c| c.address == change.address) {
        Some(i) => changes[i].after = change.after,
        None => changes.push(change),
    }
    changes.retain(|c| c.before.as_ref() != Some(&c.after));
}

/// The writes that undo `changes`: the old values, newest change first. Objects whose
/// old value is unknown are left out (they are listed as such).
pub fn restore_requests(changes: &[ChangeEntry]) -> Vec<Request> {
    changes
        .iter()
        .rev()
        .filter_map(|c| {
            c.before.clone().map(|value| Request::WriteObject {
                address: c.address,
                dtype: c.dtype,
                value,
                path: ObjectPath::Auto,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn change(index: u16, before: Option<i64>, after: i64) -> ChangeEntry {
        ChangeEntry {
            address: Address::new(index, 0),
            dtype: DataType::Integer32,
            before: before.map(Value::Int),
            after: Value::Int(after),
        }
    }

    #[test]
    fn changes_accumulate_and_vanish_when_undone() {
        let mut changes = Vec::new();
        note_change(&mut changes, change(0x6081, Some(100), 200));
        note_change(&mut changes, change(0x6083, None, 5));
        note_change(&mut changes, change(0x6081, Some(100), 300));
        assert_eq!(changes.len(), 2);
        assert_eq!(changes[0].after, Value::Int(300));
        let requests = restore_requests(&changes);
        assert_eq!(requests.len(), 1, "the unknown one is not written");
        note_change(&mut changes, change(0x6081, Some(100), 100));
        assert_eq!(changes.len(), 1);
    }

    #[test]
    fn restoring_goes_newest_first() {
        let changes = vec![change(1, Some(1), 2), change(2, Some(3), 4)];
        let order: Vec<Address> = restore_requests(&changes)
            .iter()
            .filter_map(|r| match r {
                Request::WriteObject { address, .. } => Some(*address),
                _ => None,
            })
            .collect();
        assert_eq!(order, [Address::new(2, 0), Address::new(1, 0)]);
    }
}
