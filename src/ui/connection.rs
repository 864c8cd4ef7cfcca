//! The connection bar: the bus, its fields with the hardware's defaults, connect and
//! disconnect, the link's health; and the stop strip, always visible.

use eframe::egui::{self, Color32, RichText, Ui};

use super::state::{AppState, Bus, Connection};
use super::widgets::{AMBER, GREEN, RED, name_widget, named_text_edit};
use crate::link::{EnipIo, Parity};
use crate::pdi::Action;
use crate::worker::Request;

fn field(ui: &mut Ui, label: &str, text: &mut String, width: f32) {
    ui.label(label);
    named_text_edit(ui, text, width, &format!("Connection: {label}"));
}

fn combo_name(response: &egui::Response, name: &str) {
    name_widget(response, egui::accesskit::Role::ComboBox, name);
}

/// A serial port: typed, or picked from the ports this machine has (the worker lists
/// them). `true` when the list should be asked for (again).
fn port_field(ui: &mut Ui, path: &mut String, ports: &Option<Vec<String>>) -> bool {
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
    combo_name(&picked.response, "Serial ports");
    if ui
        .small_button("Scan")
        .on_hover_text("Look for serial ports again (USB adapters plugged in since)")
        .clicked()
    {
        ask = true;
    }
    ask
}

