//! The object table: Object and Name pinned on the left, the other columns scrolled
//! sideways under one bar, a row picked by a click and edited in place.
//!
//! egui_extras' `TableBuilder` owns a table's vertical `ScrollArea`. Two tables side by
//! side (pinned and scrolled) can only follow each other a frame late: a `ScrollArea`
//! applies the wheel, kinetic scrolling and its bar's drag when it ends, after its rows
//! are laid out. And a table inside a horizontal `ScrollArea` has its vertical bar at the
//! far end of its content, out of view whenever it is scrolled. So this is one table of
//! three columns, Object, Name and a window onto the other columns, which each row draws
//! shifted left by `Columns::scroll`: the pinned and the scrolled cells of a row are laid
//! out in the same pass and cannot drift apart, and the vertical bar stays at the panel's
//! edge. The sideways offset moves with the bar under the window, a horizontal wheel or
//! Shift+wheel over the table; a column's width by dragging its header's right edge.

use eframe::egui::{self, Rect, Response, Sense, Ui, UiBuilder};
use egui_extras::{Column, TableBuilder, TableRow};

use super::edit::{edit_box_ui, edit_buttons_ui, edit_note_ui};
use super::editing;
use super::panel::{age_text, limits_text, value_text};
use super::refresh::change_glow;
use super::{Browser, Edit};
use crate::od::backup;
use crate::od::{Address, DataType, Entry};
use crate::ui::command::{Command, Said};
use crate::ui::widgets::{AMBER, GREEN, RED};

/// The scrolled columns, left to right: title and first width.
const SCROLLED: [(&str, f32); 8] = [
    ("Value", 150.0),
    ("", 210.0),
    ("Hex", 96.0),
    ("Type", 50.0),
    ("Access", 50.0),
    ("Default", 90.0),
    ("Limits", 120.0),
    ("Read", 64.0),
];
const VALUE: usize = 0;
const ACTIONS: usize = 1;
/// Space between two scrolled columns.
const GAP: f32 = 8.0;
const ROW: f32 = 22.0;
/// The bar under the scrolled columns.
const BAR: f32 = 10.0;

/// The scrolled columns' widths and how far they are scrolled sideways.
#[derive(Clone, Debug, PartialEq)]
pub struct Columns {
    pub widths: [f32; SCROLLED.len()],
    /// How far (points) the scrolled columns are shifted left.
    pub scroll: f32,
    /// The table width the Name and Value columns were last fitted to; `None` once the
    /// user sized a column by hand.
    fitted_to: Option<f32>,
    /// The Name column's width in the last frame (a change the fitting did not make is
    /// the user's).
    name_seen: f32,
}

impl Default for Columns {
    fn default() -> Self {
        Self {
            widths: SCROLLED.map(|(_, width)| width),
            scroll: 0.0,
            fitted_to: Some(0.0),
            name_seen: 0.0,
        }
    }
}

impl Columns {
    /// The Name and Value columns take a share of the table's `width` (see
    /// [`name_width`] and [`value_width`]), so a narrow panel still shows the row's
    /// buttons beside the value and a wide one the whole names, until the user drags a
    /// column's edge. `true` when they were fitted anew.
    fn fit(&mut self, width: f32) -> bool {
        let Some(fitted_to) = self.fitted_to else {
            return false;
        };
        if width <= 0.0 || (width - fitted_to).abs() < 1.0 {
            return false;
        }
        self.fitted_to = Some(width);
        if let Some(value) = self.widths.get_mut(VALUE) {
            *value = value_width(width);
        }
        true
    }

    /// The Name column is `width` wide now: resized by the user when the fitting did not
    /// change it.
    fn name_drawn(&mut self, width: f32, refitted: bool) {
        if !refitted && self.name_seen > 0.0 && (width - self.name_seen).abs() > 0.5 {
            self.fitted_to = None;
        }
        self.name_seen = width;
    }

    /// Each column's left and right edge from the scrolled window's left, unscrolled.
    fn spans(&self) -> [(f32, f32); SCROLLED.len()] {
        let mut left = 0.0;
        self.widths.map(|width| {
            let span = (left, left + width);
            left += width + GAP;
            span
        })
    }

