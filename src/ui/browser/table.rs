//! The object table: rows with value, limits and age, in-place actions, the write confirmation.

use super::*;
use eframe::egui::Response;
use egui_extras::TableRow;

pub(super) fn confirm_ui(ui: &mut Ui, b: &mut Browser, outbox: &mut Vec<Request>) {
    let Some(confirm) = b.confirm.clone() else {
        return;
    };
    let modal = egui::Modal::new(egui::Id::unique("confirm_write")).show(ui.ctx(), |ui| {
        ui.heading("Write to the drive?");
        ui.label(format!("{} {}", confirm.address, confirm.name));
        ui.label(format!(
            "{} -> {}",
            confirm
                .before
                .as_ref()
                .map(Value::to_string)
                .unwrap_or_else(|| "(not read)".into()),
            confirm.value
        ));
        let mut go = false;
        let mut cancel = false;
        ui.horizontal(|ui| {
            let write = ui.button("Write");
            crate::ui::widgets::name_widget(&write, egui::accesskit::Role::Button, "Confirm write");
            go = write.clicked();
            cancel = ui.button("Cancel").clicked();
        });
        (go, cancel)
    });
    let (go, cancel) = modal.inner;
    if go {
        b.confirm = None;
        b.edit = None;
        b.write_results.remove(&confirm.address);
        b.send(
            outbox,
            Request::WriteObject {
                address: confirm.address,
                dtype: confirm.dtype,
                value: confirm.value,
                path: ObjectPath::Auto,
            },
            Pending::Write {
                address: confirm.address,
            },
        );
    } else if cancel || modal.should_close() {
        b.confirm = None;
    }
}

pub(super) fn table_ui(
    ui: &mut Ui,
    b: &mut Browser,
    outbox: &mut Vec<Request>,
    connected: bool,
    clock: f64,
) {
    let rows: Vec<Entry> = b.rows().into_iter().cloned().collect();
    let mut visible = vec![];
    let mut actions: Vec<(Address, RowAction)> = vec![];
    // Wider than the panel on a laptop screen: the columns right of the value scroll into
    // view sideways, the header stays on top.
    egui::ScrollArea::horizontal()
        .id_salt("od_table_sideways")
        .show(ui, |ui| {
            with_columns(TableBuilder::new(ui))
                .header(20.0, |mut header| {
                    for title in [
                        "Object", "Name", "Value", "", "Hex", "Type", "Access", "Default",
                        "Limits", "Read",
                    ] {
                        header.col(|ui| {
                            ui.strong(title);
                        });
                    }
                })
                .body(|body| {
                    body.rows(22.0, rows.len(), |mut row| {
                        let Some(entry) = rows.get(row.index()) else {
                            return;
                        };
                        visible.push(entry.address);
                        let view = RowView {
                            b,
                            entry,
                            connected,
                        };
                        entry_row(&mut row, &view, clock, &mut actions);
                    });
                });
        });
    b.visible = visible;
    for (address, action) in actions {
        apply_row_action(b, outbox, address, action);
    }
}

/// The table's look and its columns, the value wide enough to type in.
fn with_columns(table: TableBuilder<'_>) -> TableBuilder<'_> {
    table
        .id_salt("od_table")
        .striped(true)
        .resizable(true)
        .auto_shrink([false, false])
        .min_scrolled_height(120.0)
        .column(Column::initial(70.0).at_least(60.0))
        .column(Column::initial(200.0).at_least(80.0).clip(true))
        .column(Column::initial(170.0).at_least(80.0).clip(true))
        .column(Column::initial(120.0).at_least(100.0))
        .column(Column::initial(90.0).clip(true))
        .column(Column::initial(46.0))
        .column(Column::initial(44.0))
        .column(Column::initial(80.0).clip(true))
        .column(Column::initial(110.0).clip(true))
        .column(Column::remainder().at_least(60.0))
}

/// What a row is drawn from.
struct RowView<'a> {
    b: &'a Browser,
    entry: &'a Entry,
    connected: bool,
}

