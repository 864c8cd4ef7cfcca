//! The state tile, headless (egui_kittest) against the simulated drive: it says in words
//! what the drive does (DISABLED, ENABLED, MOVING +300 rpm, HALTED, QUICK STOP, FAULT with
//! its code and meaning, NO LINK with when it was last seen), Enable switches the power
//! stage on without moving, the halt toggle says it is halted, a limit switch that blocks
//! a move is named, a quick stop leaves a line saying why, a Disconnect is a calm
//! DISCONNECTED; and the window's layout: the
//! command panel folds to a strip, nothing needed is cut off at 1366×768.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
mod window;

use std::time::Duration;

use drivedeck::cia::PowerState;
use drivedeck::od::{Address, DataType, Value};
use drivedeck::pdi::StatusBit;
use drivedeck::sim::Injection;
use drivedeck::ui::App;
use drivedeck::worker::{ObjectPath, Request};
use eframe::egui;
use egui::accesskit::Toggled;
use egui_kittest::Harness;
use egui_kittest::kittest::{NodeT, Queryable};
use window::{
    app_harness, connected, harness_with, position, step_until, step_until_shown, velocity,
};

/// The CiA 402 state of the newest sample.
fn power(harness: &Harness<'_, App>) -> Option<PowerState> {
    harness
        .state()
        .shown()
        .latest()
        .and_then(|s| s.statusword())
        .and_then(PowerState::from_statusword)
}

/// Step until a label containing `text` is on screen; its whole text.
fn shown_containing(harness: &mut Harness<'_, App>, text: &str) -> String {
    step_until(
        harness,
        &format!("a label containing '{text}'"),
        Duration::from_secs(5),
        |h| h.query_by_label_contains(text).is_some(),
    );
    window::text_containing(harness, text)
}

/// Move the pointer over the button labelled `label`, as a hand does, then click it. The
/// frames in between let the layout settle: the tile's headline shortens when the drive
/// drops a fault's code, and the button under it moves up.
fn press(harness: &mut Harness<'_, App>, label: &str) {
    harness.get_by_label(label).hover();
    harness.run_steps(2);
    harness.get_by_label(label).click();
    harness.step();
}

#[test]
fn the_tile_says_disabled_enabled_moving_halted_and_enable_does_not_move() {
    let mut harness = app_harness();
    connected(&mut harness);
    step_until_shown(&mut harness, "DISABLED");
    let at = position(&harness);

    // Enable: the power stage on, the motor where it stood.
    harness.get_by_label("Enable").click();
    harness.step();
    step_until_shown(&mut harness, "ENABLED");
    assert_eq!(power(&harness), Some(PowerState::OperationEnabled));
    window::step_for(&mut harness, Duration::from_millis(300));
    assert_eq!(velocity(&harness), 0.0);
    assert_eq!(position(&harness), at, "enable moved nothing");
    assert!(
        harness
            .get_by_label("Enable")
            .accesskit_node()
            .is_disabled(),
        "already enabled"
    );

    // Velocity 300 rpm: the tile says so, signed.
    harness.get_by_label("Velocity").click();
    harness.step();
    step_until_shown(&mut harness, "MOVING +300 rpm");

    // Halt: the tile and the button say halted; pressing it again resumes.
    harness.get_by_label("Halt").click();
    harness.step();
    step_until_shown(&mut harness, "HALTED");
    let button = harness.get_by_label("Halted — press to resume");
    assert_eq!(button.accesskit_node().toggled(), Some(Toggled::True));
    button.click();
    harness.step();
    step_until_shown(&mut harness, "MOVING +300 rpm");
    assert!(harness.query_by_label("Halt").is_some());
}

