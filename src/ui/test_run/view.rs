//! The Test tab: the form (test move or velocity steps), Run and Stop, where the run
//! stands; the runs of this session with a tick for the comparison; the compared runs'
//! figures side by side with each step's; and their signals overlaid, a marker where each
//! step began.

use eframe::egui::{self, Color32, RichText, Ui};
use egui_plot::{Legend, Line, Plot, VLine};

use super::model::{Kind, Run, TestRuns};
use crate::telemetry::test_run::{Spread, StepReport};
use crate::ui::drive::Drive;
use crate::ui::widgets::{AMBER, BLUE, message_ui, name_widget};

/// The id of the Test tab.
pub const TEST: &str = "test";

/// The compared runs' colours, in the order ticked.
const COLORS: [Color32; 2] = [BLUE, AMBER];

enum Intent {
    Run,
    Stop,
    Toggle(usize),
    Clear,
    Save,
}

pub fn test_ui(ui: &mut Ui, drive: &mut Drive) {
    let runs = drive.panels.get::<TestRuns>();
    let mut intents = Vec::new();
    form_ui(ui, runs, &mut intents);
    ui.separator();
    let height = ui.available_height();
    ui.horizontal_top(|ui| {
        ui.set_min_height(height);
        let list_width = (ui.available_width() * 0.3).clamp(180.0, 320.0);
        ui.vertical(|ui| {
            ui.set_width(list_width);
            runs_list_ui(ui, runs, &mut intents);
        });
        ui.separator();
        ui.vertical(|ui| {
            // The room left, kept: a wide table scrolls instead of pushing the plot out.
            let width = ui.available_width();
            ui.set_max_width(width);
            let compared = runs.compared_runs();
            if compared.is_empty() {
                ui.weak(
                    "Run a test: its figures show here, and ticking two runs compares them \
                     and overlays their response.",
                );
                return;
            }
            egui::ScrollArea::both()
                .id_salt("test_figures")
                .max_width(width)
                .max_height((ui.available_height() * 0.5).max(120.0))
                .show(ui, |ui| figures_ui(ui, &compared));
            overlay_ui(ui, &compared, width);
        });
    });
    for intent in intents {
        match intent {
            Intent::Run => runs.start(),
            Intent::Stop => runs.stop(),
            Intent::Toggle(n) => runs.toggle_compared(n),
            Intent::Clear => runs.clear(),
            Intent::Save => runs.save_newest(),
        }
    }
}

fn field(ui: &mut Ui, label: &str, text: &mut String, width: f32, enabled: bool) {
    ui.label(label);
    let response = ui.add_enabled(
        enabled,
        egui::TextEdit::singleline(text).desired_width(width),
    );
    name_widget(
        &response,
        egui::accesskit::Role::TextInput,
        &format!("test {label}"),
    );
}

fn form_ui(ui: &mut Ui, runs: &mut TestRuns, intents: &mut Vec<Intent>) {
    let idle = !runs.is_running();
    // The test, Run or Stop, and where it stands.
    ui.horizontal(|ui| {
        ui.add_enabled_ui(idle, |ui| {
            ui.selectable_value(&mut runs.form.kind, Kind::Move, "Test move");
            ui.selectable_value(&mut runs.form.kind, Kind::Velocity, "Velocity steps");
        });
        ui.separator();
        if idle {
            let button = ui
                .add_enabled(runs.is_connected(), egui::Button::new("Run test"))
                .on_hover_text("Move to the start, then run every step, measuring each")
                .on_disabled_hover_text("not connected");
            if button.clicked() {
                intents.push(Intent::Run);
            }
        } else if ui
            .button(RichText::new("Stop test").color(AMBER))
            .on_hover_text("Halt the drive and keep the steps measured so far (Esc quick-stops)")
            .clicked()
        {
            intents.push(Intent::Stop);
        }
        if let Some(progress) = runs.progress() {
            ui.spinner();
            ui.label(progress);
        }
    });
    // Its settings.
    ui.horizontal_wrapped(|ui| {
        let form = &mut runs.form;
        match form.kind {
            Kind::Move => {
                field(ui, "from", &mut form.from, 60.0, idle);
                field(ui, "to", &mut form.to, 60.0, idle);
                field(ui, "speed", &mut form.speed, 50.0, idle);
                ui.weak("rpm");
                field(ui, "dwell", &mut form.dwell, 40.0, idle);
            }
            Kind::Velocity => {
                field(ui, "speed", &mut form.speed, 50.0, idle);
                ui.weak("rpm");
                field(ui, "hold", &mut form.dwell, 40.0, idle);
            }
        }
        ui.weak("s");
        field(ui, "cycles", &mut form.cycles, 40.0, idle);
        field(ui, "band", &mut form.band, 50.0, idle);
    });
    ui.horizontal_wrapped(|ui| {
        ui.weak(match runs.form.kind {
            Kind::Move => "Back and forth between from and to (0.1°); band: the settling band, 1 % of the step if empty.",
            Kind::Velocity => "Steps 0 → v → −v → 0 rpm, each held; band in rpm, 1 % of v if empty.",
        });
        message_ui(ui, runs.message.as_ref());
    });
}

