//! The watch panel drawn: the rate and the address box on top, then one row per pinned
//! object with its value in the format chosen, the named bits under it.

use std::time::Duration;

use eframe::egui::{self, Color32, RichText, Ui};

use super::{Format, MAX_PINS, RATES, Reading, bits, format_value};
use crate::od::{Address, Entry};
use crate::ui::drive::Drive;
use crate::ui::widgets::{AMBER, GREEN, RED, choice_ui, name_widget, named_text_edit};

/// The watch panel: ask the next read when one is due, then draw.
pub fn watch_ui(ui: &mut Ui, drive: &mut Drive) {
    refresh(ui.ctx(), drive);
    head_ui(ui, drive);
    ui.separator();
    if drive.settings.watch.pins.is_empty() {
        ui.weak(
            "Nothing watched yet. Pin an object by its address above, with Watch in the \
             object dictionary, or from a plotted object in the plots' Signals menu.",
        );
        return;
    }
    egui::ScrollArea::vertical()
        .id_salt("watch_scroll")
        .auto_shrink([false, false])
        .show(ui, |ui| pins_ui(ui, drive));
}

/// Ask the next read when one is due and come back for the one after.
fn refresh(ctx: &egui::Context, drive: &mut Drive) {
    if !drive.is_connected() || drive.settings.watch.pins.is_empty() {
        return;
    }
    drive.refresh_watch();
    let period = drive.settings.watch.period();
    ctx.request_repaint_after(Duration::from_secs_f64(period / 2.0));
}

fn head_ui(ui: &mut Ui, drive: &mut Drive) {
    ui.horizontal_wrapped(|ui| {
        ui.label(RichText::new("Watch").strong());
        let rate = &mut drive.settings.watch.rate;
        let mut picked = RATES
            .iter()
            .position(|r| (r - *rate).abs() < 1e-9)
            .unwrap_or(2);
        choice_ui(
            ui,
            "watch_rate",
            "watch refresh rate",
            &mut picked,
            &[0, 1, 2, 3, 4, 5],
            rate_name,
            Some(70.0),
        )
        .on_hover_text("How often every pinned object is read again");
        *rate = RATES[picked];
    });
    ui.horizontal(|ui| {
        let typed = named_text_edit(ui, &mut drive.settings.watch.address, 90.0, "watch address")
            .on_hover_text("An object's address: 6041, 6064:00, 1018h:01h");
        let enter = typed.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
        let full = drive.settings.watch.pins.len() >= MAX_PINS;
        if (ui.add_enabled(!full, egui::Button::new("Pin")).clicked() || enter)
            && !drive.settings.watch.address.trim().is_empty()
        {
            let catalog = drive.browser.catalog();
            drive.watch.message = match drive.settings.watch.pin_typed(catalog) {
                Ok(_) => None,
                Err(e) => Some(e.to_string()),
            };
        }
    });
    if let Some(message) = &drive.watch.message {
        ui.colored_label(RED, message);
    }
}

fn rate_name(index: usize) -> &'static str {
    ["0.5 Hz", "1 Hz", "2 Hz", "5 Hz", "10 Hz", "20 Hz"][index.min(RATES.len() - 1)]
}

fn pins_ui(ui: &mut Ui, drive: &mut Drive) {
    let clock = drive.clock;
    let stale_after = 3.0 * drive.settings.watch.period() + 1.0;
    let catalog = drive.browser.catalog();
    let mut unpin = None;
    for pin in drive.settings.watch.pins.iter_mut() {
        let entry = catalog.get(pin.address);
        let reading = drive.watch.reading(pin.address);
        ui.horizontal(|ui| {
            ui.monospace(pin.address.to_string());
            let name = entry
                .map(Entry::full_name)
                .unwrap_or_else(|| "unknown".into());
            ui.add(egui::Label::new(RichText::new(name).strong()).truncate());
        });
        ui.horizontal(|ui| {
            let salt = format!("watch_format_{}", pin.address);
            let label = format!("format of {}", pin.address);
            choice_ui(
                ui,
                &salt,
                &label,
                &mut pin.format,
                &Format::ALL,
                Format::name,
                Some(52.0),
            );
            value_ui(
                ui,
                pin.address,
                entry,
                pin.format,
                reading,
                clock,
                stale_after,
            );
            if ui
                .small_button("Unpin")
                .on_hover_text("Stop watching this object")
                .clicked()
            {
                unpin = Some(pin.address);
            }
        });
        if let (Some(entry), Some(Ok(value)), Format::Bits) =
            (entry, reading.map(|r| &r.result), pin.format)
        {
            bits_ui(ui, &bits(value, entry));
        }
        ui.separator();
    }
    if let Some(address) = unpin {
        drive.settings.watch.unpin(address);
    }
}

/// The value, amber for a second after it changed, dim when it is old, red for a refusal.
fn value_ui(
    ui: &mut Ui,
    address: Address,
    entry: Option<&Entry>,
    format: Format,
    reading: Option<&Reading>,
    clock: f64,
    stale_after: f64,
) {
    let Some(entry) = entry else {
        ui.colored_label(RED, "type unknown: not in the dictionary shown");
        return;
    };
    let Some(reading) = reading else {
        ui.weak("not read yet");
        return;
    };
    match &reading.result {
        Ok(value) => {
            let text = format_value(value, entry, format);
            let changed = reading
                .changed_at
                .is_some_and(|at| clock - at < super::CHANGED_FOR_S);
            let color = if changed {
                AMBER
            } else {
                ui.visuals().strong_text_color()
            };
            let shown = ui.label(RichText::new(&text).monospace().size(15.0).color(color));
            // Screen readers (and the UI tests) hear which object the value is of.
            name_widget(
                &shown,
                egui::accesskit::Role::Label,
                &format!("{address} = {text}"),
            );
            shown.on_hover_text(format!(
                "{} ({}), read {:.1} s ago",
                entry.full_name(),
                entry.dtype.short_name(),
                (clock - reading.at).max(0.0)
            ));
        }
        Err(reason) => {
            ui.colored_label(RED, reason);
        }
    }
    let age = clock - reading.at;
    if age > stale_after {
        ui.weak(format!("({age:.0} s old)"));
    }
}

/// Each named bit as a chip: green and strong when set, dim when clear.
fn bits_ui(ui: &mut Ui, shown: &[(u8, String, bool)]) {
    ui.horizontal_wrapped(|ui| {
        ui.spacing_mut().item_spacing = egui::vec2(8.0, 3.0);
        for (bit, name, on) in shown {
            let text = RichText::new(format!("{bit} {name}"));
            if *on {
                ui.label(text.color(Color32::BLACK).background_color(GREEN));
            } else {
                ui.label(text.weak());
            }
        }
    });
}
