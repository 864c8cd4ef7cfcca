//! The status panel: every PDI-Status bit as a lamp, 603Fh with its meaning, ReturnValue,
//! the CiA 402 state from 6041h and the actual values.

use std::time::{Duration, SystemTime};

use eframe::egui::{self, RichText, Ui};

use super::command::Command;
use super::drive::Drive;
use super::widgets::{AMBER, BLUE, GREEN, RED, clipped_label, lamp, value_with_unit};
use crate::cia::{ErrorCode, PowerState};
use crate::injection::Injection;
use crate::pdi::{Opcode, ReturnValue, Status, StatusBit};
use crate::signal::Signal;
use crate::worker::Sample;

fn lamp_color(bit: StatusBit) -> egui::Color32 {
    match bit {
        StatusBit::OperationEnabled | StatusBit::TargetReached => GREEN,
        StatusBit::HomingDone | StatusBit::AutosetupDone | StatusBit::ToggleCmd => BLUE,
        StatusBit::Warning | StatusBit::LimitReached | StatusBit::QsHaltBit => AMBER,
        StatusBit::Fault | StatusBit::FollowingError | StatusBit::Error => RED,
    }
}

/// What ReturnValue holds after the command last sent (PDI spec §2.2), in the words
/// beside it, and on hover.
fn return_value_meaning(last: Option<Opcode>) -> (&'static str, String) {
    let Some(opcode) = last else {
        return (
            "",
            "No command sent from this window yet: what ReturnValue holds depends on the last command".to_owned(),
        );
    };
    let name = opcode.name();
    match opcode.return_value() {
        ReturnValue::Position => (
            "0.1° (position)",
            format!("The actual position, after {name}"),
        ),
        ReturnValue::Velocity => ("rpm (velocity)", format!("The actual speed, after {name}")),
        ReturnValue::Torque => ("‰ (torque)", format!("The actual torque, after {name}")),
        ReturnValue::ObjectRead => (
            "(the object read)",
            format!("The value of the object, after {name}"),
        ),
        ReturnValue::NotSpecified => (
            "",
            format!("After {name} the PDI specification does not say what ReturnValue holds"),
        ),
    }
}

fn mode_name(mode: i8) -> &'static str {
    match mode {
        -2 => "Auto setup",
        -1 => "Clock-direction",
        0 => "No mode",
        1 => "Profile Position",
        2 => "Velocity",
        3 => "Profile Velocity",
        4 => "Profile Torque",
        6 => "Homing",
        7 => "Interpolated Position",
        8 => "Cyclic Sync Position",
        9 => "Cyclic Sync Velocity",
        10 => "Cyclic Sync Torque",
        _ => "unknown",
    }
}

/// How strongly the last known state is drawn while it is not the drive now.
pub const STALE_OPACITY: f32 = 0.4;

pub fn status_ui(ui: &mut Ui, drive: &Drive, commands: &mut Vec<Command>) {
    ui.heading("Drive status");
    let now = SystemTime::now();
    let stale = drive.stale_line(now);
    if let Some(line) = &stale {
        stale_banner(ui, line, drive.offline_reason().as_deref());
        // The "… s ago" keeps counting while nothing else repaints the window.
        let age = drive.link.sample_age(now).unwrap_or(f64::INFINITY);
        if age < 3600.0 {
            ui.ctx()
                .request_repaint_after(Duration::from_millis(if age < 60.0 { 100 } else { 1000 }));
        }
    }
    if drive.link_info().is_some_and(|i| !i.pdi) {
        ui.colored_label(
            AMBER,
            "This device has no Plug & Drive interface (2291h/2292h): object access only, no PDI commands.",
        );
    }
    let Some(sample) = drive.latest() else {
        ui.label("No status yet: connect to a drive.");
        return;
    };
    // The last known state stays readable, but dimmed: it is not the drive now.
    ui.scope(|ui| {
        if stale.is_some() {
            ui.multiply_opacity(STALE_OPACITY);
        }
        sample_ui(ui, &sample, stale.is_some(), drive.last_opcode());
    });
    inject_ui(ui, drive, commands);
}

