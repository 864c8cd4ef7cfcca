//! The command panel: a button for every PDI command with its set values, each field with
//! its unit and range; a button stays disabled, with the reason as its tooltip, while a
//! field is invalid. The halt toggle sits on top.

use eframe::egui::{self, Color32, RichText, TextEdit, Ui};

use super::model::{caution, validate};
use crate::od::{self, Address, DataType, Value};
use crate::pdi::{FieldSpec, Opcode, StatusBit};
use crate::ui::command::Command;
use crate::ui::drive::{Drive, TORQUE_SLOPE};
use crate::ui::widgets::{
    AMBER, RED, clipped_label, labelled_text_edit_ui, name_widget, named_text_edit,
};
use crate::worker::{ObjectPath, Request};

/// The button text of a command.
pub fn button_label(opcode: Opcode) -> &'static str {
    match opcode {
        Opcode::Nop => "NOP",
        Opcode::SwitchOff => "Switch off",
        Opcode::ClearError => "Clear error",
        Opcode::Quickstop => "Quickstop",
        Opcode::OdRead => "OD-Read",
        Opcode::OdWrite => "OD-Write",
        Opcode::AutoSetup => "Auto setup",
        Opcode::HomeHere => "Home here",
        Opcode::Homing => "Homing",
        Opcode::MoveAbsolute => "Move absolute",
        Opcode::MoveRelative => "Move relative",
        Opcode::Velocity => "Velocity",
        Opcode::Torque => "Torque",
    }
}

/// The accessible name of a command's input box, e.g. "Move absolute: Max speed".
pub fn field_label(opcode: Opcode, spec: &FieldSpec) -> String {
    format!("{}: {}", button_label(opcode), spec.label)
}

fn command_hint(opcode: Opcode, methods: Option<&[i8]>) -> String {
    match opcode {
        Opcode::Homing => match methods {
            Some(methods) => format!(
                "Homing method in SetValue3. This device supports {}.",
                methods
                    .iter()
                    .map(|m| m.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            None => "Homing method in SetValue3 (a CiA 402 method the drive supports, e.g. 17 to 35; see its manual or 60E3h).".into(),
        },
        Opcode::Torque => "Ramps at the torque slope 6087h; the drive's default slope is 0, which never builds up torque.".into(),
        Opcode::AutoSetup => "Identifies the motor; it moves. Restart the device afterwards: the coordinate system is no longer valid.".into(),
        Opcode::HomeHere => "Sets the actual position to this value without moving.".into(),
        Opcode::OdRead => "Reads an object through the PDI (32 bits at most).".into(),
        Opcode::OdWrite => "Writes an object through the PDI (32 bits at most).".into(),
        Opcode::Nop => "Deletes the command; PdiStatusToggleCmd still toggles.".into(),
        Opcode::ClearError => "Clears a fault once its cause is gone.".into(),
        _ => String::new(),
    }
}

const GROUPS: [(&str, &[Opcode]); 3] = [
    (
        "Motion",
        &[
            Opcode::MoveAbsolute,
            Opcode::MoveRelative,
            Opcode::Velocity,
            Opcode::Torque,
        ],
    ),
    (
        "Homing and setup",
        &[Opcode::Homing, Opcode::HomeHere, Opcode::AutoSetup],
    ),
    (
        "Objects and housekeeping",
        // Clear error sits beside the state tile, where the fault shows.
        &[Opcode::OdRead, Opcode::OdWrite, Opcode::Nop],
    ),
];

/// How wide the command panel is while collapsed.
pub const STRIP_WIDTH: f32 = 34.0;

/// The collapsed command panel: a button to bring it back, and its name, upright.
pub fn collapsed_strip_ui(ui: &mut Ui, collapsed: &mut bool) {
    ui.add_space(4.0);
    let expand = ui
        .add(egui::Button::new(RichText::new("«").size(18.0)).min_size(egui::vec2(24.0, 28.0)))
        .on_hover_text("Show the command panel");
    name_widget(
        &expand,
        egui::accesskit::Role::Button,
        "Expand the command panel",
    );
    if expand.clicked() {
        *collapsed = false;
    }
    let font = egui::FontId::proportional(15.0);
    let color = ui.visuals().text_color();
    let galley = ui
        .painter()
        .layout_no_wrap("Commands".to_owned(), font, color);
    let top = ui.cursor().min + egui::vec2(ui.available_width() / 2.0 + galley.size().y / 2.0, 8.0);
    ui.painter().add(
        egui::epaint::TextShape::new(top, galley, color).with_angle(std::f32::consts::FRAC_PI_2),
    );
}

/// The command panel; which jog button is held (see `jog::jog_input`).
pub fn commands_ui(
    ui: &mut Ui,
    drive: &mut Drive,
    collapsed: &mut bool,
    commands: &mut Vec<Command>,
) -> i32 {
    ui.horizontal(|ui| {
        ui.heading("Commands");
        ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
            let collapse = ui
                .small_button(RichText::new("»").size(16.0))
                .on_hover_text("Fold the command panel to a narrow strip: more room for the plots");
            name_widget(
                &collapse,
                egui::accesskit::Role::Button,
                "Collapse the command panel",
            );
            if collapse.clicked() {
                *collapsed = true;
            }
        });
    });
    // Why every button below is disabled, on screen as well as in each tooltip.
    if let Some(reason) = drive.offline_reason() {
        clipped_label(ui, RichText::new(reason).color(AMBER).strong(), 2);
    }
    halt_ui(ui, drive, commands);
    let jog = crate::ui::jog::jog_ui(ui, drive);
    ui.separator();
    for (title, opcodes) in GROUPS {
        ui.label(RichText::new(title).strong());
        egui::Grid::new(title)
            .num_columns(2)
            .spacing([8.0, 4.0])
            .show(ui, |ui| {
                for opcode in opcodes {
                    command_row(ui, drive, *opcode, commands);
                }
            });
        ui.add_space(6.0);
    }
    object_ui(ui, drive, commands);
    if let Some(read) = &drive.motion.last_object {
        let text = match &read.result {
            Ok(value) => {
                let entry = od::builtin().get(read.address);
                let hex = entry.map(|e| value.to_hex(e.dtype)).unwrap_or_default();
                let unit = entry.and_then(|e| e.unit.clone()).unwrap_or_default();
                let name = entry.map(|e| e.full_name()).unwrap_or_default();
                format!("{} {name} = {value} {unit} {hex}", read.address)
            }
            Err(e) => format!("{}: {e}", read.address),
        };
        let color = if read.result.is_ok() {
            ui.visuals().text_color()
        } else {
            RED
        };
        ui.label(RichText::new(text).color(color).monospace());
    }
    torque_warning_ui(ui, drive, commands);
    jog
}

