//! Small widgets shared by the panels.

use eframe::egui::{self, Color32, Response, RichText, Sense, Ui, Vec2, WidgetInfo};

pub const GREEN: Color32 = Color32::from_rgb(60, 200, 90);
pub const AMBER: Color32 = Color32::from_rgb(240, 180, 40);
pub const RED: Color32 = Color32::from_rgb(230, 60, 50);
pub const BLUE: Color32 = Color32::from_rgb(70, 150, 240);
pub const OFF: Color32 = Color32::from_gray(70);

/// A status lamp: a coloured dot and a label. Screen readers (and UI tests) see it as a
/// read-only checkbox named by its label, checked when lit.
pub fn lamp(ui: &mut Ui, on: bool, color: Color32, label: &str, tooltip: &str) -> Response {
    ui.horizontal(|ui| {
        let size = Vec2::splat(ui.text_style_height(&egui::TextStyle::Body));
        let (rect, response) = ui.allocate_exact_size(size, Sense::hover());
        let fill = if on { color } else { OFF };
        ui.painter()
            .circle_filled(rect.center(), rect.height() * 0.38, fill);
        if on {
            ui.painter().circle_stroke(
                rect.center(),
                rect.height() * 0.45,
                egui::Stroke::new(1.0, color.gamma_multiply(0.5)),
            );
        }
        let text = if on {
            RichText::new(label).strong()
        } else {
            RichText::new(label).weak()
        };
        let label_response = ui.label(text);
        let response = response.union(label_response);
        response
            .widget_info(|| WidgetInfo::selected(egui::accesskit::Role::CheckBox, true, on, label));
        response.on_hover_text(tooltip)
    })
    .inner
}

/// A number with its unit, right-aligned in a grid cell.
pub fn value_with_unit(ui: &mut Ui, value: String, unit: &str) {
    ui.horizontal(|ui| {
        ui.monospace(value);
        if !unit.is_empty() {
            ui.weak(unit);
        }
    });
}

/// Give a widget its accessible name (screen readers and UI tests find it by this).
pub fn name_widget(response: &Response, role: egui::accesskit::Role, name: &str) {
    response.widget_info(|| WidgetInfo::labeled(role, response.enabled(), name));
}

/// A single-line text box with an accessible name.
pub fn named_text_edit(ui: &mut Ui, text: &mut String, width: f32, name: &str) -> Response {
    let response = ui.add(egui::TextEdit::singleline(text).desired_width(width));
    name_widget(&response, egui::accesskit::Role::TextInput, name);
    response
}

/// A text box the keyboard reached with Tab has its text selected, so what is typed
/// replaces it, as in any desktop form (egui puts the cursor at the end: Tab into a port
/// box holding "1502", type "502", and it read "1502502"). `before`: the widget that had
/// the focus when the frame began.
pub fn select_all_on_tab(ctx: &egui::Context, before: Option<egui::Id>) {
    if !ctx.input(|i| i.key_pressed(egui::Key::Tab)) {
        return;
    }
    let Some(now) = ctx.memory(|m| m.focused()) else {
        return;
    };
    if Some(now) == before {
        return;
    }
    if let Some(mut state) = egui::TextEdit::load_state(ctx, now) {
        // The end is clamped to the text's length where the range is used.
        let all = egui::text::CCursorRange::two(
            egui::text::CCursor::new(0),
            egui::text::CCursor::new(usize::MAX),
        );
        state.cursor.set_char_range(Some(all));
        state.store(ctx, now);
    }
}

/// A wrapped label of at most `max_rows` rows, elided with "…" beyond; the whole text on
/// hover (and to screen readers). For reasons that can run long (a link's error text).
pub fn clipped_label(ui: &mut Ui, text: RichText, max_rows: usize) -> Response {
    let job = egui::WidgetText::from(text).into_layout_job(
        ui.style(),
        egui::FontSelection::Default,
        ui.text_valign(),
    );
    let mut job = std::sync::Arc::unwrap_or_clone(job);
    job.wrap.max_rows = max_rows;
    ui.add(egui::Label::new(job).wrap())
}

/// A label and, beside it, a single-line text box with an accessible name.
pub fn labelled_text_edit_ui(
    ui: &mut Ui,
    label: &str,
    text: &mut String,
    width: f32,
    name: &str,
) -> Response {
    ui.label(label);
    named_text_edit(ui, text, width, name)
}

/// A drop-down of `choices`, each shown as `label` gives it, with an accessible name;
/// `width` as egui's default when `None`.
pub fn choice_ui<T: Copy + PartialEq>(
    ui: &mut Ui,
    id_salt: &str,
    name: &str,
    value: &mut T,
    choices: &[T],
    label: fn(T) -> &'static str,
    width: Option<f32>,
) -> Response {
    let mut combo = egui::ComboBox::from_id_salt(id_salt).selected_text(label(*value));
    if let Some(width) = width {
        combo = combo.width(width);
    }
    let picked = combo.show_ui(ui, |ui| {
        for &choice in choices {
            ui.selectable_value(value, choice, label(choice));
        }
    });
    name_widget(&picked.response, egui::accesskit::Role::ComboBox, name);
    picked.response
}

/// The outcome of the last action of a panel: green when it went well, red when not.
pub fn message_ui(ui: &mut Ui, message: Option<&Result<String, String>>) {
    match message {
        Some(Ok(text)) => {
            ui.colored_label(GREEN, text);
        }
        Some(Err(text)) => {
            ui.colored_label(RED, text);
        }
        None => {}
    }
}

/// A striped grid of `columns` in a scroll area that fills the panel and keeps the newest
/// row, at the bottom, in view (the log's tables).
pub fn log_grid_ui(ui: &mut Ui, id_salt: &str, columns: usize, rows_ui: impl FnOnce(&mut Ui)) {
    egui::ScrollArea::vertical()
        .stick_to_bottom(true)
        .auto_shrink([false, false])
        .show(ui, |ui| {
            egui::Grid::new(id_salt)
                .num_columns(columns)
                .striped(true)
                .spacing([10.0, 2.0])
                .show(ui, rows_ui);
        });
}

/// A section's title, a note beside it, and its Close button: `true` when that is clicked.
pub fn title_with_close_ui(ui: &mut Ui, title: &str, note: Option<&str>) -> bool {
    // Wrapped: a long note (a device's whole identity) stays within a narrow window.
    ui.horizontal_wrapped(|ui| {
        ui.label(RichText::new(title).strong());
        if let Some(note) = note {
            ui.weak(note);
        }
        ui.small_button("Close").clicked()
    })
    .inner
}
