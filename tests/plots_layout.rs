//! The plots on a laptop screen, headless: every plot keeps a useful height and the plot
//! area scrolls rather than crushing them, legends stay within their plots, several
//! signals share a plot each on its own scale, the read-out names objects as the window
//! writes them, an overlaid recording is in the legend, and the time axis stays in view at
//! any zoom of the window.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod window;

use std::time::Duration;

use drivedeck::od::Address;
use drivedeck::signal::{Signal, Signals};
use drivedeck::telemetry::WatchedObject;
use drivedeck::ui::plots::{Alone, DrawnPlot, PLOT_HEIGHT_MIN};
use drivedeck::ui::{App, Settings};
use drivedeck::worker::{Event, Sample};
use eframe::egui;
use egui_kittest::Harness;
use egui_kittest::kittest::{NodeT, Queryable};

/// The plot panel alone at `size`, with every built-in analog signal shown and 10 s of
/// samples at 1 kHz.
fn panel(size: egui::Vec2) -> Harness<'static, Alone> {
    let mut alone = Alone::new(Settings::default().plot.history_rows);
    // An object of the dictionary plotted too (the controlword, read every cycle).
    alone.drive.scope.set_watched(&[WatchedObject {
        address: Address::new(0x6041, 0),
        name: "Statusword".into(),
        unit: String::new(),
    }]);
    let mut harness = Harness::builder()
        .with_size(size)
        .build_ui_state(|ui, alone: &mut Alone| alone.ui(ui), alone);
    let samples = (0..10_000)
        .map(|i| {
            let t = f64::from(i) * 0.001;
            Sample {
                t,
                signals: Signals::default()
                    .with(Signal::Position, 1000.0 * (t * 0.7).sin())
                    .with(Signal::Velocity, f64::from(i % 500))
                    .with(Signal::Torque, 3.0 * (t * 2.0).cos()),
                watched: [
                    Some(f64::from(0x0237)),
                    None,
                    None,
                    None,
                    None,
                    None,
                    None,
                    None,
                ],
                ..Default::default()
            }
        })
        .collect();
    harness.state_mut().apply_event(Event::Samples(samples));
    harness.step();
    harness.step();
    harness
}

fn drawn(harness: &Harness<'_, Alone>) -> Vec<DrawnPlot> {
    harness.state().view.drawn().to_vec()
}

/// Every signal of the panel's drive shown (the status and input lanes included).
fn show_everything(harness: &mut Harness<'_, Alone>) {
    for signal in harness.state_mut().drive.scope.signals_mut() {
        signal.shown = true;
    }
    harness.step();
    harness.step();
}

/// The analog plots drawn (not the lanes, not the time axis under them).
fn analog(plots: &[DrawnPlot]) -> Vec<DrawnPlot> {
    plots
        .iter()
        .filter(|p| p.id != "lanes" && p.id != "time")
        .cloned()
        .collect()
}

fn height(plot: &DrawnPlot) -> f32 {
    plot.frame[3] - plot.frame[1]
}

/// The wheel turned over `pos` (a few frames: it is smoothed).
fn wheel_at(harness: &mut Harness<'_, Alone>, pos: egui::Pos2, notches: f32) {
    harness.event(egui::Event::PointerMoved(pos));
    harness.step();
    harness.event(egui::Event::MouseWheel {
        unit: egui::MouseWheelUnit::Line,
        delta: egui::vec2(0.0, notches),
        phase: egui::TouchPhase::Move,
        source: egui::MouseWheelSource::Wheel,
        modifiers: egui::Modifiers::NONE,
    });
    for _ in 0..40 {
        harness.step();
    }
}

