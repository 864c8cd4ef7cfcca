//! The plot panel in view: its toolbar (pause, follow, window, clear, the signals drawn,
//! the history), then the recording under review, the trigger and exports, the read-out,
//! and the stacked plots.

use eframe::egui::{self, Ui};

use super::capture;
use super::exports::Beside;
use super::exports_view;
use super::model::{PlotSettings, PlotView, PositionUnit, shown_scope};
use super::picture;
use super::readout;
use super::review;
use super::review_view;
use super::traces;
use crate::od::Address;
use crate::ui::command::PlotCommand;
use crate::ui::command::{Command, Said};
use crate::ui::drive::Drive;

/// What the plot panel's views work on: the window's plot view and choices, the drive
/// shown (its history, trigger and identity), the drives drawn beside it, and where the
/// user's intents go.
pub struct Plots<'a> {
    pub view: &'a mut PlotView,
    pub settings: &'a mut PlotSettings,
    pub drive: &'a mut Drive,
    pub beside: &'a [Beside<'a>],
    pub commands: &'a mut Vec<Command>,
}

/// The plot panel alone, with a drive of its own (the benches, `drivedeck bench`, tests
/// of the panel): its intents are applied to it as the window would.
pub struct Alone {
    pub view: PlotView,
    pub settings: PlotSettings,
    pub drive: Drive,
}

impl Alone {
    /// The panel with the window's default choices (`history_rows` samples kept).
    pub fn new(history_rows: usize) -> Alone {
        let settings = PlotSettings {
            history_rows,
            ..PlotSettings::default()
        };
        let drive = Drive::new(
            "Drive 1".into(),
            0,
            crate::ui::settings::DriveSettings::default(),
            history_rows,
            &[],
        );
        Alone {
            view: PlotView::default(),
            settings,
            drive,
        }
    }

    /// A worker event for the panel's drive, and what it means for the plots (a capture
    /// frozen on screen), as the window applies it.
    pub fn apply_event(&mut self, event: crate::worker::Event) {
        if let Some(crate::ui::drive::News::Captured(text)) = self.drive.apply(event) {
            self.view.captured(text, &self.drive.scope);
        }
    }

    /// A command for the plots, as the window applies it.
    pub fn apply(&mut self, command: PlotCommand) {
        let newest = self.drive.sample_time();
        self.view.apply(command, newest, self.settings.window_s);
    }

    /// The span the plots show.
    pub fn time_range(&self) -> Option<(f64, f64)> {
        super::model::time_range(&self.view, &self.drive, self.settings.window_s)
    }

    /// The history the plots draw.
    pub fn shown_scope(&self) -> &crate::telemetry::Scope {
        shown_scope(&self.view, &self.drive)
    }

    /// One frame of the panel, its intents applied after it.
    pub fn ui(&mut self, ui: &mut Ui) {
        let mut commands = Vec::new();
        let mut plots = Plots {
            view: &mut self.view,
            settings: &mut self.settings,
            drive: &mut self.drive,
            beside: &[],
            commands: &mut commands,
        };
        plots_ui(ui, &mut plots);
        for command in commands {
            if let Command::Plot(command) = command {
                self.apply(command);
            }
        }
    }
}

/// The share of the plot panel's height the rows above the plots take at most.
const CONTROLS_SHARE: f32 = 0.45;
/// … but never less than this, in points (a toolbar row and the read-out).
const CONTROLS_HEIGHT_MIN: f32 = 60.0;

/// One frame of the plot panel alone, drawn through `ctx` without a window at 1600×1000
/// (layout, decimation, plot items and tessellation; no GPU): what the benches and
/// `drivedeck bench`'s plotting load measure. The number of clipped primitives.
pub fn headless_frame(ctx: &egui::Context, alone: &mut Alone) -> usize {
    let input = egui::RawInput {
        screen_rect: Some(egui::Rect::from_min_size(
            egui::Pos2::ZERO,
            egui::vec2(1600.0, 1000.0),
        )),
        ..Default::default()
    };
    let output = ctx.run_ui(input, |ui| alone.ui(ui));
    ctx.tessellate(output.shapes, output.pixels_per_point).len()
}

