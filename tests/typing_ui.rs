//! Fast typing in the window, headless (egui_kittest): characters, then a click or Tab,
//! then more characters, all within one frame (the real window draws 8–15 frames/s under
//! software OpenGL, so a fast typist puts several events into one frame). Every key must
//! land in the field that had the keyboard when it was typed. The events go through the
//! window's input queue as eframe's `raw_input_hook` hands them over.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod window;

use drivedeck::ui::App;
use eframe::egui;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use window::{choose_bus, disconnected_harness};

/// The events of one frame of the real window, through the window's input queue: as many
/// frames as the queue splits them into.
fn step_as_the_window_does(harness: &mut Harness<'_, App>) {
    let mut events = std::mem::take(&mut harness.input_mut().events);
    loop {
        let now = harness
            .state_mut()
            .take_input_frame(std::mem::take(&mut events));
        harness.input_mut().events = now;
        harness.step();
        if !harness.state().input_pending() {
            break;
        }
    }
    harness.run_steps(2);
}

fn pointer_click(harness: &mut Harness<'_, App>, at: egui::Pos2) {
    let input = harness.input_mut();
    input.events.push(egui::Event::PointerMoved(at));
    for pressed in [true, false] {
        input.events.push(egui::Event::PointerButton {
            pos: at,
            button: egui::PointerButton::Primary,
            pressed,
            modifiers: egui::Modifiers::default(),
        });
    }
}

fn key(harness: &mut Harness<'_, App>, key: egui::Key) {
    for pressed in [true, false] {
        harness.input_mut().events.push(egui::Event::Key {
            key,
            physical_key: None,
            pressed,
            repeat: false,
            modifiers: egui::Modifiers::default(),
        });
    }
}

fn text(harness: &mut Harness<'_, App>, text: &str) {
    for c in text.chars() {
        harness
            .input_mut()
            .events
            .push(egui::Event::Text(c.to_string()));
    }
}

/// The Modbus TCP bar with its host box holding the keyboard, emptied.
fn modbus_bar() -> Harness<'static, App> {
    let mut harness = disconnected_harness();
    choose_bus(&mut harness, "Modbus TCP");
    harness
        .get_by_label("Connection: Host")
        .set_text_value_accesskit("");
    harness.run();
    let host = harness.get_by_label("Connection: Host").rect().center();
    pointer_click(&mut harness, host);
    step_as_the_window_does(&mut harness);
    assert!(harness.get_by_label("Connection: Host").is_focused());
    harness
}

fn value(harness: &Harness<'_, App>, label: &str) -> String {
    harness.get_by_label(label).value().unwrap_or_default()
}

#[test]
fn typing_then_a_click_then_typing_in_one_frame_lands_where_typed() {
    let mut harness = modbus_bar();
    // Select the port's text by clicking into it needs its own text gone first.
    harness
        .get_by_label("Connection: Port")
        .set_text_value_accesskit("");
    harness.run();
    let host = harness.get_by_label("Connection: Host").rect().center();
    pointer_click(&mut harness, host);
    step_as_the_window_does(&mut harness);
    let port = harness.get_by_label("Connection: Port").rect().center();
    text(&mut harness, "127.0.0.1");
    pointer_click(&mut harness, port);
    text(&mut harness, "1502");
    step_as_the_window_does(&mut harness);
    assert_eq!(value(&harness, "Connection: Host"), "127.0.0.1");
    assert_eq!(value(&harness, "Connection: Port"), "1502");
}

#[test]
fn typing_then_tab_then_typing_in_one_frame_lands_where_typed() {
    let mut harness = modbus_bar();
    harness
        .get_by_label("Connection: Port")
        .set_text_value_accesskit("");
    harness.run();
    let host = harness.get_by_label("Connection: Host").rect().center();
    pointer_click(&mut harness, host);
    step_as_the_window_does(&mut harness);
    text(&mut harness, "192.168.2.100");
    key(&mut harness, egui::Key::Tab);
    text(&mut harness, "502");
    step_as_the_window_does(&mut harness);
    assert_eq!(value(&harness, "Connection: Host"), "192.168.2.100");
    assert_eq!(value(&harness, "Connection: Port"), "502");
}

#[test]
fn tab_into_a_box_that_holds_text_selects_it_so_typing_replaces_it() {
    let mut harness = modbus_bar();
    let before = value(&harness, "Connection: Port");
    assert!(!before.is_empty(), "the port box holds its default");
    text(&mut harness, "10.0.0.5");
    key(&mut harness, egui::Key::Tab);
    text(&mut harness, "1502");
    step_as_the_window_does(&mut harness);
    assert_eq!(value(&harness, "Connection: Host"), "10.0.0.5");
    assert_eq!(value(&harness, "Connection: Port"), "1502");
}