/// The halt toggle: "Halt" brakes the running travel command; once halted it says so
/// and resumes on the next press.
fn halt_ui(ui: &mut Ui, drive: &Drive, commands: &mut Vec<Command>) {
    let offline = drive.offline_reason();
    let connected = offline.is_none();
    let halted = drive.motion.halt_engaged;
    // Halted, but not by this button (a jog's release, another master): the button says
    // so as the tile does, and offers no resume — that would start a move nobody holds.
    let halted_elsewhere = !halted
        && connected
        && drive.bit(StatusBit::OperationEnabled)
        && drive.bit(StatusBit::QsHaltBit);
    ui.horizontal(|ui| {
        let text = if halted {
            RichText::new("Halted — press to resume").size(16.0).strong().color(Color32::BLACK)
        } else if halted_elsewhere {
            RichText::new("Halted").size(16.0).strong().color(Color32::BLACK)
        } else {
            RichText::new("Halt").size(20.0).strong().color(AMBER)
        };
        let lit = halted || halted_elsewhere;
        // One width in every state: nothing beside or under it moves when it changes.
        let button = egui::Button::selectable(lit, text)
            .min_size(egui::vec2(HALT_WIDTH, 36.0))
            .fill(if lit { AMBER } else { ui.visuals().widgets.inactive.bg_fill });
        let response = ui
            .add_enabled(connected && !halted_elsewhere, button)
            .on_hover_text("Halt bit (PDI-Cmd bit 6): brake to speed 0 with the ramp and stay energised. Press again to continue to the old target.")
            .on_disabled_hover_text(match &offline {
                Some(offline) => offline.clone(),
                None => "Halted, not by this button (a jog's release): send a travel command to move again".to_owned(),
            });
        if response.clicked() {
            commands.push(Command::Request(if halted {
                Request::Resume
            } else {
                Request::Halt
            }));
        }
        let hint = if halted {
            "or send a new travel command"
        } else if halted_elsewhere {
            "Send a travel command to move again."
        } else {
            "Brakes the running travel command."
        };
        ui.add(egui::Label::new(RichText::new(hint).weak()).wrap());
    });
}

/// The halt toggle's width, the same halted or not.
const HALT_WIDTH: f32 = 216.0;

