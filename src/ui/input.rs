//! The window's input, one focus at a time: a frame never holds typing together with a
//! change of the keyboard focus (a click, a press of Tab or Enter, an accessibility
//! action). The real window draws 8–15 frames/s under software OpenGL, so a fast typist
//! puts "127.0.0.1", a click into the next box and the next characters into one frame;
//! egui hands every key of a frame to whichever text box holds the focus when that box
//! is drawn, so keys landed in the box clicked afterwards (or in both). Here the events
//! of such a frame are held back and handed over in order, one frame per focus, before
//! egui sees them (eframe's `raw_input_hook`).

use std::collections::VecDeque;

use eframe::egui::{Event, Key};

/// What an event does to the text boxes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// Goes into the box that has the keyboard: text, a key press, a paste.
    Typing,
    /// May move the keyboard to another box: a pointer button, Tab or Enter pressed, an
    /// accessibility action.
    Focus,
    /// Neither: pointer moves, key releases, the wheel, the window's own news.
    Other,
}

fn kind(event: &Event) -> Kind {
    match event {
        Event::Key {
            key: Key::Tab | Key::Enter,
            pressed: true,
            ..
        }
        | Event::PointerButton { .. }
        | Event::AccessKitActionRequest(_) => Kind::Focus,
        Event::Key { pressed: true, .. }
        | Event::Text(_)
        | Event::Paste(_)
        | Event::Copy
        | Event::Cut
        | Event::Ime(_) => Kind::Typing,
        _ => Kind::Other,
    }
}

/// Events held for the frames to come.
#[derive(Debug, Default)]
pub struct InputQueue {
    held: VecDeque<Event>,
}

impl InputQueue {
    /// This frame's events: those held from before, then `incoming`, up to the first
    /// change between typing and a change of focus; the rest is held for the next frames.
    /// A press of Tab or Enter ends its frame (egui moves the focus once per frame), and
    /// a pointer button's release ends its frame (the click is whole).
    pub fn take_frame(&mut self, incoming: Vec<Event>) -> Vec<Event> {
        self.held.extend(incoming);
        let mut frame = Vec::new();
        let mut this: Option<Kind> = None;
        while let Some(event) = self.held.front() {
            let k = kind(event);
            if k != Kind::Other {
                match this {
                    Some(t) if t != k => break,
                    _ => this = Some(k),
                }
            }
            let ends = matches!(
                event,
                Event::Key {
                    key: Key::Tab | Key::Enter,
                    pressed: true,
                    ..
                } | Event::PointerButton { pressed: false, .. }
            );
            if let Some(event) = self.held.pop_front() {
                frame.push(event);
            }
            if ends {
                // What follows at once and changes nothing (the key's release, a pointer
                // move) may come along.
                while self.held.front().is_some_and(|e| kind(e) == Kind::Other) {
                    if let Some(event) = self.held.pop_front() {
                        frame.push(event);
                    }
                }
                break;
            }
        }
        frame
    }

    /// Events are held for the next frame: ask for it at once.
    pub fn pending(&self) -> bool {
        !self.held.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use eframe::egui::{Modifiers, PointerButton, Pos2};

    fn text(s: &str) -> Event {
        Event::Text(s.into())
    }
    fn key(key: Key, pressed: bool) -> Event {
        Event::Key {
            key,
            physical_key: None,
            pressed,
            repeat: false,
            modifiers: Modifiers::default(),
        }
    }
    fn button(pressed: bool) -> Event {
        Event::PointerButton {
            pos: Pos2::new(10.0, 10.0),
            button: PointerButton::Primary,
            pressed,
            modifiers: Modifiers::default(),
        }
    }
    fn moved() -> Event {
        Event::PointerMoved(Pos2::new(10.0, 10.0))
    }

    /// Every frame the queue hands over, until it holds nothing.
    fn frames(incoming: Vec<Event>) -> Vec<Vec<Event>> {
        let mut queue = InputQueue::default();
        let mut out = vec![queue.take_frame(incoming)];
        while queue.pending() {
            out.push(queue.take_frame(Vec::new()));
        }
        out
    }

    #[test]
    fn typing_a_click_and_typing_are_three_frames() {
        let got = frames(vec![
            text("1"),
            text("2"),
            moved(),
            button(true),
            button(false),
            text("5"),
        ]);
        assert_eq!(
            got,
            vec![
                vec![text("1"), text("2"), moved()],
                vec![button(true), button(false)],
                vec![text("5")],
            ]
        );
    }

    #[test]
    fn tab_ends_its_frame_with_its_release() {
        let got = frames(vec![
            text("a"),
            key(Key::Tab, true),
            key(Key::Tab, false),
            key(Key::Tab, true),
            text("b"),
        ]);
        assert_eq!(
            got,
            vec![
                vec![text("a")],
                vec![key(Key::Tab, true), key(Key::Tab, false)],
                vec![key(Key::Tab, true)],
                vec![text("b")],
            ]
        );
    }

    #[test]
    fn typing_alone_stays_one_frame() {
        let typed = vec![key(Key::A, true), text("a"), key(Key::A, false), text("b")];
        assert_eq!(frames(typed.clone()), vec![typed]);
    }

    #[test]
    fn held_events_come_before_new_ones_in_order() {
        let mut queue = InputQueue::default();
        let first = queue.take_frame(vec![text("1"), button(true), button(false), text("2")]);
        assert_eq!(first, vec![text("1")]);
        let second = queue.take_frame(vec![text("3")]);
        assert_eq!(second, vec![button(true), button(false)]);
        let third = queue.take_frame(Vec::new());
        assert_eq!(third, vec![text("2"), text("3")]);
        assert!(!queue.pending());
    }
}
