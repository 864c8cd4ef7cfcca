//! Finding devices from the connection bar: the CANopen bus scan, EtherNet/IP discovery,
//! and the devices found, each with a button to connect to it.

use eframe::egui::{self, RichText, Ui};

use super::command::Command;
use super::connection_form::{Bus, FormError};
use super::drive::Drive;
use super::widgets::{RED, name_widget, title_with_close_ui};
use crate::link::{FoundDevice, LinkSpec};
use crate::worker::Request;

/// "Scan bus", on the CANopen buses: find the nodes on the bus the bar describes.
pub(super) fn scan_button_ui(
    ui: &mut Ui,
    drive: &Drive,
    spec: &Result<LinkSpec, FormError>,
    commands: &mut Vec<Command>,
) {
    let is_can = matches!(
        drive.settings.connection.bus,
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
        commands.push(Command::Request(Request::Scan(spec)));
    }
}

/// EtherNet/IP discovery: the interface to broadcast on, and the button.
pub(super) fn discover_ui(ui: &mut Ui, drive: &mut Drive, commands: &mut Vec<Command>) {
    if drive.link.machine.interfaces.is_none() {
        drive.ask_interfaces();
    }
    let interfaces = drive.link.machine.interfaces.clone().unwrap_or_default();
    let form = &mut drive.settings.connection;
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
        commands.push(Command::Request(Request::Discover {
            interface,
            host,
            port,
        }));
    }
}

/// The last bus scan or discovery: the devices found, each with a button to connect to it.
pub fn scan_results_ui(ui: &mut Ui, drive: &mut Drive, commands: &mut Vec<Command>) {
    let Some(result) = drive.scan.clone() else {
        return;
    };
    let enip = drive.settings.connection.bus == Bus::Enip;
    let title = if enip {
        "EtherNet/IP discovery"
    } else {
        "Bus scan"
    };
    if title_with_close_ui(ui, title, None) {
        drive.scan = None;
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
                device_row_ui(ui, drive, device, commands);
                ui.end_row();
            }
        });
}

/// A number the device gave, in hex; `?` where it gave none.
fn hex_or_unknown(value: Option<u32>) -> String {
    value.map_or("?".to_owned(), |v| format!("{v:08X}h"))
}

/// One device found: what it says of itself, and the button to connect to it.
fn device_row_ui(
    ui: &mut Ui,
    drive: &mut Drive,
    device: &FoundDevice,
    commands: &mut Vec<Command>,
) {
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
    use_device_ui(ui, drive, device, commands);
}

/// "Use node 5" or "Use 192.168.2.100": the bar set to the device, and connected to it;
/// "Add as drive": the device as another drive of the list, with its own link.
fn use_device_ui(
    ui: &mut Ui,
    drive: &mut Drive,
    device: &FoundDevice,
    commands: &mut Vec<Command>,
) {
    let mut form = drive.settings.connection.clone();
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
            // The bar now describes the device: connect to it, and close the scan.
            if let Ok(spec) = form.spec() {
                commands.push(Command::Connect(spec));
            }
            drive.settings.connection = form.clone();
            drive.scan = None;
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
            commands.push(Command::AddDriveOn(spec));
        }
    });
}
