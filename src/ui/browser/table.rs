//! The object table: rows with value, limits and age, in-place actions, the write confirmation.

use super::*;

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
            TableBuilder::new(ui)
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
                        let cell = b.values.get(&entry.address);
                        let editing = b.edit.as_ref().filter(|e| e.address == entry.address);
                        row.col(|ui| {
                            ui.monospace(entry.address.to_string());
                        });
                        row.col(|ui| {
                            let response = ui.label(entry.full_name());
                            if !entry.description.is_empty() {
                                response.on_hover_text(&entry.description);
                            }
                        });
                        row.col(|ui| match editing {
                            Some(edit) => {
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
                                if response.lost_focus()
                                    && ui.input(|i| i.key_pressed(egui::Key::Enter))
                                {
                                    actions.push((entry.address, RowAction::Submit));
                                }
                            }
                            None => {
                                if let Some(Err(e)) = b.write_results.get(&entry.address) {
                                    ui.colored_label(RED, e).on_hover_text(e);
                                } else {
                                    match cell.map(|c| &c.result) {
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
                        });
                        row.col(|ui| {
                            ui.horizontal(|ui| match editing {
                                Some(edit) => {
                                    let write = ui.small_button("Write…");
                                    crate::ui::widgets::name_widget(
                                        &write,
                                        egui::accesskit::Role::Button,
                                        &format!("Write {}", entry.address),
                                    );
                                    if write.clicked() {
                                        actions.push((entry.address, RowAction::Submit));
                                    }
                                    if ui.small_button("Cancel").clicked() {
                                        actions.push((entry.address, RowAction::CancelEdit));
                                    }
                                    if let Some(error) = &edit.error {
                                        ui.colored_label(RED, error);
                                    }
                                }
                                None => {
                                    let read = ui.add_enabled(
                                        connected && entry.access.readable(),
                                        egui::Button::new("Read").small(),
                                    );
                                    crate::ui::widgets::name_widget(
                                        &read,
                                        egui::accesskit::Role::Button,
                                        &format!("Read {}", entry.address),
                                    );
                                    if read.clicked() {
                                        actions.push((entry.address, RowAction::Read));
                                    }
                                    let plottable = entry.access.readable()
                                        && (entry.dtype.is_integer()
                                            || matches!(
                                                entry.dtype,
                                                DataType::Boolean
                                                    | DataType::Real32
                                                    | DataType::Real64
                                            ));
                                    if plottable {
                                        let plot = ui.small_button("Plot").on_hover_text(
                                            "Sample it every cycle and add it to the plots",
                                        );
                                        crate::ui::widgets::name_widget(
                                            &plot,
                                            egui::accesskit::Role::Button,
                                            &format!("Plot {}", entry.address),
                                        );
                                        if plot.clicked() {
                                            actions.push((entry.address, RowAction::Plot));
                                        }
                                    }
                                    let writable = entry.access.writable();
                                    let edit = ui.add_enabled(
                                        connected && writable,
                                        egui::Button::new("Edit").small(),
                                    );
                                    crate::ui::widgets::name_widget(
                                        &edit,
                                        egui::accesskit::Role::Button,
                                        &format!("Edit {}", entry.address),
                                    );
                                    let edit = edit.on_disabled_hover_text(if writable {
                                        "not connected"
                                    } else {
                                        "read-only: the drive does not take writes to it"
                                    });
                                    if edit.clicked() {
                                        actions.push((entry.address, RowAction::Edit));
                                    }
                                    if let Some(Ok(())) = b.write_results.get(&entry.address) {
                                        ui.colored_label(GREEN, "written");
                                    }
                                }
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
                    });
                });
        });
    b.visible = visible;
    for (address, action) in actions {
        apply_row_action(b, outbox, address, action);
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
            let text = match b.values.get(&address).map(|c| &c.result) {
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
            };
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
        RowAction::Submit => {
            let Some(edit) = b.edit.as_mut() else {
                return;
            };
            match parse_edit(&entry, &edit.text) {
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
    }
}