/// The plots of the drive shown, with the same signals of the drives beside it drawn in
/// each plot: live, and over a triggered capture's span (a recording opened from a file
/// has a time base of its own and is drawn alone).
pub fn plots_ui(ui: &mut Ui, p: &mut Plots<'_>) {
    let alone = picture::enlarged(ui.ctx(), p.view);
    let (band, plots) = match alone {
        // A picture: the title and the plots alone, in all the room there is (the window
        // draws nothing else meanwhile: `fills_window`), at up to twice the resolution.
        Some(enlarged) => picture::enlarged_ui(ui, p, enlarged),
        None => {
            // The rows above the plots take at most part of the panel (scrolling within
            // it beyond): in a narrow or zoomed-in window they wrap into many lines, and
            // would otherwise leave the plots, and their time axis, no room at all.
            let controls = (ui.available_height() * CONTROLS_SHARE).max(CONTROLS_HEIGHT_MIN);
            egui::ScrollArea::vertical()
                .id_salt("plot_controls")
                .auto_shrink([false, true])
                .max_height(controls)
                .show(ui, |ui| {
                    toolbar(ui, p);
                    review_view::review_ui(ui, p);
                    capture::capture_ui(ui, p);
                    readout::readout_ui(ui, p);
                });
            let room = ui.available_size();
            // Drawn here only when there are no plots to draw alone (it says so).
            let band = if p.view.picture.enlarged.is_none() {
                picture::title_band_ui(ui, p)
            } else {
                None
            };
            let plots = traces::traces_ui(ui, p);
            // The picture shows every plot whole, none scrolled out of view.
            p.view.drawn_at.room = plots.map(|_| [room.x, room.y.max(p.view.drawn_at.need)]);
            (band, plots)
        }
    };
    p.view.drawn_at.area = plots.map(|r| [r.min.x, r.min.y, r.max.x, r.max.y]);
    picture::taken(ui.ctx(), p.view, band, plots, alone.is_some());
    // The answers of this frame's dialogs (a scripted one answers at once) and of those
    // that came in between.
    picture::poll(ui.ctx(), p);
    exports_view::poll(ui.ctx(), p);
    review::poll(p.view);
    exports_view::confirm_ui(ui.ctx(), p);
}

/// A picture of the plots at a higher resolution is being drawn: the window shows the
/// plots alone until it is taken (nothing else may be drawn over them).
pub fn fills_window(ctx: &egui::Context, view: &PlotView) -> bool {
    picture::enlarged(ctx, view).is_some()
}

fn toolbar(ui: &mut Ui, p: &mut Plots<'_>) {
    ui.horizontal_wrapped(|ui| {
        if p.view.review.is_some() {
            ui.heading("Recording");
            review_view::open_buttons_ui(ui, p);
            signals_menu(ui, p);
            return;
        }
        ui.heading("Live plots");
        review_view::open_buttons_ui(ui, p);
        let paused = p.view.is_paused();
        if ui
            .add(egui::Button::selectable(
                paused,
                if paused { "Resume plot" } else { "Pause plot" },
            ))
            .on_hover_text(
                "Freeze the plots to look closely; sampling and recording go on underneath.",
            )
            .clicked()
        {
            p.commands.push(Command::Plot(if paused {
                PlotCommand::Resume
            } else {
                PlotCommand::Pause
            }));
        }
        let follow = p.view.follow;
        if ui
            .add(egui::Button::selectable(follow, "Follow latest"))
            .on_hover_text(
                "Keep the newest samples in view. Moving the time axis stops following: drag a \
                 plot to pan, turn the wheel over it to zoom (Shift+wheel pans), right-drag \
                 across the span to show; double-click a plot to follow again. When the plots \
                 do not all fit they scroll: drag the scroll bar at their right, or turn the \
                 wheel over their y axes' labels.",
            )
            .clicked()
        {
            p.commands.push(Command::Plot(PlotCommand::Follow(!follow)));
        }
        ui.label("Window");
        let combo = egui::ComboBox::from_id_salt("plot_window")
            .selected_text(window_text(p.settings.window_s))
            .show_ui(ui, |ui| {
                for w in [1.0, 5.0, 10.0, 30.0, 60.0, 300.0, 0.0] {
                    ui.selectable_value(&mut p.settings.window_s, w, window_text(w));
                }
            });
        crate::ui::widgets::name_widget(
            &combo.response,
            egui::accesskit::Role::ComboBox,
            "Plot window",
        );
        if ui
            .button("Clear plot")
            .on_hover_text("Forget the recorded history and markers")
            .clicked()
        {
            p.commands.push(Command::ClearPlots);
        }
        signals_menu(ui, p);
        history_menu(ui, p);
        super::exports_view::spectrum_ui(ui, p);
    });
}

fn window_text(seconds: f64) -> String {
    if seconds <= 0.0 {
        "whole history".into()
    } else if seconds >= 60.0 {
        format!("{:.0} min", seconds / 60.0)
    } else {
        format!("{seconds:.0} s")
    }
}