/// "NO LINK — last seen at …" and why, above the dimmed values.
fn stale_banner(ui: &mut Ui, line: &str, reason: Option<&str>) {
    egui::Frame::new()
        .fill(RED.gamma_multiply(0.18))
        .stroke(egui::Stroke::new(1.0, RED.gamma_multiply(0.7)))
        .corner_radius(4.0)
        .inner_margin(egui::Margin::symmetric(8, 5))
        .show(ui, |ui| {
            ui.set_width(ui.available_width());
            ui.label(RichText::new(line).color(RED).strong().size(15.0))
                .on_hover_text(
                    "The values below are the last ones received, dimmed: the drive may have \
                     changed since. They come live again when the link does.",
                );
            if let Some(reason) = reason {
                clipped_label(ui, RichText::new(reason).color(AMBER), 3);
            }
        });
}

/// The sample's status: power state, lamps, 603Fh, ReturnValue, actual values.
fn sample_ui(ui: &mut Ui, sample: &Sample, stale: bool, last: Option<Opcode>) {
    // The CiA 402 power state first: it says why a command is refused.
    ui.add_space(4.0);
    power_ui(ui, sample, stale);
    ui.add_space(6.0);
    lamps_ui(ui, sample.tx.status);
    ui.add_space(6.0);
    egui::Grid::new("pdi_values")
        .num_columns(2)
        .spacing([8.0, 3.0])
        .show(ui, |ui| {
            error_code_rows_ui(ui, sample);
            return_value_rows_ui(ui, sample, last);
            if let Some(mode) = sample.mode() {
                ui.label("Mode 6061h");
                ui.label(format!("{mode} {}", mode_name(mode)));
                ui.end_row();
            }
            if let Some(word) = sample.statusword() {
                ui.label("Statusword 6041h");
                ui.monospace(format!("{word:04X}h"));
                ui.end_row();
            }
        });
    if sample.position().is_some() {
        ui.add_space(6.0);
        actual_values_ui(ui, sample);
    }
}

/// The CiA 402 power state from 6041h, with its meaning and the state machine.
fn power_ui(ui: &mut Ui, sample: &Sample, stale: bool) {
    let Some(power) = sample.statusword().and_then(PowerState::from_statusword) else {
        ui.label(match sample.statusword() {
            Some(word) => format!("Statusword {word:04X}h matches no CiA 402 state"),
            None => "CiA 402 state unknown (6041h not read on this link)".to_owned(),
        });
        return;
    };
    let color = match power {
        PowerState::OperationEnabled => GREEN,
        PowerState::Fault | PowerState::FaultReactionActive => RED,
        PowerState::QuickStopActive => AMBER,
        _ => ui.visuals().text_color(),
    };
    let name = if stale {
        format!("{} (last known)", power.name())
    } else {
        power.name().to_owned()
    };
    // Its meaning is in the state tile above (and in the tooltip).
    ui.label(RichText::new(name).size(18.0).color(color).strong())
        .on_hover_text(power.meaning());
    ui.add_space(4.0);
    super::power_state::power_state_ui(ui, Some(power));
}

/// Every PDI-Status bit as a lamp, two a row, and the word as the drive sent it.
fn lamps_ui(ui: &mut Ui, status: Status) {
    ui.label(RichText::new("PDI-Status (2292h:01h)").strong());
    egui::Grid::new("pdi_lamps")
        .num_columns(2)
        .spacing([12.0, 2.0])
        .show(ui, |ui| {
            for (i, bit) in StatusBit::ALL.into_iter().enumerate() {
                lamp(
                    ui,
                    status.is_set(bit),
                    lamp_color(bit),
                    bit.label(),
                    &format!("bit {}: {}\n{}", bit.bit(), bit.name(), bit.meaning()),
                );
                if i % 2 == 1 {
                    ui.end_row();
                }
            }
            ui.end_row();
        });
    let undefined = status.undefined_bits();
    ui.horizontal(|ui| {
        ui.weak("raw");
        ui.monospace(format!("{:04X}h", status.0));
        if undefined != 0 {
            ui.colored_label(AMBER, format!("undefined bits {undefined:04X}h"))
                .on_hover_text("Bits 6, 8, 9, 10 and 13 are not defined by the PDI spec; shown as the drive sent them.");
        }
    });
}

