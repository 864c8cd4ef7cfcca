//! The browser panel: its toolbar, EDS loading, the bulk reads, and how values and limits read.

use eframe::egui::{self, RichText, Ui};

use super::backup_view::{backup_ui, comparison_ui, restore_ui};
use super::edit;
use super::table::{table_keys, table_ui};
use super::{Browser, DictionarySettings, MOST_READS_PER_SECOND, Purpose, REFRESH_AFTER, Tone};
use crate::od::backup;
use crate::od::eds::Eds;
use crate::od::{Address, DataType, Entry, Value};
use crate::ui::command::Command;
use crate::ui::drive::Drive;
use crate::ui::widgets::{AMBER, GREEN, RED, labelled_text_edit_ui};

pub(super) fn value_text(value: &Value, entry: &Entry) -> String {
    backup::shown(value, entry)
}

pub(super) fn limits_text(entry: &Entry) -> String {
    match (&entry.min, &entry.max) {
        (Some(min), Some(max)) => format!("{min} … {max}"),
        (Some(min), None) => format!(">= {min}"),
        (None, Some(max)) => format!("<= {max}"),
        (None, None) => String::new(),
    }
}

pub(super) fn age_text(clock: f64, at: f64) -> String {
    let age = (clock - at).max(0.0);
    if age < 1.0 {
        "now".into()
    } else if age < 120.0 {
        format!("{age:.0} s ago")
    } else {
        format!("{:.0} min ago", age / 60.0)
    }
}

pub fn browser_ui(
    ui: &mut Ui,
    drive: &mut Drive,
    settings: &mut DictionarySettings,
    commands: &mut Vec<Command>,
) {
    let connected = drive.is_connected();
    let link = drive
        .link_info()
        .map(|i| i.spec.to_string())
        .unwrap_or_default();
    let watched: Vec<Address> = drive
        .settings
        .watch
        .pins
        .iter()
        .map(|p| p.address)
        .collect();
    let b = &mut drive.browser;
    // "" while not connected; a new connection is `Browser::on_connected`'s.
    b.source.text = link;
    b.set_clock(drive.clock);
    // Before any text box can take them.
    let keys = table_keys(ui, b);
    let rate = &mut settings.reads_per_second;

    // The tab above says what this is: no heading, the rows get the room. Each group
    // (a label and its box, a bar and its button) stays on one line when the rows wrap.
    ui.horizontal_wrapped(|ui| {
        together(ui, 330.0, |ui| {
            labelled_text_edit_ui(ui, "Filter", &mut b.filter, 160.0, "Object filter");
            ui.weak(format!(
                "{} of {} objects",
                b.rows().len(),
                b.catalog().len()
            ));
        });
        read_buttons_ui(ui, b, connected);
        together(ui, 130.0, |ui| auto_read_ui(ui, rate));
    });
    ui.horizontal_wrapped(|ui| {
        together(ui, 300.0, |ui| bulk_ui(ui, b));
        together(ui, 360.0, |ui| {
            dictionary_ui(ui, b);
            labelled_text_edit_ui(ui, "EDS", &mut b.files.eds, 160.0, "EDS path");
            if ui
                .button("Load EDS")
                .on_hover_text("Use a device's EDS file (CiA 306) instead of the built-in catalog")
                .clicked()
            {
                load_eds(b);
            }
        });
    });
    backup_ui(ui, b, connected);
    message_ui(ui, b);
    comparison_ui(ui, b);
    restore_ui(ui, b, connected);
    edit::confirm_ui(ui, b);
    table_ui(ui, b, commands, (connected, &watched), keys);
    b.refresh_visible(connected, *rate);
}

/// Read visible and Read all.
fn read_buttons_ui(ui: &mut Ui, b: &mut Browser, connected: bool) {
    let readable = Browser::readable(&b.rows());
    let busy = b.bulk.is_some();
    if ui
        .add_enabled(connected && !busy, egui::Button::new("Read visible"))
        .on_hover_text("Read the rows on screen")
        .clicked()
    {
        let visible: Vec<(Address, DataType)> = b
            .visible
            .iter()
            .filter_map(|a| b.catalog().get(*a))
            .filter(|e| e.access.readable())
            .map(|e| (e.address, e.dtype))
            .collect();
        b.read_many(visible, Purpose::Browse);
    }
    if ui
        .add_enabled(connected && !busy, egui::Button::new("Read all"))
        .on_hover_text(
            "Read every object that passes the filter, with progress; the motor keeps running",
        )
        .clicked()
    {
        b.read_many(readable, Purpose::Browse);
    }
}

/// In a wrapping row: `add` on one line, on the next one when less than `width` is left.
fn together(ui: &mut Ui, width: f32, add: impl FnOnce(&mut Ui)) {
    if ui.available_rect_before_wrap().width() < width
        && ui.cursor().left() > ui.max_rect().left() + 1.0
    {
        ui.end_row();
    }
    ui.horizontal(add);
}

/// How many objects a second the table reads by itself (0: none).
fn auto_read_ui(ui: &mut Ui, rate: &mut f64) {
    ui.label("Auto-read");
    let field = ui
        .add(
            egui::DragValue::new(rate)
                .range(0.0..=MOST_READS_PER_SECOND)
                .speed(1.0)
                .max_decimals(0)
                .suffix(" /s"),
        )
        .on_hover_text(format!(
            "The rows on screen are read by themselves, this many objects a second at most, \
             again when their value is older than {REFRESH_AFTER:.0} s; a value that changed is \
             lit for a while. 0: only on request."
        ));
    crate::ui::widgets::name_widget(
        &field,
        egui::accesskit::Role::SpinButton,
        "Auto-read objects per second",
    );
}