pub fn connection_ui(ui: &mut Ui, state: &mut AppState) {
    let mut want_ports = false;
    ui.horizontal_wrapped(|ui| {
        let form = &mut state.settings.connection;
        let bus = egui::ComboBox::from_id_salt("bus")
            .selected_text(form.bus.name())
            .show_ui(ui, |ui| {
                for bus in Bus::ALL {
                    ui.selectable_value(&mut form.bus, bus, bus.name());
                }
            });
        combo_name(&bus.response, "Bus");
        match form.bus {
            Bus::Sim => {
                ui.weak("built in: no hardware needed");
            }
            Bus::ModbusTcp => {
                field(ui, "Host", &mut form.tcp_host, 110.0);
                field(ui, "Port", &mut form.tcp_port, 52.0);
                field(ui, "Unit", &mut form.unit, 28.0);
            }
            Bus::ModbusRtu => {
                want_ports |= port_field(ui, &mut form.rtu_path, &state.serial_ports);
                field(ui, "Baud", &mut form.baud, 56.0);
                let parity = egui::ComboBox::from_id_salt("parity")
                    .selected_text(form.parity.name())
                    .width(60.0)
                    .show_ui(ui, |ui| {
                        for parity in [Parity::Even, Parity::None, Parity::Odd] {
                            ui.selectable_value(&mut form.parity, parity, parity.name());
                        }
                    });
                combo_name(&parity.response, "Parity");
                field(ui, "Stop", &mut form.stop_bits, 20.0);
                field(ui, "Slave", &mut form.slave, 32.0);
            }
            Bus::CanopenSocketcan => {
                field(ui, "Interface", &mut form.can_iface, 70.0);
                field(ui, "Node", &mut form.node, 32.0);
                field(ui, "PDO", &mut form.pdo, 20.0);
            }
            Bus::CanopenSim => {
                field(ui, "Node", &mut form.node, 32.0);
                field(ui, "PDO", &mut form.pdo, 20.0);
                ui.weak("simulated drive on an in-memory CAN bus");
            }
            Bus::CanopenSlcan => {
                want_ports |= port_field(ui, &mut form.slcan_path, &state.serial_ports);
                field(ui, "Bit rate", &mut form.bitrate, 70.0);
                field(ui, "Node", &mut form.node, 32.0);
                field(ui, "PDO", &mut form.pdo, 20.0);
            }
            Bus::Enip => {
                field(ui, "Host", &mut form.enip_host, 110.0);
                field(ui, "Port", &mut form.enip_port, 52.0);
                let io = egui::ComboBox::from_id_salt("enip_io")
                    .selected_text(form.enip_io.name())
                    .width(70.0)
                    .show_ui(ui, |ui| {
                        for io in [EnipIo::Pdi, EnipIo::Common, EnipIo::Explicit] {
                            ui.selectable_value(&mut form.enip_io, io, io.name());
                        }
                    });
                combo_name(&io.response, "I/O set");
                field(ui, "RPI ms", &mut form.rpi, 32.0);
            }
        }
        if form.bus == Bus::Enip {
            discover_ui(ui, state);
        }
        let form = &mut state.settings.connection;

        let spec = form.spec();
        let is_can = matches!(
            form.bus,
            Bus::CanopenSim | Bus::CanopenSlcan | Bus::CanopenSocketcan
        );
        if is_can
            && ui
                .add_enabled(spec.is_ok(), egui::Button::new("Scan bus"))
                .on_hover_text("Find the CANopen nodes on this bus: heartbeats, and 1018h read from every node id")
                .clicked()
            && let Ok(spec) = spec.clone()
        {
            state.request(Request::Scan(spec));
        }
        let busy = matches!(state.connection, Connection::Connecting(_));
        match &state.connection {
            Connection::Connected(_)
            | Connection::Failed {
                retry_in: Some(_), ..
            } => {
                if ui.button("Disconnect").clicked() {
                    state.ask_to_leave(false);
                }
            }
            _ => {
                let response = ui
                    .add_enabled(spec.is_ok() && !busy, egui::Button::new("Connect"))
                    .on_disabled_hover_text(
                        spec.as_ref().err().map(|e| e.to_string()).unwrap_or_default(),
                    );
                if response.clicked()
                    && let Ok(spec) = spec.clone()
                {
                    state.request(Request::Connect(spec));
                }
            }
        }
        if let Err(reason) = &spec {
            ui.colored_label(RED, reason.to_string());
        }

        ui.separator();
        ui.label("Poll");
        let poll = ui.add(
            egui::DragValue::new(&mut state.settings.poll_rate)
                .range(1.0..=1000.0)
                .speed(1.0)
                .max_decimals(0)
                .suffix(" Hz"),
        );
        name_widget(&poll, egui::accesskit::Role::SpinButton, "Poll rate");
        poll.on_hover_text("Process-image exchanges per second (the plots sample at this rate)");
        let loss = egui::ComboBox::from_id_salt("on_link_loss")
            .selected_text(format!("link lost: {}", state.settings.on_link_loss.name()))
            .show_ui(ui, |ui| {
                for action in crate::worker::LinkLossAction::ALL {
                    ui.selectable_value(&mut state.settings.on_link_loss, action, action.name());
                }
            });
        name_widget(&loss.response, egui::accesskit::Role::ComboBox, "When the link drops");
        loss.response.on_hover_text(
            "What the worker does when the link fails while the motor may be moving: one last try to halt (default) or switch off, or nothing; the log says whether it reached the drive",
        );
        let after = ui.add(
            egui::DragValue::new(&mut state.settings.lost_after)
                .range(1..=crate::worker::MAX_LOST_AFTER)
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
        match &state.connection {
            Connection::Disconnected => {
                ui.weak("disconnected");
            }
            Connection::Connecting(spec) => {
                ui.spinner();
                ui.label(format!("connecting to {spec}"));
            }
            Connection::Connected(info) => {
                ui.colored_label(GREEN, "connected:");
                ui.label(&info.description);
                if let Some(health) = state.health {
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
    });
    if want_ports {
        state.ask_serial_ports();
    }
}

/// Quickstop and Switch Off, always visible; Esc and Shift+Esc reach them from anywhere.
pub fn stop_strip_ui(ui: &mut Ui, state: &mut AppState) {
    let offline = state.offline_reason().unwrap_or_default();
    let connected = state.is_connected();
    ui.horizontal(|ui| {
        let quickstop = egui::Button::new(
            RichText::new("QUICKSTOP (Esc)")
                .size(17.0)
                .strong()
                .color(Color32::WHITE),
        )
        .fill(RED)
        .min_size(egui::vec2(170.0, 34.0));
        if ui
            .add_enabled(connected, quickstop)
            .on_hover_text("PDI-Cmd 3: brake with the quick stop reaction of 605Ah")
            .on_disabled_hover_text(&offline)
            .clicked()
        {
            state.request(Request::Command(Action::Quickstop));
        }
        let switch_off = egui::Button::new(
            RichText::new("Switch off (Shift+Esc)")
                .size(15.0)
                .color(Color32::BLACK),
        )
        .fill(AMBER)
        .min_size(egui::vec2(150.0, 34.0));
        if ui
            .add_enabled(connected, switch_off)
            .on_hover_text("PDI-Cmd 1: power stage off, motor de-energised (it coasts)")
            .on_disabled_hover_text(&offline)
            .clicked()
        {
            state.request(Request::Command(Action::SwitchOff));
        }
    });
}

/// Esc = Quickstop, Shift+Esc = Switch Off, whatever has focus.
pub fn stop_keys(ctx: &egui::Context, state: &mut AppState) {
    if !state.is_connected() {
        return;
    }
    let (quickstop, switch_off) = ctx.input_mut(|i| {
        let switch_off = i.consume_key(egui::Modifiers::SHIFT, egui::Key::Escape);
        let quickstop = i.consume_key(egui::Modifiers::NONE, egui::Key::Escape);
        (quickstop, switch_off)
    });
    if switch_off {
        state.request(Request::Command(Action::SwitchOff));
    } else if quickstop {
        state.request(Request::Command(Action::Quickstop));
    }
}

/// EtherNet/IP discovery: the interface to broadcast on, and the button.
fn discover_ui(ui: &mut Ui, state: &mut AppState) {
    if state.interfaces.is_none() {
        state.ask_interfaces();
    }
    let interfaces = state.interfaces.clone().unwrap_or_default();
    let form = &mut state.settings.connection;
    let shown = if form.discover_interface.is_empty() {
        "all interfaces".to_owned()
    } else {
        form.discover_interface.clone()
    };
    let picked = egui::ComboBox::from_id_salt("discover_interface")
        .selected_text(shown)
        .width(150.0)
        .show_ui(ui, |ui| {
            ui.selectable_value(
                &mut form.discover_interface,
                String::new(),
                "all interfaces",
            );
            for interface in &interfaces {
                ui.selectable_value(
                    &mut form.discover_interface,
                    interface.name.clone(),
                    interface.label(),
                );
            }
        });
    combo_name(&picked.response, "Discover on");
    let port = form.enip_port.trim().parse::<u16>().unwrap_or(44818);
    let host = Some(form.enip_host.trim().to_owned()).filter(|h| !h.is_empty());
    let interface = Some(form.discover_interface.clone()).filter(|i| !i.is_empty());
    if ui
        .button("Discover")
        .on_hover_text(
            "Find the EtherNet/IP adapters: ListIdentity broadcast on the chosen interface, and asked of the host directly",
        )
        .clicked()
    {
        state.request(Request::Discover {
            interface,
            host,
            port,
        });
    }
}

/// The last bus scan: the nodes found, each with a button to connect to it.
pub fn scan_results_ui(ui: &mut Ui, state: &mut AppState) {
    let Some(result) = state.scan.clone() else {
        return;
    };
    let title = if state.settings.connection.bus == Bus::Enip {
        "EtherNet/IP discovery"
    } else {
        "Bus scan"
    };
    ui.horizontal(|ui| {
        ui.label(RichText::new(title).strong());
        if ui.small_button("Close").clicked() {
            state.scan = None;
        }
    });
    let found = match result {
        Ok(found) => found,
        Err(e) => {
            ui.colored_label(RED, e.to_string());
            return;
        }
    };
    let enip = state.settings.connection.bus == Bus::Enip;
    if found.is_empty() {
        ui.label(if enip {
            "No adapter answered: check the cable, that this computer is in the drive's IP subnet, and that no firewall blocks UDP 44818."
        } else {
            "No node answered: check the bit rate, the wiring and the termination (120 Ω at both ends)."
        });
        return;
    }
    egui::Grid::new("scan_results")
        .num_columns(8)
        .striped(true)
        .show(ui, |ui| {
            for title in [
                "Node", "Vendor", "Product", "Revision", "Serial", "Name", "State", "",
            ] {
                ui.label(RichText::new(title).strong());
            }
            ui.end_row();
            for device in &found {
                let hex = |v: Option<u32>| v.map_or("?".to_owned(), |v| format!("{v:08X}h"));
                ui.label(&device.address);
                ui.label(device.vendor_name());
                ui.monospace(hex(device.product));
                match (device.node, device.revision) {
                    // EtherNet/IP: major.minor.
                    (None, Some(r)) => ui.monospace(format!("{}.{}", r >> 16, r & 0xFFFF)),
                    _ => ui.monospace(hex(device.revision)),
                };
                ui.monospace(hex(device.serial));
                ui.label(device.name.clone().unwrap_or_default());
                ui.label(device.state.clone().unwrap_or_default());
                if let Some(node) = device.node {
                    let use_it = ui.button(format!("Use node {node}"));
                    if use_it.clicked() {
                        state.settings.connection.node = node.to_string();
                        if let Ok(spec) = state.settings.connection.spec() {
                            state.request(Request::Connect(spec));
                        }
                        state.scan = None;
                    }
                } else if let Ok(address) = device.address.parse::<std::net::SocketAddr>() {
                    if ui.button(format!("Use {}", address.ip())).clicked() {
                        let form = &mut state.settings.connection;
                        form.bus = Bus::Enip;
                        form.enip_host = address.ip().to_string();
                        form.enip_port = address.port().to_string();
                        if let Ok(spec) = form.spec() {
                            state.request(Request::Connect(spec));
                        }
                        state.scan = None;
                    }
                } else {
                    ui.label("");
                }
                ui.end_row();
            }
        });
}