#[test]
fn a_quick_stop_says_why_a_fault_shows_its_code_beside_clear_error_and_no_link_its_age() {
    let mut harness = app_harness();
    connected(&mut harness);
    // Quick stop option 6: brake on the quick stop ramp and stay in Quick Stop Active.
    harness
        .state_mut()
        .shown_mut()
        .request(Request::WriteObject {
            address: Address::new(0x605A, 0),
            dtype: DataType::Integer16,
            value: Value::Int(6),
            path: ObjectPath::Auto,
        });
    harness.get_by_label("Velocity").click();
    harness.step();
    step_until_shown(&mut harness, "MOVING +300 rpm");
    harness.get_by_label("QUICKSTOP (Esc)").click();
    harness.step();
    step_until_shown(&mut harness, "QUICK STOP");
    assert_eq!(power(&harness), Some(PowerState::QuickStopActive));
    let why = shown_containing(&mut harness, "Why: ");
    assert!(why.contains("Quickstop sent from this window at"), "{why}");

    // A fault: its code and meaning, and Clear error beside it.
    assert!(
        harness.query_by_label("Clear error").is_none(),
        "no fault yet"
    );
    let inject = |active| Request::Inject {
        injection: Injection::OverCurrent,
        active,
    };
    harness.state_mut().shown_mut().request(inject(true));
    let fault = shown_containing(&mut harness, "FAULT 2300h");
    assert!(
        fault.len() > "FAULT 2300h ".len(),
        "with its meaning: {fault}"
    );
    // A command the drive refuses: the line under the tile says why.
    harness.get_by_label("Velocity").click();
    harness.step();
    step_until(
        &mut harness,
        "the refusal under the tile",
        Duration::from_secs(5),
        |h| {
            h.query_by_label_contains("Why: ")
                .is_some_and(|_| window::text_containing(h, "Why: ").contains("refused"))
        },
    );
    let why = window::text_containing(&harness, "Why: ");
    assert!(why.starts_with("Why: Profile Velocity"), "{why}");
    harness.state_mut().shown_mut().request(inject(false));
    harness.step();
    press(&mut harness, "Clear error");
    step_until_shown(&mut harness, "DISABLED");
    assert!(harness.query_by_label("Clear error").is_none());

    // Disconnected on purpose: a calm DISCONNECTED (no alarm), the last state known and
    // how long ago the drive was seen.
    // 605Ah was changed: the window asks whether to restore it first.
    press(&mut harness, "Disconnect");
    step_until_shown(&mut harness, "Leave it as it is, disconnect");
    press(&mut harness, "Leave it as it is, disconnect");
    step_until_shown(&mut harness, "DISCONNECTED");
    let detail = shown_containing(&mut harness, "last known: ");
    assert!(detail.starts_with("last known: "), "{detail}");
    assert!(detail.ends_with(" s ago)"), "{detail}");
    assert!(harness.query_by_label_contains("NO LINK").is_none());
    assert!(
        harness
            .get_by_label("Enable")
            .accesskit_node()
            .is_disabled(),
        "nothing to enable without a link"
    );
}

#[test]
fn a_limit_switch_that_blocks_a_move_is_named_with_its_direction() {
    let mut harness = app_harness();
    connected(&mut harness);
    // Past the positive limit switch at 3600.0°, fast.
    window::fill(
        &mut harness,
        &[
            ("Move absolute: Target position", "40000"),
            ("Move absolute: Max speed", "3000"),
        ],
    );
    harness.get_by_label("Move absolute").click();
    harness.step();
    step_until(
        &mut harness,
        "the limit switch",
        Duration::from_secs(10),
        |h| h.state().shown().bit(StatusBit::LimitReached),
    );
    let line = shown_containing(&mut harness, "limit switch active");
    assert!(
        line.starts_with("Positive limit switch active (60FDh bit 1)")
            && line.contains("positive (+) direction is blocked"),
        "{line}"
    );
}

/// The rectangle of the widget labelled `label`, which must lie on screen.
fn on_screen(harness: &Harness<'_, App>, label: &str, screen: egui::Rect) -> egui::Rect {
    let rect = harness.get_by_label(label).rect();
    assert!(
        screen.contains_rect(rect),
        "'{label}' at {rect:?} is cut off the {screen:?} window"
    );
    rect
}

#[test]
fn at_1366_by_768_nothing_needed_is_cut_off_and_the_command_panel_folds() {
    let size = egui::vec2(1366.0, 768.0);
    let screen = egui::Rect::from_min_size(egui::Pos2::ZERO, size);
    let mut harness = harness_with(drivedeck::ui::Settings::default(), true, size);
    connected(&mut harness);
    step_until_shown(&mut harness, "DISABLED");
    for label in [
        "Disconnect",
        "QUICKSTOP (Esc)",
        "Switch off (Shift+Esc)",
        "DISABLED",
        "Enable",
        "Plots",
        "Object dictionary",
        "Collapse the command panel",
        "Halt",
        "Move absolute",
    ] {
        on_screen(&harness, label, screen);
    }
    let plots_tab = harness.get_by_label("Plots").rect();
    // The command panel leaves the plots most of the width: no row of it (a long unit,
    // an object's name) widens it past a third of the window.
    let commands_left = harness.get_by_label("Move absolute").rect().left();
    assert!(
        commands_left > size.x * 2.0 / 3.0,
        "the command panel starts at {commands_left}"
    );

    // Folded: a strip at the right edge, the plots get the room.
    harness.get_by_label("Collapse the command panel").click();
    harness.run_steps(3);
    assert!(harness.state().settings().commands_collapsed);
    assert!(harness.query_by_label("Move absolute").is_none());
    let expand = on_screen(&harness, "Expand the command panel", screen);
    assert!(expand.left() > size.x - 60.0, "a narrow strip: {expand:?}");
    on_screen(&harness, "DISABLED", screen);
    assert_eq!(harness.get_by_label("Plots").rect(), plots_tab);
    harness.get_by_label("Expand the command panel").click();
    harness.run_steps(3);
    assert!(!harness.state().settings().commands_collapsed);
    on_screen(&harness, "Move absolute", screen);
}