fn command_row(ui: &mut Ui, drive: &mut Drive, opcode: Opcode, commands: &mut Vec<Command>) {
    let verdict = validate(drive, opcode);
    command_button_ui(ui, drive, opcode, &verdict, commands);
    // The inputs beside the button, one per line: label, box, unit.
    ui.vertical(|ui| {
        set_values_ui(ui, drive, opcode);
        let note = match &verdict {
            Err(reason) if !opcode.fields().is_empty() => Some((RED, reason.clone())),
            Ok(request) => caution(drive, request).map(|text| (AMBER, text)),
            _ => None,
        };
        if let Some((color, text)) = note {
            ui.colored_label(color, text);
        }
    });
    ui.end_row();
}

/// The command's button: enabled with a valid request on a live drive, otherwise saying
/// why not; a click sends the request.
fn command_button_ui(
    ui: &mut Ui,
    drive: &Drive,
    opcode: Opcode,
    verdict: &Result<Request, String>,
    commands: &mut Vec<Command>,
) {
    let offline = drive.offline_reason();
    let enabled = offline.is_none() && verdict.is_ok();
    let button = egui::Button::new(button_label(opcode)).min_size(egui::vec2(110.0, 0.0));
    let mut response = ui.add_enabled(enabled, button);
    let methods = drive.link_info().and_then(|i| i.homing_methods.clone());
    let hint = command_hint(opcode, methods.as_deref());
    if !hint.is_empty() {
        response = response.on_hover_text(&hint);
    }
    let reason = match (verdict, offline) {
        (Err(reason), None) => reason.clone(),
        (Err(reason), Some(offline)) => format!("{offline}\n{reason}"),
        (Ok(_), Some(offline)) => offline,
        (Ok(_), None) => String::new(),
    };
    let response = response.on_disabled_hover_text(&reason);
    if response.clicked()
        && let Ok(request) = verdict
    {
        commands.push(Command::SendCommand(request.clone()));
    }
}

/// One line per set value of the command: its label, its box (red while it does not
/// parse), its unit; the range and the object on hover.
fn set_values_ui(ui: &mut Ui, drive: &mut Drive, opcode: Opcode) {
    let specs = opcode.fields();
    let inputs = drive
        .settings
        .inputs
        .entry(opcode.name().to_owned())
        .or_default();
    inputs.resize(specs.len(), String::new());
    for (spec, text) in specs.iter().zip(inputs.iter_mut()) {
        ui.horizontal(|ui| {
            let height = ui.spacing().interact_size.y;
            ui.add_sized(
                [104.0, height],
                egui::Label::new(spec.label).halign(egui::Align::LEFT),
            );
            let valid = spec.parse(text).is_ok();
            let edit = TextEdit::singleline(text)
                .desired_width(86.0)
                .text_color_opt((!valid).then_some(RED));
            let field = ui.add(edit);
            name_widget(
                &field,
                egui::accesskit::Role::TextInput,
                &field_label(opcode, spec),
            );
            field.on_hover_text(field_hint(spec));
            // Units are short ("‰", the rest in the box's hint); one that is not is cut
            // short (whole on hover) rather than widen the panel.
            ui.add(egui::Label::new(RichText::new(spec.unit).weak()).truncate());
        });
    }
}

/// A set value's range, object and hint, for its box's tooltip.
fn field_hint(spec: &FieldSpec) -> String {
    let hint = if spec.hint.is_empty() {
        String::new()
    } else {
        format!("\n{}", spec.hint)
    };
    format!(
        "{} ({}): {} to {} {}{hint}",
        spec.field.name(),
        spec.field.object(),
        spec.format(spec.min),
        spec.format(spec.max),
        spec.unit,
    )
}

