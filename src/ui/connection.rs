//! The connection bar: the bus, its fields with the hardware's defaults, connect and
//! disconnect, the link's health; and the stop strip, always visible.

use std::time::SystemTime;

use eframe::egui::{self, Color32, RichText, Ui};

use super::command::Command;
use super::connection_form::{Bus, ConnectionForm, FormError};
use super::drive::{Connection, Drive};
use super::scan::{discover_ui, scan_button_ui};
use super::settings::DriveSettings;
use super::widgets::{
    AMBER, GREEN, RED, choice_ui, labelled_text_edit_ui, name_widget, named_text_edit,
};
use crate::link::{EnipIo, LinkSpec, Parity};
use crate::pdi::Action;
use crate::worker::{Health, LinkLossAction, MAX_LOST_AFTER};

/// A labelled box of the bar, named "Connection: <label>".
fn field_ui(ui: &mut Ui, label: &str, text: &mut String, width: f32) {
    labelled_text_edit_ui(ui, label, text, width, &format!("Connection: {label}"));
}

/// A serial port: typed, or picked from the ports this machine has (the worker lists
/// them). `true` when the list should be asked for (again).
fn port_field_ui(ui: &mut Ui, path: &mut String, ports: &Option<Vec<String>>) -> bool {
    ui.label("Port");
    named_text_edit(ui, path, 110.0, "Connection: Port");
    let mut ask = ports.is_none();
    let found = ports.clone().unwrap_or_default();
    let picked = egui::ComboBox::from_id_salt("serial_ports")
        .selected_text(match ports {
            None => "looking…",
            Some(found) if found.is_empty() => "none found",
            Some(_) => "pick",
        })
        .width(80.0)
        .show_ui(ui, |ui| {
            for port in found.iter() {
                ui.selectable_value(path, port.clone(), port);
            }
        });
    name_widget(
        &picked.response,
        egui::accesskit::Role::ComboBox,
        "Serial ports",
    );
    if ui
        .small_button("Scan")
        .on_hover_text("Look for serial ports again (USB adapters plugged in since)")
        .clicked()
    {
        ask = true;
    }
    ask
}

pub fn connection_ui(ui: &mut Ui, drive: &mut Drive, commands: &mut Vec<Command>) {
    let mut want_ports = false;
    ui.horizontal_wrapped(|ui| {
        let form = &mut drive.settings.connection;
        choice_ui(ui, "bus", "Bus", &mut form.bus, &Bus::ALL, Bus::name, None);
        want_ports = bus_fields_ui(ui, form, &drive.link.machine.serial_ports);
        if form.bus == Bus::Enip {
            discover_ui(ui, drive, commands);
        }

        let spec = drive.settings.connection.spec();
        scan_button_ui(ui, drive, &spec, commands);
        connect_button_ui(ui, drive, &spec, commands);
        if let Err(reason) = &spec {
            ui.colored_label(RED, reason.to_string());
        }

        ui.separator();
        poll_rate_ui(ui, &mut drive.settings);
        link_loss_ui(ui, &mut drive.settings);
        link_state_ui(ui, drive);
    });
    if want_ports {
        drive.ask_serial_ports();
    }
}

/// The boxes of the bus picked. `true` when the serial ports should be listed (again).
fn bus_fields_ui(ui: &mut Ui, form: &mut ConnectionForm, ports: &Option<Vec<String>>) -> bool {
    match form.bus {
        Bus::Sim => {
            ui.weak("built in: no hardware needed");
        }
        Bus::ModbusTcp => {
            field_ui(ui, "Host", &mut form.tcp_host, 110.0);
            field_ui(ui, "Port", &mut form.tcp_port, 52.0);
            field_ui(ui, "Unit", &mut form.unit, 28.0);
        }
        Bus::ModbusRtu => return modbus_rtu_fields_ui(ui, form, ports),
        Bus::CanopenSocketcan => {
            field_ui(ui, "Interface", &mut form.can_iface, 70.0);
            node_fields_ui(ui, form);
        }
        Bus::CanopenSim => {
            node_fields_ui(ui, form);
            ui.weak("simulated drive on an in-memory CAN bus");
        }
        Bus::CanopenSlcan => {
            let want_ports = port_field_ui(ui, &mut form.slcan_path, ports);
            field_ui(ui, "Bit rate", &mut form.bitrate, 70.0);
            node_fields_ui(ui, form);
            return want_ports;
        }
        Bus::Enip => enip_fields_ui(ui, form),
    }
    false
}