#[test]
fn every_plot_keeps_a_useful_height_and_the_plots_scroll_on_a_small_screen() {
    for (width, height_px) in [(1024.0, 600.0), (1366.0, 768.0)] {
        let mut harness = panel(egui::vec2(width, height_px));
        show_everything(&mut harness);
        let plots = drawn(&harness);
        let analog = analog(&plots);
        assert!(analog.len() >= 5, "{plots:?}");
        for plot in &analog {
            assert!(
                height(plot) >= PLOT_HEIGHT_MIN - 0.5,
                "at {width}×{height_px} {} is {} points high",
                plot.id,
                height(plot)
            );
        }
        println!(
            "at {width}×{height_px} with everything shown: {:?}",
            plots
                .iter()
                .map(|p| format!("{} {:.0}", p.id, height(p)))
                .collect::<Vec<_>>()
        );
        // Neighbours apart: no plot's area runs into the next one's.
        let stacked: Vec<&DrawnPlot> = plots.iter().filter(|p| p.id != "time").collect();
        for pair in stacked.windows(2) {
            assert!(pair[0].frame[3] < pair[1].frame[1], "{pair:?}");
        }
        // The time axis stays on the screen, under the plots.
        let time = plots.last().expect("the time axis");
        assert_eq!(time.id, "time");
        assert!(time.frame[3] <= height_px, "{time:?}");
    }

    // At 1024×600 they do not all fit: the wheel over the y axis's labels scrolls them,
    // the time axis stays where it is.
    let mut harness = panel(egui::vec2(1024.0, 600.0));
    show_everything(&mut harness);
    let before = drawn(&harness);
    let span = harness.state().view.shown_range();
    let first = &before[0];
    let over_labels = egui::pos2(
        first.frame[0] - 20.0,
        (first.frame[1] + first.frame[3]) / 2.0,
    );
    wheel_at(&mut harness, over_labels, -3.0);
    let after = drawn(&harness);
    assert!(
        after[0].frame[1] < before[0].frame[1] - 10.0,
        "not scrolled: {:?} → {:?}",
        before[0].frame,
        after[0].frame
    );
    assert_eq!(
        after.last().map(|p| p.frame),
        before.last().map(|p| p.frame),
        "the time axis moved"
    );
    assert_eq!(
        harness.state().view.shown_range(),
        span,
        "the time axis zoomed"
    );
    assert!(harness.state().view.follows());
}

#[test]
fn two_signals_in_one_plot_keep_their_colours_scales_and_true_values() {
    let mut harness = panel(egui::vec2(1366.0, 768.0));
    harness
        .state_mut()
        .settings
        .together
        .insert("velocity".into(), "position".into());
    harness.step();
    harness.step();
    let plots = analog(&drawn(&harness));
    // Position and velocity in one plot, torque in its own.
    let ids: Vec<Vec<&str>> = plots
        .iter()
        .map(|p| p.lines.iter().map(|(id, _)| id.as_str()).collect())
        .collect();
    assert!(ids.contains(&vec!["position", "velocity"]), "{ids:?}");
    assert!(!ids.contains(&vec!["velocity"]), "{ids:?}");
    let shared = plots
        .iter()
        .find(|p| p.lines.len() == 2)
        .expect("the shared plot");
    // Each line in its own true values: the position swings ±1000 × 0.1°, the velocity
    // ramps 0 to 499.
    let (_, position) = &shared.lines[0];
    let (_, velocity) = &shared.lines[1];
    let (position, velocity) = (position.expect("position"), velocity.expect("velocity"));
    assert!(
        position.low < -500.0 && position.high > 500.0,
        "{position:?}"
    );
    assert!(
        velocity.low >= 0.0
            && velocity.low < 10.0
            && velocity.high > 490.0
            && velocity.high <= 499.0,
        "{velocity:?}"
    );
    // The read-out under the pointer over the shared plot gives both true values.
    let pos = egui::pos2(
        (shared.frame[0] + shared.frame[2]) / 2.0,
        (shared.frame[1] + shared.frame[3]) / 2.0,
    );
    harness.event(egui::Event::PointerMoved(pos));
    harness.step();
    let t: f64 = window::text_containing(&harness, "pointer t = ")
        .trim_start_matches("pointer t = ")
        .trim_end_matches(" s")
        .parse()
        .expect("a time");
    let value = |name: &str| -> f64 {
        let text = window::text_containing(&harness, &format!("| {name}: "));
        text.trim_start_matches(&format!("| {name}: "))
            .split_whitespace()
            .next()
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("no value in '{text}'"))
    };
    let row = (t * 1000.0).round();
    assert!((value("velocity") - row % 500.0).abs() < 1e-6, "at {t} s");
    assert!(
        (value("position") - 1000.0 * (row / 1000.0 * 0.7).sin()).abs() < 0.5,
        "at {t} s"
    );
}

