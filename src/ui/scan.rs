//! Finding devices from the connection bar: the CANopen bus scan, EtherNet/IP discovery,
//! and the devices found, each with a button to connect to it.

use eframe::egui::{self, RichText, Ui};

use super::state::{AppState, Bus, FormError};
use super::widgets::{RED, name_widget, title_with_close_ui};
use crate::link::{FoundDevice, LinkSpec};
use crate::worker::Request;

/// "Scan bus", on the CANopen buses: find the nodes on the bus the bar describes.
pub(super) fn scan_button_ui(
    ui: &mut Ui,
    state: &mut AppState,
    spec: &Result<LinkSpec, FormError>,
) {
    let is_can = matches!(
        state.settings.connection.bus,
        Bus::CanopenSim | Bus::CanopenSlcan | Bus::CanopenSocketcan
    );
    if is_can
        && ui
            .add_enabled(spec.is_ok(), egui::Button::new("Scan bus"))
            .on_hover_text(
                "Find the CANopen nodes on this bus: heartbeats, and 1018h read from every node id",
            )
            .clicked()
        && let Ok(spec) = spec.clone()
    {
        state.request(Request::Scan(spec));
    }
}

/// EtherNet/IP discovery: the interface to broadcast on, and the button.
pub(super) fn discover_ui(ui: &mut Ui, state: &mut AppState) {
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
    name_widget(
        &picked.response,
        egui::accesskit::Role::ComboBox,
        "Discover on",
    );
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

/// The last bus scan or discovery: the devices found, each with a button to connect to it.
pub fn scan_results_ui(ui: &mut Ui, state: &mut AppState) {
    let Some(result) = state.scan.clone() else {
        return;
    };
    let enip = state.settings.connection.bus == Bus::Enip;
    let title = if enip {
        "EtherNet/IP discovery"
    } else {
        "Bus scan"
    };
    if title_with_close_ui(ui, title, None) {
        state.scan = None;
    }
    let found = match result {
        Ok(found) => found,
        Err(e) => {
            ui.colored_label(RED, e.to_string());
            return;
        }
    };
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
                device_row_ui(ui, state, device);
                ui.end_row();
            }
        });
}

/// A number the device gave, in hex; `?` where it gave none.
fn hex_or_unknown(value: Option<u32>) -> String {
    value.map_or("?".to_owned(), |v| format!("{v:08X}h"))
}

/// One device found: what it says of itself, and the button to connect to it.
fn device_row_ui(ui: &mut Ui, state: &mut AppState, device: &FoundDevice) {
    ui.label(&device.address);
    ui.label(device.vendor_name());
    ui.monospace(hex_or_unknown(device.product));
    match (device.node, device.revision) {
        // EtherNet/IP: major.minor.
        (None, Some(r)) => ui.monospace(format!("{}.{}", r >> 16, r & 0xFFFF)),
        _ => ui.monospace(hex_or_unknown(device.revision)),
    };
    ui.monospace(hex_or_unknown(device.serial));
    ui.label(device.name.clone().unwrap_or_default());
    ui.label(device.state.clone().unwrap_or_default());
    use_device_ui(ui, state, device);
}

/// "Use node 5" or "Use 192.168.2.100": the bar set to the device, and connected to it;
/// "Add as drive": the device as another drive of the list, with its own link.
fn use_device_ui(ui: &mut Ui, state: &mut AppState, device: &FoundDevice) {
    let mut form = state.settings.connection.clone();
    let label = if let Some(node) = device.node {
        form.node = node.to_string();
        format!("Use node {node}")
    } else if let Ok(address) = device.address.parse::<std::net::SocketAddr>() {
        form.bus = Bus::Enip;
        form.enip_host = address.ip().to_string();
        form.enip_port = address.port().to_string();
        format!("Use {}", address.ip())
    } else {
        ui.label("");
        return;
    };
    ui.horizontal(|ui| {
        if ui.button(&label).clicked() {
            state.settings.connection = form.clone();
            connect_to_form(state);
        }
        let spec = form.spec();
        let add = ui
            .add_enabled(spec.is_ok(), egui::Button::new("Add as drive"))
            .on_hover_text("Another drive in the list, with its own link to this device");
        name_widget(
            &add,
            egui::accesskit::Role::Button,
            &format!("Add {} as drive", device.address),
        );
        if add.clicked()
            && let Ok(spec) = spec
        {
            state.wanted_drives.push(spec);
        }
    });
}

/// Connect to what the bar now describes, and close the scan.
fn connect_to_form(state: &mut AppState) {
    if let Ok(spec) = state.settings.connection.spec() {
        state.request(Request::Connect(spec));
    }
    state.scan = None;
}