    /// All the scrolled columns side by side.
    fn width(&self) -> f32 {
        self.widths.iter().sum::<f32>() + GAP * (SCROLLED.len() - 1) as f32
    }

    /// Keep the offset within what there is to scroll in a window `view` wide.
    fn clamp(&mut self, view: f32) {
        self.scroll = self.scroll.clamp(0.0, (self.width() - view).max(0.0));
    }

    /// Where column `i` is in a row whose window is `cell`, and whether any of it shows.
    fn rect(&self, i: usize, cell: Rect, y: egui::Rangef) -> Option<Rect> {
        let (left, right) = self.spans().get(i).copied()?;
        let x0 = cell.left() - self.scroll + left;
        let x1 = cell.left() - self.scroll + right;
        (x1 > cell.left() && x0 < cell.right()).then(|| Rect::from_x_y_ranges(x0..=x1, y))
    }
}

/// What the user did in a row.
pub(super) enum RowAction {
    Select,
    Read,
    Plot,
    Watch,
    Edit,
    Typed(String),
    Submit,
    CancelEdit,
    /// The edit box took the keyboard.
    Focused,
}

/// The keys of the table, read before anything else takes them: Enter edits the selected
/// row, the up and down arrows move the selection. Only while no text box has the
/// keyboard and no dialog is open.
pub(super) fn table_keys(ui: &Ui, b: &Browser) -> (Option<(Address, RowAction)>, Option<usize>) {
    let busy = ui.ctx().egui_wants_keyboard_input()
        || ui.ctx().memory(|m| m.top_modal_layer().is_some())
        || b.edit.is_some()
        || b.confirm.is_some();
    if busy {
        return (None, None);
    }
    let (enter, up, down) = ui.input(|i| {
        (
            i.key_pressed(egui::Key::Enter),
            i.key_pressed(egui::Key::ArrowUp),
            i.key_pressed(egui::Key::ArrowDown),
        )
    });
    let rows = b.rows();
    let at = b
        .selected
        .and_then(|s| rows.iter().position(|e| e.address == s));
    let to = match (at, up, down) {
        (Some(at), true, false) => Some(at.saturating_sub(1)),
        (Some(at), false, true) => Some((at + 1).min(rows.len().saturating_sub(1))),
        (None, true, _) | (None, _, true) => Some(0),
        _ => None,
    };
    if let Some(to) = to
        && let Some(entry) = rows.get(to)
    {
        return (Some((entry.address, RowAction::Select)), Some(to));
    }
    match (enter, b.selected) {
        (true, Some(address)) => (Some((address, RowAction::Edit)), None),
        _ => (None, None),
    }
}

/// The table: its rows (those drawn become `b.visible`), what was done in them applied.
pub(super) fn table_ui(
    ui: &mut Ui,
    b: &mut Browser,
    commands: &mut Vec<Command>,
    (connected, watched): (bool, &[Address]),
    keys: (Option<(Address, RowAction)>, Option<usize>),
) {
    let rows: Vec<Entry> = b.rows().into_iter().cloned().collect();
    let area = ui.available_rect_before_wrap();
    let mut columns = b.columns.clone();
    let refitted = columns.fit(area.width());
    sideways_wheel(ui, area, &mut columns);
    let (key_action, scroll_to) = keys;
    let mut actions: Vec<(Address, RowAction)> = key_action.into_iter().collect();
    let mut visible = vec![];
    let table_rect = area.with_max_y((area.max.y - BAR - 2.0).max(area.min.y));
    ui.scope_builder(UiBuilder::new().max_rect(table_rect), |ui| {
        // Labels take no clicks: a click anywhere on a row picks it.
        ui.style_mut().interaction.selectable_labels = false;
        let mut builder = with_columns(TableBuilder::new(ui), area.width());
        if refitted {
            // The Name column starts again from its share of the new width.
            builder.reset();
        }
        if let Some(row) = scroll_to {
            builder = builder.scroll_to_row(row, None);
        }
        let mut window = Rect::NOTHING;
        let mut name = 0.0;
        let mut table = builder.header(ROW, |mut header| {
            header.col(|ui| {
                ui.strong("Object");
            });
            header.col(|ui| {
                name = ui.max_rect().width();
                ui.strong("Name");
            });
            header.col(|ui| window = ui.max_rect());
        });
        columns.name_drawn(name, refitted);
        columns.clamp(window.width());
        let bar = Rect::from_x_y_ranges(window.x_range(), (table_rect.max.y + 2.0)..=area.max.y);
        sideways_bar_ui(table.ui_mut(), bar, &mut columns);
        scrolled_header_ui(table.ui_mut(), window, &mut columns);
        let view = TableView {
            b,
            columns: &columns,
            connected,
            watched,
        };
        let heights: Vec<f32> = rows.iter().map(|e| view.height(e)).collect();
        table.body(|body| {
            body.heterogeneous_rows(heights.into_iter(), |mut row| {
                let Some(entry) = rows.get(row.index()) else {
                    return;
                };
                visible.push(entry.address);
                entry_row(&mut row, &view, entry, &mut actions);
            });
        });
    });
    ui.allocate_rect(area, Sense::hover());
    b.columns = columns;
    b.visible = visible;
    for (address, action) in actions {
        apply_row_action(b, commands, address, action);
    }
}

