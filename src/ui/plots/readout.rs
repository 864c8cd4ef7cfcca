//! What the plots say in numbers: the values under the pointer (or the newest ones), and
//! the two cursors A and B with Δt and, per signal, the value at each and Δvalue.

use eframe::egui::Ui;

use super::model::{shown_scope, time_range, time_under, with_turns};
use super::view::Plots;
use crate::telemetry::{Kind, Ring, Scope, format_number};

/// The values under the pointer (or the newest ones) of every signal drawn; the cursors'
/// read-out instead while one is placed.
pub fn readout_ui(ui: &mut Ui, p: &mut Plots<'_>) {
    if p.view.cursors.iter().any(Option::is_some) {
        cursors_ui(ui, p);
        return;
    }
    let pointer = pointer_time(ui, p);
    let scope = shown_scope(p.view, p.drive);
    let ring = scope.ring();
    let at = pointer.or(ring.last_time());
    let Some(at) = at else {
        ui.weak("no samples yet");
        return;
    };
    let Some(row) = ring.index_at_or_before(at) else {
        return;
    };
    ui.horizontal_wrapped(|ui| {
        let what = if pointer.is_some() {
            "pointer"
        } else {
            "latest"
        };
        ui.monospace(format!("{what} t = {:.3} s", ring.time(row).unwrap_or(at)))
            .on_hover_text("Click a plot to place cursor A, right-click for cursor B");
        for signal in scope.signals().iter().filter(|s| scope.is_drawn(s)) {
            let Some(v) = value_near(ring, row, signal.column) else {
                continue;
            };
            let text = match signal.kind {
                Kind::Analog => format!("{} {}", format_number(v), signal.info.unit),
                Kind::Bits => format!("{:04X}h", v as u32),
            };
            ui.monospace(format!(
                "| {}: {}",
                shown_id(&signal.info.id),
                text.trim_end()
            ));
        }
        // How to place the cursors is said on the time's hover: a line of its own, or a
        // wrapped tail, would come off the plots' height.
    });
}

/// A signal's id as the read-out says it: an object of the dictionary as the rest of the
/// window writes it ("6041h:00"; its id in files stays "6041h_00h"), the built-in ones as
/// they are ("position").
pub fn shown_id(id: &str) -> String {
    let object = id
        .strip_suffix('h')
        .and_then(|rest| rest.split_once("h_"))
        .filter(|(index, sub)| {
            index.len() == 4
                && sub.len() == 2
                && index
                    .chars()
                    .chain(sub.chars())
                    .all(|c| c.is_ascii_hexdigit())
        });
    match object {
        Some((index, sub)) => format!("{index}h:{sub}"),
        None => id.to_owned(),
    }
}

/// The time on the axis under the pointer, when it is over a plot (and no menu or dialog
/// covers it): where the plots were drawn in the last frame, on the span they are drawn on
/// in this one. The read-out comes before the plots, and a pan or zoom asked in the last
/// frame is drawn in this one: the time is the one the axis shows under the pointer now.
fn pointer_time(ui: &Ui, p: &Plots<'_>) -> Option<f64> {
    let pos = ui.input(|i| i.pointer.hover_pos())?;
    if ui.ctx().layer_id_at(pos) != Some(ui.layer_id()) {
        return None;
    }
    let span = time_range(p.view, p.drive, p.settings.window_s)?;
    time_under(&p.view.drawn, (pos.x, pos.y), span)
}

/// The cursors: "A 1.200 s  B 1.700 s  Δt 0.500 s", then per analog signal the change
/// from A to B (positions also in degrees and revolutions), its values at A and B on
/// hover.
fn cursors_ui(ui: &mut Ui, p: &mut Plots<'_>) {
    let [a, b] = p.view.cursors;
    let scope = shown_scope(p.view, p.drive);
    let rows = cursor_rows(scope, a, b);
    let mut clear = false;
    // One wrapped line (the plots under it move as little as can be): the times, then
    // each signal's values and change.
    ui.horizontal_wrapped(|ui| {
        ui.strong(cursor_times(a, b));
        clear = ui.small_button("Clear cursors").clicked();
        for [name, at_a, at_b, delta] in rows {
            ui.monospace(format!("| {name}: Δ {delta}"))
                .on_hover_text(format!("at A {at_a}\nat B {at_b}"));
        }
    });
    if clear {
        p.view.cursors = [None; 2];
    }
}