/// 603Fh in a grid row (red while the fault bit is set), its meaning in the next one.
fn error_code_rows_ui(ui: &mut Ui, sample: &Sample) {
    ui.label("Error code 603Fh");
    let code = ErrorCode(sample.tx.error_code);
    if code.0 == 0 {
        ui.monospace("0000h (none)");
    } else {
        let color = if sample.tx.status.is_set(StatusBit::Fault) {
            RED
        } else {
            AMBER
        };
        ui.colored_label(color, format!("{:04X}h", code.0))
            .on_hover_text(code.meaning());
    }
    ui.end_row();
    if code.0 != 0 {
        ui.label("");
        ui.label(code.meaning());
        ui.end_row();
    }
}

/// ReturnValue in the unit of the mode, or, after a refused object access, the abort code
/// and its meaning.
fn return_value_rows_ui(ui: &mut Ui, sample: &Sample, last: Option<Opcode>) {
    ui.label("ReturnValue");
    let rv = sample.tx.return_value;
    if sample.tx.status.is_set(StatusBit::Error) {
        let abort = crate::cia::AbortCode(rv as u32);
        ui.colored_label(RED, format!("{:08X}h", rv as u32))
            .on_hover_text(abort.to_string());
        ui.end_row();
        ui.label("");
        ui.label(abort.text().unwrap_or("not a CiA 301 abort code"));
    } else {
        let (unit, meaning) = return_value_meaning(last);
        ui.horizontal(|ui| {
            ui.monospace(rv.to_string());
            if !unit.is_empty() {
                ui.weak(unit);
            }
        })
        .response
        .on_hover_text(meaning);
    }
    ui.end_row();
}

/// Position, velocity, torque, following error, the analog and digital inputs, where the
/// link carries them.
fn actual_values_ui(ui: &mut Ui, sample: &Sample) {
    ui.label(RichText::new("Actual values").strong());
    egui::Grid::new("actual_values")
        .num_columns(2)
        .spacing([8.0, 3.0])
        .show(ui, |ui| {
            for signal in [
                Signal::Position,
                Signal::Velocity,
                Signal::Torque,
                Signal::FollowingError,
                Signal::AnalogInput,
            ] {
                if let Some(v) = sample.get(signal) {
                    ui.label(signal.name());
                    value_with_unit(ui, format!("{v:.0}"), signal.unit());
                    ui.end_row();
                }
            }
            if let Some(inputs) = sample.digital_inputs() {
                ui.label(Signal::DigitalInputs.name());
                ui.monospace(format!("{inputs:08X}h"))
                    .on_hover_text("bit 0 negative limit, bit 1 positive limit, bit 2 home switch");
                ui.end_row();
            }
        });
}

/// The simulator's fault injection, while connected to it.
fn inject_ui(ui: &mut Ui, drive: &Drive, commands: &mut Vec<Command>) {
    if drive.link_info().is_some_and(|i| i.can_inject) {
        ui.add_space(8.0);
        ui.collapsing("Simulator: inject faults", |ui| {
            for injection in Injection::DRIVE {
                let mut active = drive.link.injected.contains(&injection);
                if ui
                    .checkbox(&mut active, injection.name())
                    .on_hover_text(injection.describe())
                    .changed()
                {
                    commands.push(Command::Inject { injection, active });
                }
            }
            ui.small("A fault stays latched after you withdraw it, until Clear Error.");
            ui.separator();
            if ui
                .button("Pull the cable for 3 s")
                .on_hover_text(Injection::LinkLoss.describe())
                .clicked()
            {
                commands.push(Command::Inject {
                    injection: Injection::LinkLoss,
                    active: true,
                });
            }
        });
    }
}