/// The Name column's width in a table `width` wide: three tenths (130 to 420 points), so
/// that on a wide screen the objects' names ("Modes of operation display", "Following
/// error window") show whole.
fn name_width(width: f32) -> f32 {
    (width * 0.3).clamp(130.0, 420.0)
}

/// The Value column's width in a table `width` wide: a little more than a fifth (110 to
/// 220 points).
fn value_width(width: f32) -> f32 {
    (width * 0.22).clamp(110.0, 220.0)
}

/// The table's look and its columns: Object and Name, then the window onto the rest.
fn with_columns(table: TableBuilder<'_>, width: f32) -> TableBuilder<'_> {
    let name = name_width(width);
    table
        .id_salt("od_table")
        .striped(true)
        .resizable(true)
        .sense(Sense::click())
        .auto_shrink([false, false])
        .min_scrolled_height(120.0)
        .column(Column::initial(76.0).at_least(64.0))
        .column(Column::initial(name).at_least(90.0).clip(true))
        .column(Column::remainder().at_least(120.0).clip(true))
}

/// A horizontal wheel (or Shift+wheel) over the table moves the scrolled columns; the
/// vertical one is the table's own.
fn sideways_wheel(ui: &mut Ui, area: Rect, columns: &mut Columns) {
    if !ui.rect_contains_pointer(area) {
        return;
    }
    let dx = ui.input(|i| i.smooth_scroll_delta.x);
    if dx != 0.0 {
        columns.scroll -= dx;
        ui.input_mut(|i| i.smooth_scroll_delta.x = 0.0);
    }
}

/// The bar under the scrolled columns: drag its handle, or click the track to move there.
fn sideways_bar_ui(ui: &mut Ui, track: Rect, columns: &mut Columns) {
    let view = track.width();
    let content = columns.width();
    if content <= view || view <= 0.0 {
        return;
    }
    let response = ui.interact(
        track,
        ui.scope_id().with("od_sideways_bar"),
        Sense::click_and_drag(),
    );
    crate::ui::widgets::name_widget(
        &response,
        egui::accesskit::Role::ScrollBar,
        "Scroll the columns sideways",
    );
    let handle = (view / content * view).max(24.0).min(view);
    let travel = (view - handle).max(1.0);
    let range = content - view;
    if response.dragged() {
        columns.scroll += response.drag_delta().x * range / travel;
    } else if response.clicked()
        && let Some(at) = response.interact_pointer_pos()
    {
        columns.scroll = (at.x - track.left() - handle / 2.0) / travel * range;
    }
    columns.clamp(view);
    let x = track.left() + columns.scroll / range * travel;
    let knob = Rect::from_min_size(
        egui::pos2(x, track.top()),
        egui::vec2(handle, track.height()),
    );
    let painter = ui.painter();
    painter.rect_filled(track, 3.0, ui.visuals().extreme_bg_color);
    painter.rect_filled(
        knob.shrink(1.0),
        3.0,
        ui.style().interact(&response).bg_fill,
    );
}

/// The titles of the scrolled columns, each one's right edge a handle to resize it.
fn scrolled_header_ui(ui: &mut Ui, window: Rect, columns: &mut Columns) {
    for (i, (title, _)) in SCROLLED.iter().enumerate() {
        let Some(rect) = columns.rect(i, window, window.y_range()) else {
            continue;
        };
        let mut child = scrolled_child(ui, rect, window, ("od_head", i));
        child.strong(*title);
        let edge =
            Rect::from_x_y_ranges((rect.right() - 3.0)..=(rect.right() + 3.0), rect.y_range());
        let handle = ui.interact(edge, ui.scope_id().with(("od_resize", i)), Sense::drag());
        if handle.hovered() || handle.dragged() {
            ui.ctx().set_cursor_icon(egui::CursorIcon::ResizeHorizontal);
            let stroke = ui.visuals().widgets.hovered.fg_stroke;
            ui.painter().with_clip_rect(window).vline(
                rect.right() + GAP / 2.0,
                window.y_range(),
                stroke,
            );
        }
        if handle.dragged()
            && let Some(width) = columns.widths.get_mut(i)
        {
            *width = (*width + handle.drag_delta().x).max(30.0);
            columns.fitted_to = None;
        }
    }
}

/// A child of `ui` drawing one scrolled cell at `rect`, clipped to the window.
fn scrolled_child(ui: &mut Ui, rect: Rect, window: Rect, salt: impl egui::AsIdSalt) -> Ui {
    let mut child = ui.new_child(
        UiBuilder::new()
            .id_salt(salt)
            .max_rect(rect)
            .layout(egui::Layout::left_to_right(egui::Align::Center)),
    );
    child.set_clip_rect(rect.intersect(window).intersect(ui.clip_rect()));
    child
}

/// What the rows are drawn from.
struct TableView<'a> {
    b: &'a Browser,
    columns: &'a Columns,
    connected: bool,
    /// What the watch panel holds already.
    watched: &'a [Address],
}