#[test]
fn at_1024_by_600_the_warning_after_a_link_loss_mid_move_is_seen_whole() {
    let size = egui::vec2(1024.0, 600.0);
    let screen = egui::Rect::from_min_size(egui::Pos2::ZERO, size);
    let mut harness = harness_with(drivedeck::ui::Settings::default(), true, size);
    connected(&mut harness);
    window::start_turning(&mut harness, 50.0);
    // The cable is pulled mid-move: the last halt cannot get through.
    harness.state_mut().shown_mut().request(Request::Inject {
        injection: Injection::LinkLoss,
        active: true,
    });
    step_until(
        &mut harness,
        "the warning of the halt that got no answer",
        Duration::from_secs(8),
        |h| {
            h.state()
                .shown()
                .motion
                .why
                .as_deref()
                .is_some_and(|w| w.contains("may still be moving"))
        },
    );
    harness.run_steps(3);
    let why = harness
        .state()
        .shown()
        .motion
        .why
        .clone()
        .unwrap_or_default();
    // What to do leads; the protocol's detail comes after it.
    assert!(
        why.starts_with("Stop the drive at the machine: it may still be moving"),
        "{why}"
    );
    // The tile's words, whole where they matter: the lead is on screen, inside the tile.
    let tile = harness
        .get_by_label_contains("Why: Stop the drive at the machine")
        .rect();
    assert!(screen.contains_rect(tile), "the tile's line at {tile:?}");
    // The log's line wraps inside the window instead of running off its right edge.
    let line = harness
        .get_all_by_label_contains("Stop the drive at the machine")
        .map(|n| n.rect())
        .filter(|r| r.top() > size.y * 0.6)
        .collect::<Vec<_>>();
    assert!(!line.is_empty(), "the log shows the warning");
    for rect in line {
        assert!(
            rect.right() <= size.x,
            "the log line ends at {} in a {} px window",
            rect.right(),
            size.x
        );
    }
}

#[test]
fn secondary_text_is_legible() {
    let mut harness = app_harness();
    connected(&mut harness);
    harness.run_steps(2);
    let style = harness.ctx.global_style();
    let small = style
        .text_styles
        .get(&egui::TextStyle::Small)
        .map_or(0.0, |f| f.size);
    assert!(small >= 12.0, "small text is {small} points");
    // Weak text against the panel's background: at least 4.5:1 (WCAG AA).
    let luminance = |c: egui::Color32| {
        let channel = |v: u8| {
            let v = f32::from(v) / 255.0;
            if v <= 0.040_45 {
                v / 12.92
            } else {
                ((v + 0.055) / 1.055).powf(2.4)
            }
        };
        0.2126 * channel(c.r()) + 0.7152 * channel(c.g()) + 0.0722 * channel(c.b())
    };
    let weak = luminance(style.visuals.weak_text_color());
    let background = luminance(style.visuals.panel_fill);
    let contrast = (weak.max(background) + 0.05) / (weak.min(background) + 0.05);
    assert!(contrast >= 4.5, "weak text contrast {contrast:.1}:1");
}

#[test]
fn the_first_start_on_a_narrow_screen_folds_the_command_panel() {
    for (size, folded) in [
        (egui::vec2(1024.0, 600.0), true),
        (egui::vec2(1366.0, 768.0), false),
    ] {
        let mut app = App::new(
            drivedeck::ui::Settings::default(),
            std::sync::Arc::new(|| {}),
            false,
        );
        app.first_start();
        let mut harness = Harness::builder()
            .with_size(size)
            .build_ui_state(|ui, app: &mut App| app.frame(ui), app);
        harness.run_steps(2);
        assert_eq!(
            harness.state().settings().commands_collapsed,
            folded,
            "at {size:?}"
        );
        // Later starts keep what the user chose: one click brings the panel back.
        if folded {
            harness.get_by_label("Expand the command panel").click();
            harness.run_steps(2);
            assert!(!harness.state().settings().commands_collapsed);
        }
    }
}