#[test]
fn the_read_out_names_an_object_as_the_window_writes_it() {
    let harness = panel(egui::vec2(1366.0, 768.0));
    let text = window::text_containing(&harness, "| 6041h");
    assert!(text.starts_with("| 6041h:00: 567"), "{text}");
}

#[test]
fn the_signals_menu_puts_a_signal_in_anothers_plot_and_hides_a_lane() {
    let mut harness = panel(egui::vec2(1366.0, 768.0));
    harness.get_by_label("Signals").click();
    harness.run_steps(2);
    harness.get_by_label("Plot Velocity 606Ch with").click();
    harness.run_steps(2);
    harness
        .query_all_by_label("Position 6064h")
        .find(|node| node.accesskit_node().role() != egui::accesskit::Role::Label)
        .expect("the position among the plots to join")
        .click();
    harness.run_steps(2);
    assert_eq!(
        harness
            .state()
            .settings
            .together
            .get("velocity")
            .map(String::as_str),
        Some("position")
    );
    // Choosing closes the menu; opened again for the lanes.
    if harness.query_by_label("Target reached").is_none() {
        harness.get_by_label("Signals").click();
        harness.run_steps(2);
    }
    harness.get_by_label("Target reached").click();
    harness.run_steps(2);
    let bit = drivedeck::pdi::StatusBit::TargetReached.bit();
    assert_eq!(
        harness.state().settings.hidden_lanes,
        [drivedeck::ui::plots::lane_key("pdi_status", bit)]
    );
    let plots = analog(&drawn(&harness));
    assert!(
        plots
            .iter()
            .any(|p| p.lines.len() == 2 && p.lines[1].0 == "velocity"),
        "{plots:?}"
    );
    // The choices are kept between runs; a settings file from before them still loads.
    let text = serde_json::to_string(&harness.state().settings).expect("saved");
    let back: drivedeck::ui::plots::PlotSettings = serde_json::from_str(&text).expect("read");
    assert_eq!(&back, &harness.state().settings);
    let old: drivedeck::ui::plots::PlotSettings =
        serde_json::from_str(r#"{"window_s": 30.0, "shown": ["velocity"]}"#).expect("old");
    assert_eq!(old.window_s, 30.0);
    assert_eq!(old.together, drivedeck::ui::plots::default_together());
    assert!(old.hidden_lanes.is_empty());
}

/// The window with `drives` simulated drives at 1024×600, every one sampled and drawn.
fn drives_at_1024x600(drives: usize) -> Harness<'static, App> {
    let mut harness = window::harness_with(Settings::default(), true, egui::vec2(1024.0, 600.0));
    window::connected(&mut harness);
    for k in 1..drives {
        let index = harness
            .state_mut()
            .add_drive(format!("Axis {k}"), "sim://")
            .expect("another drive");
        // Drawn in the plots beside the drive shown.
        harness
            .state_mut()
            .apply_command(drivedeck::ui::Command::PlotBeside(index, true));
    }
    window::step_until(
        &mut harness,
        "every drive sampled",
        Duration::from_secs(5),
        |h| (0..drives).all(|i| h.state().drive(i).is_some_and(|d| d.latest().is_some())),
    );
    harness.run_steps(4);
    harness
}

#[test]
fn with_four_drives_every_legend_stays_within_its_plot() {
    let harness = drives_at_1024x600(4);
    let plots = harness.state().plot().drawn().to_vec();
    // The legend entries ("Axis 2: Velocity 606Ch"): each fully inside the plot it
    // starts in, and a signal's entries (one per drive) all in one plot (a legend taller
    // than its plot runs on into the next plot down).
    let entries: Vec<(String, egui::Rect)> = harness
        .query_all_by_role(egui::accesskit::Role::CheckBox)
        .filter_map(|node| {
            let label = node.accesskit_node().label()?.to_string();
            let (drive, signal) = label.split_once(": ")?;
            (drive.starts_with("Axis ") || drive == "Drive 1").then(|| {
                let signal = signal.split_whitespace().next().unwrap_or("").to_owned();
                (signal, node.rect())
            })
        })
        .collect();
    assert!(entries.len() >= 3, "{entries:?}");
    let mut plot_of: std::collections::HashMap<String, String> = Default::default();
    for (signal, entry) in &entries {
        let own = plots
            .iter()
            .find(|p| entry.top() >= p.frame[1] && entry.top() <= p.frame[3])
            .unwrap_or_else(|| panic!("a legend entry at {entry:?} is in no plot: {plots:?}"));
        assert!(
            entry.bottom() <= own.frame[3] && entry.right() <= own.frame[2],
            "{signal}'s legend entry at {entry:?} runs out of {} {:?}",
            own.id,
            own.frame
        );
        let first = plot_of.entry(signal.clone()).or_insert(own.id.clone());
        assert_eq!(
            *first, own.id,
            "{signal}'s legend entries are spread over two plots: {entries:?}"
        );
    }
    for plot in analog(&plots) {
        println!(
            "four drives at 1024×600: {} {:.0} points high",
            plot.id,
            height(&plot)
        );
    }
}