impl TableView<'_> {
    /// The value being typed into `entry`'s row, if it is.
    fn editing(&self, entry: &Entry) -> Option<&Edit> {
        self.b.edit.as_ref().filter(|e| e.address == entry.address)
    }

    /// A row being edited has a second line, for why the value is refused.
    fn height(&self, entry: &Entry) -> f32 {
        if self.editing(entry).is_some() {
            2.0 * ROW
        } else {
            ROW
        }
    }
}

/// One object's row: Object and Name, then its scrolled cells; a click picks it, a
/// double-click edits it.
fn entry_row(
    row: &mut TableRow<'_, '_>,
    view: &TableView<'_>,
    entry: &Entry,
    actions: &mut Vec<(Address, RowAction)>,
) {
    row.set_selected(view.b.selected == Some(entry.address));
    row.col(|ui| {
        ui.monospace(entry.address.to_string());
    });
    row.col(|ui| {
        let name = ui.add(egui::Label::new(entry.full_name()).truncate());
        if !entry.description.is_empty() {
            name.on_hover_text(&entry.description);
        }
    });
    row.col(|ui| scrolled_cells_ui(ui, view, entry, actions));
    let response = row.response();
    if response.double_clicked() {
        actions.push((entry.address, RowAction::Select));
        actions.push((entry.address, RowAction::Edit));
    } else if response.clicked() {
        actions.push((entry.address, RowAction::Select));
    }
}