/// The dictionary shown: an EDS's (with the way back to the built-in one), or the built-in.
fn dictionary_ui(ui: &mut Ui, b: &mut Browser) {
    match &b.eds {
        Some((path, _)) => {
            ui.weak(format!("dictionary: {path}"));
            if ui.small_button("Built-in").clicked() {
                b.eds = None;
            }
        }
        None => {
            ui.weak("built-in catalog").on_hover_text(
                "The objects of Nanotec's drives, as built in; Load EDS for another device's",
            );
        }
    }
}

/// Warnings shown in the message line; the rest are counted (all go to the log).
const EDS_WARNINGS_SHOWN: usize = 3;

fn load_eds(b: &mut Browser) {
    let path = b.files.eds.trim().to_owned();
    if path.is_empty() {
        b.say(Tone::Failed, "give the path of an EDS or DCF file first");
        return;
    }
    // A CANopen link's node id resolves the file's $NODEID formulas (COB-IDs).
    let node_id = match b.source.text.parse::<crate::link::LinkSpec>() {
        Ok(
            crate::link::LinkSpec::CanopenSocketcan { can, .. }
            | crate::link::LinkSpec::CanopenSlcan { can, .. }
            | crate::link::LinkSpec::CanopenSim { can },
        ) => Some(can.node),
        _ => None,
    };
    match Eds::load(std::path::Path::new(&path), node_id) {
        Ok(eds) => {
            let merged = eds.merged_with(crate::od::builtin());
            for w in &eds.warnings {
                tracing::warn!("{path}: {w}");
            }
            let (tone, text) = eds_loaded_text(&eds, merged.catalog.len(), &path);
            b.say(tone, text);
            b.values.clear();
            b.eds = Some((path, merged.catalog));
        }
        Err(e) => b.say(Tone::Failed, format!("{path}: {e}")),
    }
}

/// What a loaded EDS says: how many objects from which device; with what the import
/// skipped or guessed, counted, the first few named, in amber.
fn eds_loaded_text(eds: &Eds, objects: usize, path: &str) -> (Tone, String) {
    let mut text = format!(
        "loaded {objects} objects from {path} ({} {})",
        crate::text::shown(
            eds.device_info
                .vendor_name
                .as_deref()
                .unwrap_or("unknown vendor")
        ),
        crate::text::shown(
            eds.device_info
                .product_name
                .as_deref()
                .unwrap_or("unknown product")
        ),
    );
    if eds.warnings.is_empty() {
        return (Tone::Done, text);
    }
    let shown: Vec<String> = eds
        .warnings
        .iter()
        .take(EDS_WARNINGS_SHOWN)
        .map(ToString::to_string)
        .collect();
    text.push_str(&format!(
        "; {} warning(s), entries skipped or guessed: {}",
        eds.warnings.len(),
        shown.join("; ")
    ));
    if eds.warnings.len() > EDS_WARNINGS_SHOWN {
        text.push_str(" (the rest in the log)");
    }
    (Tone::Warning, text)
}

/// The progress row of a bulk read. Always drawn (idle: empty, Cancel disabled), so the
/// widgets below never jump when a read starts or ends: a click aimed at Cancel as the
/// read completes must not land on the button that moved under the pointer.
fn bulk_ui(ui: &mut Ui, b: &mut Browser) {
    let (fraction, text, id, cancelled) = match &b.bulk {
        Some(bulk) => {
            let what = match &bulk.purpose {
                Purpose::Browse => "Reading",
                Purpose::Backup { .. } => "Reading for the backup",
                Purpose::Compare(_) => "Reading to compare",
                Purpose::Restore(_) => "Reading before the restore",
            };
            (
                bulk.done as f32 / bulk.total.max(1) as f32,
                format!("{what}: {} of {}", bulk.done, bulk.total),
                bulk.id,
                bulk.cancelled,
            )
        }
        None => (0.0, "no read running".to_owned(), None, false),
    };
    ui.scope(|ui| {
        let mut bar = egui::ProgressBar::new(fraction)
            .text(text)
            .desired_width(220.0);
        if id.is_none() {
            // Idle: no coloured fill, only the text.
            bar = bar.fill(ui.visuals().extreme_bg_color);
        }
        ui.add(bar);
        if ui
            .add_enabled(id.is_some() && !cancelled, egui::Button::new("Cancel"))
            .on_hover_text("Stop the read: what is not read yet is dropped")
            .clicked()
            && let Some(id) = id
        {
            b.cancel_bulk(id);
        }
    });
}

/// The colour of a message of the browser; `None`: the text colour.
pub fn tone_color(tone: Tone) -> Option<egui::Color32> {
    match tone {
        Tone::Done => Some(GREEN),
        Tone::Info => None,
        Tone::Warning => Some(AMBER),
        Tone::Failed => Some(RED),
    }
}

/// The message line: in its outcome's colour; one from an earlier connection is dimmed
/// and says where it came from.
pub(super) fn message_ui(ui: &mut Ui, b: &Browser) {
    let Some(message) = &b.message else {
        return;
    };
    let earlier = message.earlier(b.connection());
    let mut text = if earlier {
        RichText::new(format!(
            "[{}, earlier connection] {}",
            message.link, message.text
        ))
    } else {
        RichText::new(&message.text)
    };
    if let Some(color) = tone_color(message.tone) {
        text = text.color(if earlier {
            color.gamma_multiply(0.6)
        } else {
            color
        });
    } else if earlier {
        text = text.weak();
    }
    ui.add(egui::Label::new(text).wrap());
}