fn runs_list_ui(ui: &mut Ui, runs: &mut TestRuns, intents: &mut Vec<Intent>) {
    ui.horizontal(|ui| {
        ui.strong(format!("Runs ({})", runs.runs.len()));
        if ui
            .add_enabled(!runs.runs.is_empty(), egui::Button::new("Clear runs"))
            .clicked()
        {
            intents.push(Intent::Clear);
        }
    });
    ui.horizontal(|ui| {
        let field = ui.add(egui::TextEdit::singleline(&mut runs.save_path).desired_width(110.0));
        name_widget(&field, egui::accesskit::Role::TextInput, "test run file");
        if ui
            .add_enabled(!runs.compared.is_empty(), egui::Button::new("Save run"))
            .on_hover_text(
                "The newest ticked run as a recording (CSV, or JSON for .json): its response \
                 and a marker with the figures at each step; Open recording… shows it",
            )
            .clicked()
        {
            intents.push(Intent::Save);
        }
    });
    egui::ScrollArea::vertical()
        .id_salt("test_runs")
        .show(ui, |ui| {
            for run in runs.runs.iter().rev() {
                let ticked = runs.compared.iter().position(|n| *n == run.number);
                let mut on = ticked.is_some();
                let text = match ticked {
                    Some(k) => RichText::new(&run.title).color(COLORS[k % COLORS.len()]),
                    None => RichText::new(&run.title),
                };
                if ui
                    .checkbox(&mut on, text)
                    .on_hover_text("Compare and overlay (two at a time)")
                    .changed()
                {
                    intents.push(Intent::Toggle(run.number));
                }
                if let Some(why) = &run.ended_early {
                    ui.colored_label(AMBER, format!("  ended early: {why}"));
                }
            }
        });
}

fn cell(value: Option<f64>, digits: usize) -> String {
    value.map_or("–".to_owned(), |v| format!("{v:.digits$}"))
}

fn spread_cell(spread: Option<Spread>, digits: usize) -> String {
    spread.map_or("–".to_owned(), |s| {
        format!("{:.digits$} / {:.digits$}", s.mean, s.worst)
    })
}

/// A row of the comparison: its name, the figure's spread in a run, its decimals.
type FigureRow = (&'static str, fn(&Run) -> Option<Spread>, usize);

/// The compared runs' summaries side by side, then each one's steps.
fn figures_ui(ui: &mut Ui, compared: &[&Run]) {
    egui::Grid::new("test_summary")
        .striped(true)
        .spacing([14.0, 2.0])
        .show(ui, |ui| {
            ui.strong("mean / worst");
            for (k, run) in compared.iter().enumerate() {
                ui.label(
                    RichText::new(format!("Run {}", run.number))
                        .color(COLORS[k % 2])
                        .strong(),
                );
            }
            ui.end_row();
            let rows: [FigureRow; 6] = [
                ("rise time [s]", |r| r.summary.rise_time_s, 3),
                ("overshoot [%]", |r| r.summary.overshoot_pct, 1),
                ("settling time [s]", |r| r.summary.settling_time_s, 3),
                ("steady-state error", |r| r.summary.steady_state_error, 1),
                (
                    "peak following error",
                    |r| r.summary.peak_following_error,
                    1,
                ),
                (
                    "to TargetReached [s]",
                    |r| r.summary.time_to_target_reached_s,
                    3,
                ),
            ];
            for (name, figure, digits) in rows {
                ui.label(name);
                for run in compared {
                    ui.monospace(spread_cell(figure(run), digits));
                }
                ui.end_row();
            }
        });
    for (k, run) in compared.iter().enumerate() {
        ui.add_space(4.0);
        ui.label(RichText::new(&run.title).color(COLORS[k % 2]));
        steps_ui(ui, run);
    }
}

fn steps_ui(ui: &mut Ui, run: &Run) {
    egui::Grid::new(("test_steps", run.number))
        .striped(true)
        .spacing([10.0, 1.0])
        .show(ui, |ui| {
            for heading in [
                "cycle",
                "from",
                "to",
                "rise s",
                "overshoot %",
                "settle s",
                "ss error",
                "FE peak",
                "FE rms",
                "reached s",
            ] {
                ui.weak(heading);
            }
            ui.end_row();
            for s in &run.steps {
                step_row_ui(ui, s);
            }
        });
}

fn step_row_ui(ui: &mut Ui, s: &StepReport) {
    ui.monospace(s.cycle.to_string());
    ui.monospace(s.from.to_string());
    ui.monospace(s.to.to_string());
    ui.monospace(cell(s.rise_time_s, 3));
    ui.monospace(cell(s.overshoot_pct, 1));
    ui.monospace(cell(s.settling_time_s, 3));
    ui.monospace(cell(s.steady_state_error, 1));
    ui.monospace(cell(s.peak_following_error, 1));
    ui.monospace(cell(s.rms_following_error, 1));
    ui.monospace(cell(s.time_to_target_reached_s, 3));
    ui.end_row();
}

/// The compared runs' signals on one time axis (from each run's first step), a marker at
/// each step's start.
fn overlay_ui(ui: &mut Ui, compared: &[&Run], width: f32) {
    let unit = match compared.first().map(|r| r.signal) {
        Some(crate::signal::Signal::Velocity) => "velocity [rpm]",
        _ => "position [0.1°]",
    };
    Plot::new("test_overlay")
        .legend(Legend::default())
        .width(width)
        .height(ui.available_height().max(120.0))
        .x_axis_label("time from the first step [s]")
        .y_axis_label(unit)
        .show(ui, |plot_ui| {
            for (k, run) in compared.iter().enumerate() {
                let color = COLORS[k % 2];
                plot_ui.line(
                    Line::new(format!("Run {}", run.number), run.trace.clone())
                        .color(color)
                        .width(1.5),
                );
                for at in &run.step_starts {
                    plot_ui.add(
                        VLine::new("", *at)
                            .color(color.gamma_multiply(0.4))
                            .width(1.0)
                            .allow_hover(false),
                    );
                }
            }
        });
}