/// The cells of the scrolled columns that show in the window; under a value being
/// edited, why it is refused.
fn scrolled_cells_ui(
    ui: &mut Ui,
    view: &TableView<'_>,
    entry: &Entry,
    actions: &mut Vec<(Address, RowAction)>,
) {
    let window = ui.max_rect();
    let line = egui::Rangef::new(window.top(), window.top() + ROW);
    for i in 0..SCROLLED.len() {
        let Some(rect) = view.columns.rect(i, window, line) else {
            continue;
        };
        let mut child = scrolled_child(ui, rect, window, ("od_cell", i));
        cell_ui(&mut child, i, view, entry, actions);
    }
    if let Some(edit) = view.editing(entry)
        && let Some((left, _)) = view.columns.spans().get(VALUE).copied()
    {
        let x0 = window.left() - view.columns.scroll + left;
        let under = Rect::from_x_y_ranges(x0..=window.right(), line.max..=window.bottom());
        edit_note_ui(ui, under.intersect(window), entry, edit);
    }
}

/// Scrolled column `i` of `entry`'s row.
fn cell_ui(
    ui: &mut Ui,
    i: usize,
    view: &TableView<'_>,
    entry: &Entry,
    actions: &mut Vec<(Address, RowAction)>,
) {
    let cell = view.b.values.get(&entry.address);
    let value = cell.and_then(|c| c.result.as_ref().ok());
    match i {
        VALUE => value_cell_ui(ui, view, entry, actions),
        ACTIONS => match view.editing(entry) {
            Some(_) => edit_buttons_ui(ui, entry, actions),
            None => row_buttons_ui(ui, view, entry, actions),
        },
        2 => {
            if let Some(value) = value {
                ui.monospace(value.to_hex(entry.dtype));
            }
        }
        3 => {
            ui.label(entry.dtype.short_name());
        }
        4 => {
            ui.label(entry.access.short_name());
        }
        5 => {
            if let Some(default) = &entry.default {
                ui.label(backup::shown(default, entry));
            }
        }
        6 => {
            ui.label(limits_text(entry));
        }
        _ => {
            if let Some(cell) = cell {
                ui.weak(age_text(view.b.now, cell.at));
            }
        }
    }
}

/// The value: the box it is typed into, or as last read (a refusal in red), lit for a
/// while when it changed since the read before.
fn value_cell_ui(
    ui: &mut Ui,
    view: &TableView<'_>,
    entry: &Entry,
    actions: &mut Vec<(Address, RowAction)>,
) {
    let cell = view.b.values.get(&entry.address);
    if let Some(edit) = view.editing(entry) {
        edit_box_ui(ui, entry, edit, ui.max_rect().width() - 4.0, actions);
        return;
    }
    if let Some(Err(e)) = view.b.write_results.get(&entry.address) {
        ui.colored_label(RED, e).on_hover_text(e);
        return;
    }
    let Some(cell) = cell else {
        ui.weak("?");
        return;
    };
    // The highlight goes under the text, drawn once the text is.
    let behind = ui.painter().add(egui::Shape::Noop);
    let label = match &cell.result {
        Ok(value) => ui.label(value_text(value, entry)),
        Err(e) => ui.colored_label(RED, e).on_hover_text(e),
    };
    if let Some((at, before)) = &cell.changed {
        // No repaint asked for the fading: values change only while connected, and the
        // samples of a link repaint the window every cycle.
        let glow = change_glow(view.b.now - at);
        if glow > 0.0 {
            let lit =
                egui::Shape::rect_filled(ui.max_rect(), 2.0, AMBER.gamma_multiply(0.35 * glow));
            ui.painter().set(behind, lit);
        }
        label.on_hover_text(format!(
            "changed {} (was {})",
            age_text(view.b.now, *at),
            backup::shown(before, entry)
        ));
    }
}

/// A row's small button, named "<what> <address>" for screen readers.
pub(super) fn row_button_ui(
    ui: &mut Ui,
    enabled: bool,
    text: &str,
    what: &str,
    address: Address,
) -> Response {
    let button = ui.add_enabled(enabled, egui::Button::new(text).small());
    crate::ui::widgets::name_widget(
        &button,
        egui::accesskit::Role::Button,
        &format!("{what} {address}"),
    );
    button
}