/// The window on the simulated drive at `size` (its default settings), `zoom` as after
/// Ctrl+Plus, samples drawn.
fn window_at(size: egui::Vec2, zoom: f32) -> Harness<'static, App> {
    let mut harness = window::harness_with(Settings::default(), true, size);
    harness.ctx.set_zoom_factor(zoom);
    window::connected(&mut harness);
    window::step_until(
        &mut harness,
        "the plots drawn",
        Duration::from_secs(5),
        |h| h.state().plot().drawn().len() >= 3,
    );
    harness.run_steps(4);
    harness
}

#[test]
fn the_default_layout_reads_at_1366x768_and_the_time_axis_stays_in_view_at_zoom_1_5() {
    for (size, zoom) in [
        (egui::vec2(1366.0, 768.0), 1.0),
        (egui::vec2(1024.0, 600.0), 1.0),
        (egui::vec2(1366.0, 768.0), 1.5),
    ] {
        let harness = window_at(size, zoom);
        let plots = harness.state().plot().drawn().to_vec();
        let screen = size / zoom;
        println!(
            "default layout at {}×{} zoom {zoom}: {:?}",
            size.x,
            size.y,
            plots
                .iter()
                .map(|p| format!("{} {:.0}", p.id, height(p)))
                .collect::<Vec<_>>()
        );
        for plot in analog(&plots) {
            assert!(
                height(&plot) >= PLOT_HEIGHT_MIN - 0.5,
                "{} is {} points high at {size:?} zoom {zoom}",
                plot.id,
                height(&plot)
            );
        }
        // The time axis's labels (under the lowest plot's area) are on the screen.
        let lowest = plots.last().expect("plots");
        assert!(
            lowest.frame[3] + 30.0 <= screen.y,
            "the time axis under {:?} is off the {screen:?} screen at zoom {zoom}",
            lowest.frame
        );
        if zoom == 1.0 && size.y >= 768.0 {
            // The default signals (position with the following error, velocity with the
            // analog input, torque) and the status lanes all fit at 1366×768, no
            // scrolling: every plot's area ends above the time axis.
            let stacked: Vec<&DrawnPlot> = plots.iter().filter(|p| p.id != "time").collect();
            let time = plots
                .iter()
                .find(|p| p.id == "time")
                .expect("the time axis");
            assert!(
                stacked.iter().all(|p| p.frame[3] <= time.frame[1]),
                "{plots:?}"
            );
            assert!(stacked.iter().any(|p| p.id == "lanes"), "{plots:?}");
            let shared: Vec<Vec<&str>> = plots
                .iter()
                .map(|p| p.lines.iter().map(|(id, _)| id.as_str()).collect())
                .collect();
            assert!(
                shared.contains(&vec!["position", "following_error"])
                    && shared.contains(&vec!["velocity", "analog_input"]),
                "{shared:?}"
            );
        }
    }
}

/// The plots' rectangle in the window's last frame, in points.
fn plots_size(harness: &Harness<'_, drivedeck::ui::App>) -> egui::Vec2 {
    harness.state().plots_rect().expect("plots drawn").size()
}

/// Ask the whole window for a PNG at up to twice the resolution; the message it gives.
fn larger_png(harness: &mut Harness<'_, drivedeck::ui::App>) -> String {
    harness
        .get_by_label("PNG at up to twice the resolution")
        .click();
    harness.step();
    assert_eq!(harness.state().settings().plot.picture_scale, 2.0);
    harness.get_by_label("Save PNG…").click();
    harness.run_steps(3);
    harness
        .state()
        .plot()
        .message()
        .cloned()
        .expect("a message")
        .expect("taking it")
}