/// Which signals are drawn (the button says how many; the menu stays open while
/// choosing, each signal in the colour of its trace), how positions are drawn, and the
/// objects added from the dictionary.
fn signals_menu(ui: &mut Ui, p: &mut Plots<'_>) {
    let scope = shown_scope(p.view, p.drive);
    let drawn = scope.signals().iter().filter(|s| scope.is_drawn(s)).count();
    let title = format!("Signals ({drawn} of {})", scope.signals().len());
    let config = egui::containers::menu::MenuConfig::new()
        .close_behavior(egui::PopupCloseBehavior::CloseOnClickOutside);
    let (button, _) = egui::containers::menu::MenuButton::new(title)
        .config(config)
        .ui(ui, |ui| signals_menu_body(ui, p));
    crate::ui::widgets::name_widget(&button, egui::accesskit::Role::Button, "Signals");
}

fn signals_menu_body(ui: &mut Ui, p: &mut Plots<'_>) {
    {
        let reviewing = p.view.review.is_some();
        let scope = match &mut p.view.review {
            Some(review) => &mut review.base.scope,
            None => &mut p.drive.scope,
        };
        let colors = traces::colors(scope.signals());
        let mut changed = false;
        let with_samples: Vec<bool> = scope
            .signals()
            .iter()
            .map(|s| scope.ring().latest(s.column).is_some())
            .collect();
        for ((signal, color), has) in scope.signals_mut().iter_mut().zip(colors).zip(with_samples) {
            let mut drawn = signal.shown || (signal.auto && has);
            let label = if signal.info.unit.is_empty() {
                signal.info.name.clone()
            } else {
                format!("{} [{}]", signal.info.name, signal.info.unit)
            };
            ui.horizontal(|ui| {
                let (rect, _) = ui.allocate_exact_size(egui::vec2(14.0, 4.0), egui::Sense::hover());
                ui.painter().rect_filled(rect, 1.0, color);
                if ui.checkbox(&mut drawn, label).changed() {
                    signal.shown = drawn;
                    signal.auto = false;
                    changed = true;
                }
            });
        }
        together_ui(ui, scope.signals(), &mut p.settings.together);
        if changed && !reviewing {
            p.settings.shown = p
                .drive
                .scope
                .signals()
                .iter()
                .filter(|s| s.shown)
                .map(|s| s.info.id.clone())
                .collect();
        }
    }
    lanes_ui(ui, &p.view.lanes_seen, &mut p.settings.hidden_lanes);
    ui.separator();
    ui.horizontal(|ui| {
        ui.label("Positions in");
        for unit in PositionUnit::ALL {
            ui.selectable_value(&mut p.settings.position_unit, unit, unit.unit());
        }
    })
    .response
    .on_hover_text(
        "Positions in the factory unit (0.1°) drawn as counted, in degrees or in revolutions",
    );
    if p.view.review.is_some() {
        return;
    }
    {
        ui.separator();
        ui.label("Plot an object of the dictionary (sampled every cycle):");
        ui.horizontal(|ui| {
            ui.add(
                egui::TextEdit::singleline(&mut p.view.watch_text)
                    .hint_text("e.g. 2031:00")
                    .desired_width(90.0),
            )
            .on_hover_text("Index and subindex in hex");
            if ui.button("Add").clicked() {
                let text = p.view.watch_text.clone();
                p.commands.push(Command::PlotObject {
                    text,
                    from: Said::Plots,
                });
            }
        });
        let plotted: Vec<Address> = p.drive.plotted.iter().map(|(w, _)| w.address).collect();
        for address in plotted {
            ui.horizontal(|ui| {
                if ui
                    .button(format!("Remove {address}"))
                    .on_hover_text("Stop sampling it (its history is kept until cleared)")
                    .clicked()
                {
                    p.commands.push(Command::UnplotObject(address));
                }
                let pinned = p.drive.settings.watch.is_pinned(address);
                let pin = ui
                    .add_enabled(!pinned, egui::Button::new("Watch"))
                    .on_hover_text("Pin it to the watch panel too: its value in numbers")
                    .on_disabled_hover_text("in the watch panel already");
                crate::ui::widgets::name_widget(
                    &pin,
                    egui::accesskit::Role::Button,
                    &format!("Watch {address}"),
                );
                if pin.clicked() {
                    p.commands.push(Command::PinToWatch {
                        address,
                        from: Said::Plots,
                    });
                }
            });
        }
    }
}

