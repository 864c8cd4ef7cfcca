//! What the tool changed on the drive this session, with the values before, and "restore
//! what I changed": the old values written back in reverse order.

use eframe::egui::{self, RichText, Ui};

use super::state::AppState;
use super::widgets::AMBER;
use crate::od::{self, Address, DataType, Value};
use crate::worker::{ObjectPath, Request};

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

impl AppState {
    /// Write back every old value, newest change first.
    pub fn restore_changes(&mut self) {
        let requests = restore_requests(&self.changes);
        self.info(format!(
            "restoring {} changed object(s) in reverse order",
            requests.len()
        ));
        for request in requests {
            self.request(request);
        }
    }
}

pub fn changes_ui(ui: &mut Ui, state: &mut AppState) {
    let restorable = state.changes.iter().filter(|c| c.before.is_some()).count();
    ui.horizontal(|ui| {
        let button = ui
            .add_enabled(
                state.is_connected() && restorable > 0,
                egui::Button::new(format!("Restore what I changed ({restorable})")),
            )
            .on_hover_text("Write every old value back, the newest change first")
            .on_disabled_hover_text("nothing to restore, or not connected");
        if button.clicked() {
            state.restore_changes();
        }
        ui.weak(
            "Objects written this session (dictionary, command panel, torque slope); PDO \
             mappings are restored by the CANopen link itself on disconnect.",
        );
    });
    egui::ScrollArea::vertical()
        .auto_shrink([false, false])
        .show(ui, |ui| {
            egui::Grid::new("changes_grid")
                .num_columns(4)
                .striped(true)
                .spacing([12.0, 2.0])
                .show(ui, |ui| {
                    if state.changes.is_empty() && state.link_changes.is_empty() {
                        ui.weak("nothing changed on the drive this session");
                        ui.end_row();
                    }
                    for change in &state.link_changes {
                        ui.weak("link");
                        ui.label(change);
                        ui.end_row();
                    }
                    for change in &state.changes {
                        ui.monospace(change.address.to_string());
                        ui.label(
                            od::builtin()
                                .get(change.address)
                                .map(|e| e.full_name())
                                .unwrap_or_default(),
                        );
                        match &change.before {
                            Some(before) => ui.label(format!("was {before}")),
                            None => ui.colored_label(
                                AMBER,
                                "was unknown (could not be read first): not restored",
                            ),
                        };
                        ui.label(RichText::new(format!("now {}", change.after)).strong());
                        ui.end_row();
                    }
                });
        });
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