#[test]
fn a_hi_res_png_draws_the_plots_alone_at_their_size_with_the_zoom_raised() {
    let mut harness = window::harness_with(Settings::default(), true, egui::vec2(1920.0, 1080.0));
    window::step_for(&mut harness, Duration::from_millis(300));
    let on_screen = plots_size(&harness);
    let said = larger_png(&mut harness);
    // The window's zoom raised as far as it holds the plots (1.4× on 1920×1080 with the
    // default panels), the plots drawn alone (no panel over them: in the real window one
    // would come out in the picture) at their size on screen: the same layout with more
    // pixels each way.
    let zoom = harness.ctx.zoom_factor();
    assert!(zoom > 1.3 && zoom <= 2.0, "{zoom}");
    assert_eq!(harness.ctx.pixels_per_point(), zoom);
    let enlarged = plots_size(&harness);
    assert!(
        (enlarged - on_screen).length() <= 2.0,
        "{on_screen:?} on screen, {enlarged:?} for the picture"
    );
    for elsewhere in [
        "QUICKSTOP (Esc)",
        "Drive status",
        "Halt",
        "Object dictionary",
    ] {
        assert!(
            harness.query_by_label(elsewhere).is_none(),
            "{elsewhere} drawn with the plots for the picture"
        );
    }
    let width: f32 = said
        .split("about ")
        .nth(1)
        .and_then(|rest| rest.split('×').next())
        .and_then(|w| w.parse().ok())
        .expect("the picture's width in the message");
    assert!(
        said.contains(&format!("{zoom:.1}× picture")) && (width - on_screen.x * zoom).abs() < 3.0,
        "{said}: {on_screen:?} at {zoom}"
    );
    // No screenshot comes headless: given up after a while, the zoom and the panels back.
    harness.run_steps(130);
    assert_eq!(harness.ctx.zoom_factor(), 1.0);
    assert!(harness.state().plot().message().is_some_and(Result::is_err));
    assert!(harness.query_by_label("QUICKSTOP (Esc)").is_some());
}

#[test]
fn a_png_larger_than_the_window_holds_is_taken_as_large_as_it_holds_and_says_so() {
    let mut harness = window::harness_with(Settings::default(), true, egui::vec2(1366.0, 768.0));
    window::step_for(&mut harness, Duration::from_millis(300));
    let on_screen = plots_size(&harness);
    let said = larger_png(&mut harness);
    // Not 2× (the plots would have to be laid out anew), but as much as the height holds,
    // the plots at their size on screen.
    let zoom = harness.ctx.zoom_factor();
    assert!(zoom > 1.1 && zoom < 2.0, "{zoom}");
    let enlarged = plots_size(&harness);
    assert!(
        (enlarged - on_screen).length() <= 2.0,
        "{on_screen:?} on screen, {enlarged:?} for the picture"
    );
    assert!(
        said.contains(&format!("{zoom:.1}× picture"))
            && said.contains("the most this window holds"),
        "{said}"
    );
}

#[test]
fn a_png_from_a_small_screen_shows_every_plot_whole_not_the_scrolled_part() {
    // 1024×600 as the window starts there (the command panel folded on a narrow screen):
    // the plots scroll on screen, some (or part of one) out of view.
    let settings = Settings {
        commands_collapsed: true,
        ..Settings::default()
    };
    let mut harness = window::harness_with(settings, true, egui::vec2(1024.0, 600.0));
    window::step_for(&mut harness, Duration::from_millis(300));
    let clipped = |plots: &[DrawnPlot]| {
        plots
            .iter()
            .filter(|p| (p.visible[3] - p.visible[1]) < (p.frame[3] - p.frame[1]) - 1.0)
            .count()
    };
    let on_screen = harness.state().plot().drawn().to_vec();
    assert!(clipped(&on_screen) > 0, "{on_screen:?}");
    harness.get_by_label("Save PNG…").click();
    harness.run_steps(3);
    // For the picture the plots are drawn alone, with the room to show every one whole.
    let for_picture = harness.state().plot().drawn().to_vec();
    assert_eq!(for_picture.len(), on_screen.len());
    assert_eq!(clipped(&for_picture), 0, "{for_picture:?}");
    assert!(harness.query_by_label("QUICKSTOP (Esc)").is_none());
}