/// Which plot each analog signal is drawn in: its own, or with another's (a scope's
/// channels, each on a y axis of its own).
fn together_ui(
    ui: &mut Ui,
    signals: &[crate::telemetry::SignalDef],
    together: &mut std::collections::BTreeMap<String, String>,
) {
    let analog: Vec<&crate::telemetry::SignalDef> = signals
        .iter()
        .filter(|s| s.kind == crate::telemetry::Kind::Analog)
        .collect();
    ui.separator();
    ui.label("Plot with …").on_hover_text(
        "Draw a signal in another's plot, each in its colour on a y axis of its own",
    );
    egui::Grid::new("plot_together").show(ui, |ui| {
        for signal in &analog {
            let id = &signal.info.id;
            let name_of = |id: &str| {
                analog
                    .iter()
                    .find(|s| s.info.id == id)
                    .map_or_else(|| id.to_owned(), |s| s.info.name.clone())
            };
            let chosen = together.get(id).cloned();
            ui.label(&signal.info.name);
            // A submenu (a combo box's popup would close the menu around it).
            let current = chosen
                .as_deref()
                .map_or_else(|| "own plot".to_owned(), name_of);
            let hosts: Vec<&&crate::telemetry::SignalDef> = analog
                .iter()
                .filter(|h| h.info.id != *id && !together.contains_key(&h.info.id))
                .collect();
            let menu = ui.menu_button(current, |ui| {
                if ui.selectable_label(chosen.is_none(), "own plot").clicked() {
                    together.remove(id);
                    ui.close();
                }
                // Only a signal with a plot of its own takes another.
                for host in hosts {
                    let this = chosen.as_deref() == Some(host.info.id.as_str());
                    if ui.selectable_label(this, &host.info.name).clicked() {
                        together.insert(id.clone(), host.info.id.clone());
                        ui.close();
                    }
                }
            });
            crate::ui::widgets::name_widget(
                &menu.response,
                egui::accesskit::Role::Button,
                &format!("Plot {} with", signal.info.name),
            );
            ui.end_row();
        }
    });
}

/// The digital lanes there are to draw, each shown or hidden.
fn lanes_ui(ui: &mut Ui, seen: &[(String, String)], hidden: &mut Vec<String>) {
    if seen.is_empty() && hidden.is_empty() {
        return;
    }
    ui.separator();
    ui.label("Lanes").on_hover_text(
        "The status bits and inputs drawn as lanes (a bit appears when it was high in view)",
    );
    ui.horizontal_wrapped(|ui| {
        for (key, name) in seen {
            let mut shown = !hidden.contains(key);
            if ui.checkbox(&mut shown, name).changed() {
                hidden.retain(|k| k != key);
                if !shown {
                    hidden.push(key.clone());
                }
            }
        }
    });
}

/// The live plots' redraw rate: a box in frames per second.
fn redraw_ui(ui: &mut Ui, redraw_hz: &mut f64) {
    use crate::ui::pace::{REDRAW_HZ_MAX, REDRAW_HZ_MIN, redraw_hz as accepted};
    ui.horizontal(|ui| {
        ui.label("Redraw live plots at");
        *redraw_hz = accepted(*redraw_hz);
        let field = ui
            .add(
                egui::DragValue::new(redraw_hz)
                    .range(REDRAW_HZ_MIN..=REDRAW_HZ_MAX)
                    .speed(1.0)
                    .max_decimals(0)
                    .suffix(" Hz"),
            )
            .on_hover_text(
                "Frames per second at most while the plots follow new samples; fewer cost \
                 less CPU. Paused or moved plots redraw once a second.",
            );
        crate::ui::widgets::name_widget(&field, egui::accesskit::Role::SpinButton, "Redraw rate");
    });
}

fn history_menu(ui: &mut Ui, p: &mut Plots<'_>) {
    let ring = p.drive.scope.ring();
    let rate = p.drive.settings.poll_rate.max(1.0);
    let label = format!(
        "{} of {} samples ({:.0} s at {rate:.0} Hz, {:.0} MB)",
        ring.len(),
        ring.capacity(),
        ring.capacity() as f64 / rate,
        ring.memory_bytes() as f64 / 1e6
    );
    ui.menu_button("History", |ui| {
        ui.label(label);
        ui.horizontal(|ui| {
            ui.label("Samples per signal");
            if p.view.rows_text.is_empty() {
                p.view.rows_text = p.drive.scope.capacity().to_string();
            }
            ui.add(egui::TextEdit::singleline(&mut p.view.rows_text).desired_width(90.0));
            if ui.button("Apply").clicked() {
                match crate::number::parse_integer(&p.view.rows_text, false)
                    .and_then(|v| usize::try_from(v).ok())
                    .filter(|v| (1_000..=50_000_000).contains(v))
                {
                    Some(rows) => p.commands.push(Command::SetHistory(rows)),
                    None => {
                        p.view.message = Some(Err(format!(
                            "'{}' is not a history size: 1000 to 50 000 000 samples",
                            p.view.rows_text
                        )))
                    }
                }
            }
        });
        ui.weak("The default, 600 000, is 10 minutes at 1 kHz. The oldest samples go first.");
        ui.separator();
        redraw_ui(ui, &mut p.settings.redraw_hz);
    });
}