/// Read, Plot (what can be sampled), Watch (pin to the watch panel) and Edit; "written" after a write went through.
fn row_buttons_ui(
    ui: &mut Ui,
    view: &TableView<'_>,
    entry: &Entry,
    actions: &mut Vec<(Address, RowAction)>,
) {
    let address = entry.address;
    let readable = entry.access.readable();
    if row_button_ui(ui, view.connected && readable, "Read", "Read", address).clicked() {
        actions.push((address, RowAction::Read));
    }
    let plottable = readable
        && (entry.dtype.is_integer()
            || matches!(
                entry.dtype,
                DataType::Boolean | DataType::Real32 | DataType::Real64
            ));
    if plottable
        && row_button_ui(ui, true, "Plot", "Plot", address)
            .on_hover_text("Sample it every cycle and add it to the plots")
            .clicked()
    {
        actions.push((address, RowAction::Plot));
    }
    if readable
        && row_button_ui(
            ui,
            !view.watched.contains(&address),
            "Watch",
            "Watch",
            address,
        )
        .on_hover_text("Pin it to the watch panel: read again at the panel's rate")
        .on_disabled_hover_text("in the watch panel already")
        .clicked()
    {
        actions.push((address, RowAction::Watch));
    }
    let writable = entry.access.writable();
    let edit = row_button_ui(ui, view.connected && writable, "Edit", "Edit", address)
        .on_hover_text("Or double-click the row, or Enter on it")
        .on_disabled_hover_text(if writable {
            "not connected"
        } else {
            "read-only: the drive does not take writes to it"
        });
    if edit.clicked() {
        actions.push((address, RowAction::Edit));
    }
    if let Some(Ok(())) = view.b.write_results.get(&address) {
        ui.colored_label(GREEN, "written");
    }
}

fn apply_row_action(
    b: &mut Browser,
    commands: &mut Vec<Command>,
    address: Address,
    action: RowAction,
) {
    let Some(entry) = b.catalog().get(address).cloned() else {
        return;
    };
    match action {
        RowAction::Select => b.selected = Some(address),
        RowAction::Read => b.read_one(address, entry.dtype),
        RowAction::Plot => commands.push(Command::PlotObject {
            text: address.to_string(),
            from: Said::Dictionary,
        }),
        RowAction::Watch => commands.push(Command::PinToWatch {
            address,
            from: Said::Dictionary,
        }),
        RowAction::Edit => {
            let connected = !b.source.text.is_empty();
            if connected && entry.access.writable() {
                editing::start_edit(b, &entry);
            }
        }
        RowAction::Typed(text) => editing::typed(b, &entry, text),
        RowAction::CancelEdit => b.edit = None,
        RowAction::Submit => editing::submit_edit(b, &entry),
        RowAction::Focused => {
            if let Some(edit) = b.edit.as_mut() {
                edit.focus = false;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn name_and_value_follow_the_table_width_until_sized_by_hand() {
        let mut columns = Columns::default();
        assert!(columns.fit(500.0));
        assert_eq!(columns.widths[VALUE], 110.0);
        assert!(!columns.fit(500.0), "the same width: nothing to do");
        assert!(columns.fit(800.0));
        assert_eq!(columns.widths[VALUE], 176.0);
        assert!(columns.fit(2000.0));
        assert_eq!(columns.widths[VALUE], 220.0);
        assert_eq!(name_width(2000.0), 420.0);
        assert_eq!(name_width(1000.0), 300.0);
        assert_eq!(name_width(400.0), 130.0);
        // The Name column as fitted, then dragged by the user: the fitting stops.
        columns.name_drawn(300.0, true);
        columns.name_drawn(300.0, false);
        assert!(columns.fitted_to.is_some());
        columns.name_drawn(340.0, false);
        assert_eq!(columns.fitted_to, None);
        columns.widths[VALUE] = 300.0;
        assert!(!columns.fit(500.0));
        assert_eq!(columns.widths[VALUE], 300.0, "the user's width stays");
    }

    #[test]
    fn the_sideways_offset_stays_within_what_there_is_to_scroll() {
        let mut columns = Columns::default();
        let all = columns.width();
        columns.scroll = 10_000.0;
        columns.clamp(300.0);
        assert_eq!(columns.scroll, all - 300.0);
        columns.clamp(all + 50.0);
        assert_eq!(columns.scroll, 0.0, "everything fits: nothing to scroll");
    }
}
