//! The trigger in view: the condition, the time around it, Arm or Disarm, and where the
//! capture stands.

use eframe::egui::{self, Ui};

use super::trigger::{TriggerForm, edge_text};
use super::view::Plots;
use crate::telemetry::{Builtin, CaptureState, Edge, Kind, bit_name};
use crate::ui::widgets::choice_ui;

/// Arm the trigger as typed (a capture frozen on screen goes: the plots run live again,
/// waiting for the next one).
pub fn arm(p: &mut Plots<'_>) {
    match p.settings.trigger.trigger(&p.drive.scope) {
        Ok(trigger) => {
            let text = p.drive.scope.describe_trigger(&trigger);
            p.drive.scope.arm(trigger);
            if p.view.review.as_ref().is_some_and(|r| r.capture) {
                super::review::close(p.view);
            }
            p.view.message = Some(Ok(format!("armed: {text}")));
        }
        Err(e) => p.view.message = Some(Err(e)),
    }
}

/// A signal the trigger may watch: its id, its name, and which built-in it is.
type Candidate = (String, String, Option<Builtin>);

/// The trigger row: the condition, the time around it, Arm or Disarm, and where it stands.
pub(super) fn trigger_ui(ui: &mut Ui, p: &mut Plots<'_>) {
    ui.label("Trigger");
    let form = &mut p.settings.trigger;
    choice_ui(
        ui,
        "trigger_kind",
        "Trigger kind",
        &mut form.threshold,
        &[false, true],
        |threshold| if threshold { "threshold" } else { "status bit" },
        None,
    );
    let wanted = if form.threshold {
        Kind::Analog
    } else {
        Kind::Bits
    };
    let candidates: Vec<Candidate> = p
        .drive
        .scope
        .signals()
        .iter()
        .filter(|s| s.kind == wanted)
        .map(|s| (s.info.id.clone(), s.info.name.clone(), s.builtin()))
        .collect();
    let builtin = trigger_signal_ui(ui, form, &candidates);
    if form.threshold {
        ui.add(
            egui::TextEdit::singleline(&mut form.level)
                .desired_width(60.0)
                .hint_text("level"),
        )
        .on_hover_text("The level the signal crosses, in its unit");
    } else {
        trigger_bit_ui(ui, form, builtin);
    }
    let edges = [Edge::Rising, Edge::Falling, Edge::Either];
    choice_ui(
        ui,
        "trigger_edge",
        "Trigger edge",
        &mut form.edge,
        &edges,
        edge_text,
        None,
    );
    ui.label("pre [s]");
    ui.add(egui::TextEdit::singleline(&mut form.pre_s).desired_width(36.0))
        .on_hover_text("History kept from before the trigger");
    ui.label("post [s]");
    ui.add(egui::TextEdit::singleline(&mut form.post_s).desired_width(36.0))
        .on_hover_text("Recorded after the trigger");
    arm_ui(ui, p);
}

/// The signal to watch, among `candidates` (the first when the one picked is not among
/// them); which built-in signal it is.
fn trigger_signal_ui(
    ui: &mut Ui,
    form: &mut TriggerForm,
    candidates: &[Candidate],
) -> Option<Builtin> {
    if !candidates.iter().any(|(id, _, _)| *id == form.signal)
        && let Some((id, _, _)) = candidates.first()
    {
        form.signal = id.clone();
    }
    let selected = candidates
        .iter()
        .find(|(id, _, _)| *id == form.signal)
        .map_or_else(String::new, |(_, name, _)| name.clone());
    let combo = egui::ComboBox::from_id_salt("trigger_signal")
        .selected_text(selected)
        .show_ui(ui, |ui| {
            for (id, name, _) in candidates {
                ui.selectable_value(&mut form.signal, id.clone(), name);
            }
        });
    crate::ui::widgets::name_widget(
        &combo.response,
        egui::accesskit::Role::ComboBox,
        "Trigger signal",
    );
    candidates
        .iter()
        .find(|(id, _, _)| *id == form.signal)
        .and_then(|(_, _, b)| *b)
}

/// The bit to watch: PDI-Status's named bits, or any of 32.
fn trigger_bit_ui(ui: &mut Ui, form: &mut TriggerForm, builtin: Option<Builtin>) {
    let bits: Vec<u8> = match builtin {
        Some(Builtin::PdiStatus) => crate::pdi::StatusBit::ALL
            .into_iter()
            .map(|b| b.bit())
            .collect(),
        _ => (0..32).collect(),
    };
    let combo = egui::ComboBox::from_id_salt("trigger_bit")
        .selected_text(bit_name(builtin, form.bit))
        .show_ui(ui, |ui| {
            for bit in bits {
                ui.selectable_value(&mut form.bit, bit, bit_name(builtin, bit));
            }
        });
    crate::ui::widgets::name_widget(
        &combo.response,
        egui::accesskit::Role::ComboBox,
        "Trigger bit",
    );
}

/// Arm the trigger as typed, or disarm it; what the capture is doing.
fn arm_ui(ui: &mut Ui, p: &mut Plots<'_>) {
    let capture = p.drive.scope.capture_state();
    let armed = matches!(capture, CaptureState::Armed | CaptureState::Fired { .. });
    if armed {
        if ui.button("Disarm").clicked() {
            p.drive.scope.disarm();
            p.view.message = Some(Ok("trigger disarmed".into()));
        }
    } else if ui
        .button("Arm")
        .on_hover_text("Wait for the condition, then record the time around it")
        .clicked()
    {
        arm(p);
    }
    match capture {
        CaptureState::Idle => ui.weak("not armed"),
        CaptureState::Armed => ui.strong("armed, waiting"),
        CaptureState::Fired { at } => ui.strong(format!("fired at {at:.3} s, recording")),
        CaptureState::Complete { from, at, to } => {
            ui.label(format!("recorded {:.2} s around {at:.3} s", to - from))
        }
    };
}