impl RowView<'_> {
    /// The value last read, or why it could not be.
    fn cell(&self) -> Option<&Cell> {
        self.b.values.get(&self.entry.address)
    }

    /// The value being typed into this row, if it is.
    fn editing(&self) -> Option<&Edit> {
        self.b
            .edit
            .as_ref()
            .filter(|e| e.address == self.entry.address)
    }
}

/// One object's row: its cells left to right, what the user did in it into `actions`.
fn entry_row(
    row: &mut TableRow<'_, '_>,
    view: &RowView<'_>,
    clock: f64,
    actions: &mut Vec<(Address, RowAction)>,
) {
    let entry = view.entry;
    let cell = view.cell();
    row.col(|ui| {
        ui.monospace(entry.address.to_string());
    });
    row.col(|ui| {
        let response = ui.label(entry.full_name());
        if !entry.description.is_empty() {
            response.on_hover_text(&entry.description);
        }
    });
    row.col(|ui| value_cell_ui(ui, view, actions));
    row.col(|ui| {
        ui.horizontal(|ui| match view.editing() {
            Some(edit) => edit_buttons_ui(ui, entry, edit, actions),
            None => row_buttons_ui(ui, view, actions),
        });
    });
    row.col(|ui| {
        if let Some(Ok(value)) = cell.map(|c| &c.result) {
            ui.monospace(value.to_hex(entry.dtype));
        }
    });
    row.col(|ui| {
        ui.label(entry.dtype.short_name());
    });
    row.col(|ui| {
        ui.label(entry.access.short_name());
    });
    row.col(|ui| {
        if let Some(default) = &entry.default {
            ui.label(default.to_string());
        }
    });
    row.col(|ui| {
        ui.label(limits_text(entry));
    });
    row.col(|ui| {
        if let Some(cell) = cell {
            ui.weak(age_text(clock, cell.at));
        }
    });
}

/// The value: the box it is typed into, or as last read (a refusal in red).
fn value_cell_ui(ui: &mut Ui, view: &RowView<'_>, actions: &mut Vec<(Address, RowAction)>) {
    let entry = view.entry;
    if let Some(edit) = view.editing() {
        edit_box_ui(ui, entry, edit, actions);
    } else if let Some(Err(e)) = view.b.write_results.get(&entry.address) {
        ui.colored_label(RED, e).on_hover_text(e);
    } else {
        match view.cell().map(|c| &c.result) {
            Some(Ok(value)) => {
                ui.label(value_text(value, entry));
            }
            Some(Err(e)) => {
                ui.colored_label(RED, e).on_hover_text(e);
            }
            None => {
                ui.weak("?");
            }
        }
    }
}

/// The box a new value is typed into; Enter submits it.
fn edit_box_ui(ui: &mut Ui, entry: &Entry, edit: &Edit, actions: &mut Vec<(Address, RowAction)>) {
    let mut text = edit.text.clone();
    let response = crate::ui::widgets::named_text_edit(
        ui,
        &mut text,
        110.0,
        &format!("New value {}", entry.address),
    );
    if text != edit.text {
        actions.push((entry.address, RowAction::Typed(text)));
    }
    if response.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter)) {
        actions.push((entry.address, RowAction::Submit));
    }
}

/// A row's small button, named "<what> <address>" for screen readers.
fn row_button_ui(ui: &mut Ui, enabled: bool, text: &str, what: &str, address: Address) -> Response {
    let button = ui.add_enabled(enabled, egui::Button::new(text).small());
    crate::ui::widgets::name_widget(
        &button,
        egui::accesskit::Role::Button,
        &format!("{what} {address}"),
    );
    button
}