fn torque_warning_ui(ui: &mut Ui, drive: &mut Drive, commands: &mut Vec<Command>) {
    let Some(warning) = drive.motion.torque_warning.clone() else {
        return;
    };
    let slope_text = match drive.motion.torque_slope {
        Some(0) => "The torque slope 6087h is 0 (the factory value): with it the torque never builds up and the motor does not move.".to_owned(),
        Some(v) => format!("The torque slope 6087h is {v} ‰/s."),
        None => "The torque slope 6087h could not be read, so it may still be 0 (the factory value), which never builds up torque.".to_owned(),
    };
    let modal = egui::Modal::new(egui::Id::unique("torque_slope_warning")).show(ui.ctx(), |ui| {
        ui.set_max_width(420.0);
        ui.heading("Torque slope is not set");
        ui.label(slope_text);
        ui.add_space(6.0);
        ui.horizontal(|ui| {
            let slope = &mut drive.settings.torque_slope;
            labelled_text_edit_ui(ui, "Set 6087h to", slope, 70.0, "Torque slope 6087h");
            ui.label("‰/s");
        });
        let slope = Value::parse(DataType::Unsigned32, &drive.settings.torque_slope)
            .ok()
            .filter(|v| v.as_i128().is_some_and(|v| v > 0));
        ui.add_space(6.0);
        ui.horizontal(|ui| {
            let set = ui.add_enabled(slope.is_some(), egui::Button::new("Set slope and send"));
            if set.clicked()
                && let Some(value) = slope.clone()
            {
                commands.push(Command::Request(Request::WriteObject {
                    address: TORQUE_SLOPE,
                    dtype: DataType::Unsigned32,
                    value,
                    path: ObjectPath::Auto,
                }));
                commands.push(Command::Request(Request::Command(warning.action)));
                drive.motion.torque_warning = None;
            }
            if ui.button("Send anyway").clicked() {
                commands.push(Command::Request(Request::Command(warning.action)));
                drive.motion.torque_warning = None;
            }
            if ui.button("Cancel").clicked() {
                drive.motion.torque_warning = None;
            }
        });
    });
    if modal.should_close() {
        drive.motion.torque_warning = None;
    }
}

/// Read or write any object the way the link does it best (SDO, FC 43, directly on the
/// simulator; the PDI where nothing else exists): strings and 64-bit values included.
fn object_ui(ui: &mut Ui, drive: &mut Drive, commands: &mut Vec<Command>) {
    ui.label(RichText::new("Any object").strong())
        .on_hover_text("Read or write through the link's own object access (SDO, FC 43, direct), any type and length");
    let offline = drive.offline_reason();
    let connected = offline.is_none();
    let name = ui.horizontal(|ui| {
        let address_text = &mut drive.settings.object_address;
        named_text_edit(ui, address_text, 70.0, "Object address");
        let address = address_text.parse::<Address>();
        let entry = address
            .as_ref()
            .ok()
            .and_then(|a| od::builtin().get(*a))
            .cloned();
        let name = match (&address, &entry) {
            (Err(e), _) => e.to_string(),
            (Ok(_), Some(entry)) => {
                format!("{} ({}, {})", entry.full_name(), entry.dtype, entry.access)
            }
            (Ok(_), None) => {
                "not in the catalog: read as an integer of the size the drive answers with"
                    .to_owned()
            }
        };
        let read = ui
            .add_enabled(connected && address.is_ok(), egui::Button::new("Read"))
            .on_disabled_hover_text(match &offline {
                Some(reason) => reason.clone(),
                None => name.clone(),
            });
        if read.clicked()
            && let Ok(address) = address.clone()
        {
            commands.push(Command::Request(Request::ReadObject {
                address,
                dtype: entry.as_ref().map(|e| e.dtype),
                path: ObjectPath::Auto,
            }));
        }
        named_text_edit(ui, &mut drive.settings.object_value, 120.0, "Object value");
        let parsed = match (&address, &entry) {
            (Ok(_), Some(entry)) if !entry.access.writable() => {
                Err(format!("{} is read-only", entry.full_name()))
            }
            (Ok(_), Some(entry)) => Value::parse(entry.dtype, &drive.settings.object_value)
                .and_then(|v| entry.check(&v).map(|()| v))
                .map(|v| (entry.dtype, v))
                .map_err(|e| e.to_string()),
            (Ok(_), None) => Value::parse(DataType::Integer32, &drive.settings.object_value)
                .map(|v| (DataType::Integer32, v))
                .map_err(|e| e.to_string()),
            (Err(e), _) => Err(e.to_string()),
        };
        let write = ui
            .add_enabled(connected && parsed.is_ok(), egui::Button::new("Write"))
            .on_disabled_hover_text(match (&parsed, &offline) {
                (Err(reason), _) => reason.clone(),
                (Ok(_), Some(offline)) => offline.clone(),
                (Ok(_), None) => String::new(),
            });
        if write.clicked()
            && let (Ok(address), Ok((dtype, value))) = (address, parsed.clone())
        {
            commands.push(Command::Request(Request::WriteObject {
                address,
                dtype,
                value,
                path: ObjectPath::Auto,
            }));
        }
        name
    });
    // On a line of its own, where it wraps rather than widen the panel.
    ui.weak(name.inner);
}