/// "A 1.200 s  B 1.700 s  Δt 0.500 s", with "–" for a cursor not placed.
pub fn cursor_times(a: Option<f64>, b: Option<f64>) -> String {
    let at = |t: Option<f64>| t.map_or_else(|| "–".to_owned(), |t| format!("{t:.3} s"));
    let mut text = format!("A {}  B {}", at(a), at(b));
    if let (Some(a), Some(b)) = (a, b) {
        text.push_str(&format!("  Δt {:.3} s", b - a));
    }
    text
}

/// The cursors' table: per analog signal drawn, its name, the value at A, at B, and B − A.
pub fn cursor_rows(scope: &Scope, a: Option<f64>, b: Option<f64>) -> Vec<[String; 4]> {
    let ring = scope.ring();
    let value_at = |t: Option<f64>, column: usize| {
        t.and_then(|t| ring.index_at_or_before(t))
            .and_then(|row| value_near(ring, row, column))
    };
    scope
        .signals()
        .iter()
        .filter(|s| scope.is_drawn(s) && s.kind == Kind::Analog)
        .map(|signal| {
            let unit = signal.info.unit.as_str();
            let (va, vb) = (value_at(a, signal.column), value_at(b, signal.column));
            let cell = |v: Option<f64>| v.map_or_else(|| "–".to_owned(), |v| with_turns(v, unit));
            let delta = match (va, vb) {
                (Some(va), Some(vb)) => with_turns(vb - va, unit),
                _ => "–".to_owned(),
            };
            [signal.info.name.clone(), cell(va), cell(vb), delta]
        })
        .collect()
}

/// The channel's value at `row`, or the nearest one before it within a few samples (a
/// signal read round robin is not in every row).
fn value_near(ring: &Ring, row: usize, column: usize) -> Option<f64> {
    (0..=32)
        .filter_map(|back| row.checked_sub(back))
        .filter_map(|i| ring.value(i, column))
        .find(|v| !v.is_nan())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::telemetry::{ChannelInfo, Metadata, Recording};

    #[test]
    fn an_object_is_read_out_as_the_window_writes_it() {
        assert_eq!(shown_id("6041h_00h"), "6041h:00");
        assert_eq!(shown_id("2031h_0Ah"), "2031h:0A");
        assert_eq!(shown_id("position"), "position");
        assert_eq!(shown_id("pdi_status"), "pdi_status");
        assert_eq!(shown_id("60xxh_00h"), "60xxh_00h");
    }

    #[test]
    fn the_cursors_say_the_time_between_them_and_each_signals_change() {
        let recording = Recording {
            meta: Metadata::default(),
            channels: vec![
                ChannelInfo {
                    id: "position".into(),
                    name: "Position 6064h".into(),
                    unit: "0.1°".into(),
                },
                ChannelInfo {
                    id: "velocity".into(),
                    name: "Velocity 606Ch".into(),
                    unit: "rpm".into(),
                },
            ],
            times: vec![0.0, 0.5, 1.0, 1.5],
            columns: vec![
                vec![0.0, 900.0, 1800.0, 3600.0],
                vec![0.0, 100.0, 300.0, 300.0],
            ],
            markers: Vec::new(),
        };
        let scope = Scope::from_recording(&recording).expect("scope");
        assert_eq!(
            cursor_times(Some(0.5), Some(1.5)),
            "A 0.500 s  B 1.500 s  Δt 1.000 s"
        );
        assert_eq!(cursor_times(Some(0.5), None), "A 0.500 s  B –");
        let rows = cursor_rows(&scope, Some(0.5), Some(1.5));
        assert_eq!(
            rows[0],
            [
                "Position 6064h".to_owned(),
                "900 0.1° = 90.0° = 0.250 rev".to_owned(),
                "3600 0.1° = 360.0° = 1.000 rev".to_owned(),
                "2700 0.1° = 270.0° = 0.750 rev".to_owned()
            ]
        );
        assert_eq!(rows[1][3], "200 rpm");
        let rows = cursor_rows(&scope, None, Some(1.0));
        assert_eq!(
            rows[1][1..],
            ["–".to_owned(), "300 rpm".to_owned(), "–".to_owned()]
        );
    }
}