/// While a value is typed: write it (after the confirmation), or cancel; why it is refused.
fn edit_buttons_ui(
    ui: &mut Ui,
    entry: &Entry,
    edit: &Edit,
    actions: &mut Vec<(Address, RowAction)>,
) {
    if row_button_ui(ui, true, "Write…", "Write", entry.address).clicked() {
        actions.push((entry.address, RowAction::Submit));
    }
    if ui.small_button("Cancel").clicked() {
        actions.push((entry.address, RowAction::CancelEdit));
    }
    if let Some(error) = &edit.error {
        ui.colored_label(RED, error);
    }
}

/// Read, Plot (what can be sampled) and Edit; "written" after a write went through.
fn row_buttons_ui(ui: &mut Ui, view: &RowView<'_>, actions: &mut Vec<(Address, RowAction)>) {
    let entry = view.entry;
    let address = entry.address;
    let readable = entry.access.readable();
    if row_button_ui(ui, view.connected && readable, "Read", "Read", address).clicked() {
        actions.push((address, RowAction::Read));
    }
    let plottable = readable
        && (entry.dtype.is_integer()
            || matches!(
                entry.dtype,
                DataType::Boolean | DataType::Real32 | DataType::Real64
            ));
    if plottable
        && row_button_ui(ui, true, "Plot", "Plot", address)
            .on_hover_text("Sample it every cycle and add it to the plots")
            .clicked()
    {
        actions.push((address, RowAction::Plot));
    }
    let writable = entry.access.writable();
    let edit = row_button_ui(ui, view.connected && writable, "Edit", "Edit", address)
        .on_disabled_hover_text(if writable {
            "not connected"
        } else {
            "read-only: the drive does not take writes to it"
        });
    if edit.clicked() {
        actions.push((address, RowAction::Edit));
    }
    if let Some(Ok(())) = view.b.write_results.get(&address) {
        ui.colored_label(GREEN, "written");
    }
}

/// What the user did in a row.
enum RowAction {
    Read,
    Plot,
    Edit,
    Typed(String),
    Submit,
    CancelEdit,
}

fn apply_row_action(
    b: &mut Browser,
    outbox: &mut Vec<Request>,
    address: Address,
    action: RowAction,
) {
    let Some(entry) = b.catalog().get(address).cloned() else {
        return;
    };
    match action {
        RowAction::Read => b.read_one(outbox, address, entry.dtype),
        RowAction::Plot => b.plot_request = Some(address),
        RowAction::Edit => {
            let text = edit_text(b.values.get(&address), &entry);
            b.edit = Some(Edit {
                address,
                text,
                error: None,
            });
        }
        RowAction::Typed(text) => {
            if let Some(edit) = b.edit.as_mut() {
                edit.text = text;
                edit.error = None;
            }
        }
        RowAction::CancelEdit => b.edit = None,
        RowAction::Submit => submit_edit(b, address, &entry),
    }
}

/// What the edit box starts with: the value as last read (bytes in hex, a flag as 0 or
/// 1), else the default.
fn edit_text(cell: Option<&Cell>, entry: &Entry) -> String {
    match cell.map(|c| &c.result) {
        Some(Ok(Value::Bytes(bytes))) => bytes
            .iter()
            .map(|x| format!("{x:02X}"))
            .collect::<Vec<_>>()
            .join(" "),
        Some(Ok(Value::Text(t))) => t.clone(),
        Some(Ok(Value::Bool(v))) => u8::from(*v).to_string(),
        Some(Ok(v)) => v.to_string(),
        _ => entry
            .default
            .as_ref()
            .map(Value::to_string)
            .unwrap_or_default(),
    }
}

/// The value typed, checked: the confirmation asked for, or why it is refused.
fn submit_edit(b: &mut Browser, address: Address, entry: &Entry) {
    let Some(edit) = b.edit.as_mut() else {
        return;
    };
    match parse_edit(entry, &edit.text) {
        Err(reason) => edit.error = Some(reason),
        Ok(value) => {
            let before = b
                .values
                .get(&address)
                .and_then(|c| c.result.as_ref().ok().cloned());
            b.confirm = Some(Confirm {
                address,
                name: entry.full_name(),
                dtype: entry.dtype,
                value,
                before,
            });
        }
    }
}