/// The serial line and the slave. `true` when the serial ports should be listed (again).
fn modbus_rtu_fields_ui(
    ui: &mut Ui,
    form: &mut ConnectionForm,
    ports: &Option<Vec<String>>,
) -> bool {
    let want_ports = port_field_ui(ui, &mut form.rtu_path, ports);
    field_ui(ui, "Baud", &mut form.baud, 56.0);
    let parities = [Parity::Even, Parity::None, Parity::Odd];
    let parity = &mut form.parity;
    choice_ui(
        ui,
        "parity",
        "Parity",
        parity,
        &parities,
        Parity::name,
        Some(60.0),
    );
    field_ui(ui, "Stop", &mut form.stop_bits, 20.0);
    field_ui(ui, "Slave", &mut form.slave, 32.0);
    want_ports
}

/// The CANopen node and the PDO set, on every CAN bus.
fn node_fields_ui(ui: &mut Ui, form: &mut ConnectionForm) {
    field_ui(ui, "Node", &mut form.node, 32.0);
    field_ui(ui, "PDO", &mut form.pdo, 20.0);
}

/// The adapter's address, the I/O set and the interval of its cyclic data.
fn enip_fields_ui(ui: &mut Ui, form: &mut ConnectionForm) {
    field_ui(ui, "Host", &mut form.enip_host, 110.0);
    field_ui(ui, "Port", &mut form.enip_port, 52.0);
    let sets = [EnipIo::Pdi, EnipIo::Common, EnipIo::Explicit];
    choice_ui(
        ui,
        "enip_io",
        "I/O set",
        &mut form.enip_io,
        &sets,
        EnipIo::name,
        Some(70.0),
    );
    field_ui(ui, "RPI ms", &mut form.rpi, 32.0);
}

/// Connect to what the bar describes; Disconnect while connected or retrying.
fn connect_button_ui(
    ui: &mut Ui,
    drive: &Drive,
    spec: &Result<LinkSpec, FormError>,
    commands: &mut Vec<Command>,
) {
    let busy = matches!(drive.link.connection, Connection::Connecting(_));
    match &drive.link.connection {
        Connection::Connected(_)
        | Connection::Failed {
            retry_in: Some(_), ..
        } => {
            if ui.button("Disconnect").clicked() {
                commands.push(Command::Disconnect);
            }
        }
        _ => {
            let response = ui
                .add_enabled(spec.is_ok() && !busy, egui::Button::new("Connect"))
                .on_disabled_hover_text(
                    spec.as_ref()
                        .err()
                        .map(|e| e.to_string())
                        .unwrap_or_default(),
                );
            if response.clicked()
                && let Ok(spec) = spec.clone()
            {
                commands.push(Command::Connect(spec));
            }
        }
    }
}

/// How many process-image exchanges the worker makes a second.
fn poll_rate_ui(ui: &mut Ui, settings: &mut DriveSettings) {
    ui.label("Poll");
    let poll = ui.add(
        egui::DragValue::new(&mut settings.poll_rate)
            .range(1.0..=1000.0)
            .speed(1.0)
            .max_decimals(0)
            .suffix(" Hz"),
    );
    name_widget(&poll, egui::accesskit::Role::SpinButton, "Poll rate");
    poll.on_hover_text("Process-image exchanges per second (the plots sample at this rate)");
}

/// What the worker does when the link drops, and after how many failed exchanges it
/// counts as dropped.
fn link_loss_ui(ui: &mut Ui, settings: &mut DriveSettings) {
    let loss = egui::ComboBox::from_id_salt("on_link_loss")
        .selected_text(format!("link lost: {}", settings.on_link_loss.name()))
        .show_ui(ui, |ui| {
            for action in LinkLossAction::ALL {
                ui.selectable_value(&mut settings.on_link_loss, action, action.name());
            }
        });
    name_widget(
        &loss.response,
        egui::accesskit::Role::ComboBox,
        "When the link drops",
    );
    loss.response.on_hover_text(
        "What the worker does when the link fails while the motor may be moving: one last try to halt (default) or switch off, or nothing; the log says whether it reached the drive",
    );
    let after = ui.add(
        egui::DragValue::new(&mut settings.lost_after)
            .range(1..=MAX_LOST_AFTER)
            .speed(0.1)
            .prefix("after ")
            .suffix(" failures"),
    );
    name_widget(
        &after,
        egui::accesskit::Role::SpinButton,
        "Failed exchanges before the link counts as lost",
    );
    after.on_hover_text(
        "How many exchanges must fail in a row before the link counts as lost. A lost, late or corrupted reply is first sent again (three tries within the timeout); fewer failures than this are retried and named in the log",
    );
}

/// Where the link stands: connecting, connected (and how well), failed.
fn link_state_ui(ui: &mut Ui, drive: &Drive) {
    match &drive.link.connection {
        Connection::Disconnected => {
            ui.weak("disconnected");
        }
        Connection::Connecting(spec) => {
            ui.spinner();
            ui.label(format!("connecting to {spec}"));
        }
        // Connected but silent: the link is up, the drive is not answering — not green.
        Connection::Connected(info)
            if drive.link.sampled_since_connect && !drive.is_live(SystemTime::now()) =>
        {
            ui.colored_label(RED, "connected, no data:")
                .on_hover_text("The link is up but the drive stopped answering");
            ui.label(&info.description);
        }
        Connection::Connected(info) => {
            ui.colored_label(GREEN, "connected:");
            ui.label(&info.description);
            if let Some(health) = drive.link.health {
                health_ui(ui, &health);
            }
        }
        Connection::Failed {
            error, retry_in, ..
        } => {
            let retry = retry_in
                .map(|d| format!(" (retrying in {:.1} s)", d.as_secs_f64()))
                .unwrap_or_default();
            ui.colored_label(RED, format!("{error}{retry}"));
        }
    }
}

/// The exchanges a second, their round-trip time, the errors; what was dropped on hover.
fn health_ui(ui: &mut Ui, health: &Health) {
    let recovered = if health.recovered > 0 {
        format!(", {} replies sent again", health.recovered)
    } else {
        String::new()
    };
    ui.weak(format!(
        "{:.0} cycles/s, RTT {:.2} ms (max {:.2}), {} errors{recovered}",
        health.cycles_per_second,
        health.rtt_mean.as_secs_f64() * 1e3,
        health.rtt_max.as_secs_f64() * 1e3,
        health.errors
    ))
    .on_hover_text(if health.dropped_samples + health.dropped_frames > 0 {
        format!(
            "{} samples and {} traced frames dropped because the window was busy",
            health.dropped_samples, health.dropped_frames
        )
    } else {
        "Process-image exchanges per second and their round-trip time".to_owned()
    });
}

/// The two stop buttons, for the drives named (with more than one they stop them all, and
/// say so); which was pressed. `offline` says why they are disabled.
pub fn stop_buttons_ui(
    ui: &mut Ui,
    enabled: bool,
    offline: &str,
    drives: &[&str],
) -> Option<Action> {
    let all = drives.len() > 1;
    let every = if all {
        format!(", on every connected drive ({})", drives.join(", "))
    } else {
        String::new()
    };
    let mut pressed = None;
    ui.horizontal(|ui| {
        let quickstop = egui::Button::new(
            RichText::new(if all {
                "QUICKSTOP ALL (Esc)"
            } else {
                "QUICKSTOP (Esc)"
            })
            .size(17.0)
            .strong()
            .color(Color32::WHITE),
        )
        .fill(RED)
        .min_size(egui::vec2(170.0, 34.0));
        if ui
            .add_enabled(enabled, quickstop)
            .on_hover_text(format!(
                "PDI-Cmd 3: brake with the quick stop reaction of 605Ah{every}"
            ))
            .on_disabled_hover_text(offline)
            .clicked()
        {
            pressed = Some(Action::Quickstop);
        }
        let switch_off = egui::Button::new(
            RichText::new(if all {
                "Switch off all (Shift+Esc)"
            } else {
                "Switch off (Shift+Esc)"
            })
            .size(15.0)
            .color(Color32::BLACK),
        )
        .fill(AMBER)
        .min_size(egui::vec2(150.0, 34.0));
        if ui
            .add_enabled(enabled, switch_off)
            .on_hover_text(format!(
                "PDI-Cmd 1: power stage off, motor de-energised (it coasts){every}"
            ))
            .on_disabled_hover_text(offline)
            .clicked()
        {
            pressed = Some(Action::SwitchOff);
        }
    });
    pressed
}

/// Esc = Quickstop, Shift+Esc = Switch Off, whatever has focus, while a drive is
/// connected (`connected`): the stop pressed.
pub fn stop_keys(ctx: &egui::Context, connected: bool) -> Option<Action> {
    if !connected {
        return None;
    }
    let (quickstop, switch_off) = ctx.input_mut(|i| {
        let switch_off = i.consume_key(egui::Modifiers::SHIFT, egui::Key::Escape);
        let quickstop = i.consume_key(egui::Modifiers::NONE, egui::Key::Escape);
        (quickstop, switch_off)
    });
    // Esc would have closed an open drop-down or menu: it still does, beside the stop.
    if switch_off || quickstop {
        egui::Popup::close_all(ctx);
    }
    if switch_off {
        Some(Action::SwitchOff)
    } else if quickstop {
        Some(Action::Quickstop)
    } else {
        None
    }
}
