//! A panel's model, one per drive, kept by the drive without the drive knowing its type:
//! the recipe a new panel follows (see ARCHITECTURE.md, "A new panel"). The model is plain
//! data with no egui; it hears every event of its drive, the replies to the requests it
//! asked for (each with the tag it gave), and hands its requests over when the drive
//! sends. Its view reads it through [`Panels::get`] and pushes the user's intents as
//! commands; one line in `ui::view` registers the view.
//!
//! A model: no egui here.

use std::any::{Any, TypeId};
use std::fmt::Debug;

use crate::worker::{Event, Request};

/// Any type as `Any`, so [`Panels`] can find a model again by its type.
pub trait AsAny: Any {
    fn as_any(&self) -> &dyn Any;
    fn as_any_mut(&mut self) -> &mut dyn Any;
}

impl<T: Any> AsAny for T {
    fn as_any(&self) -> &dyn Any {
        self
    }
    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}

/// What a panel's model does with its drive's news. Every method has a default, so a
/// model that only shows what it is told needs none but `on_event`.
pub trait PanelModel: AsAny + Debug {
    /// Every worker event of its drive, in order.
    fn on_event(&mut self, _event: &Event) {}

    /// A reply to one of its requests (`Rejected`, `Sent`, `Progress`, `ObjectRead`,
    /// `ObjectWritten`, `Cancelled`): `tag` is what it said the request was for. `true`
    /// when the request is over (no more replies are expected).
    fn on_reply(&mut self, _tag: u64, _event: &Event) -> bool {
        false
    }

    /// The window's clock (seconds), every frame: for waits and time-outs of its own.
    fn tick(&mut self, _now: f64) {}

    /// What it holds on the drive that must be given back before the window lets go of
    /// the drive (an output it forced), one sentence each; empty when nothing.
    fn holding(&self) -> Vec<String> {
        Vec::new()
    }

    /// The drive is being left (Disconnect, closing the window): give back what it holds.
    /// Its requests go out with the next frame's; `holding` stays non-empty until they
    /// are answered.
    fn let_go(&mut self) {}

    /// The requests it wants sent now, each with its tag.
    fn take_requests(&mut self) -> Vec<(u64, Request)> {
        Vec::new()
    }
}

/// When a panel that shows live values reads them again: every so many seconds of the
/// worker's clock (the samples' time), never while its last reading is under way.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Cadence {
    last: Option<f64>,
    /// A reading is under way.
    pub reading: bool,
}

impl Cadence {
    /// Whether a reading is due with these samples, `every` seconds after the last one
    /// (the reading then counts as under way).
    pub fn due(&mut self, samples: &[crate::signal::Sample], every: f64) -> bool {
        let Some(t) = samples.last().map(|s| s.t) else {
            return false;
        };
        if self.reading || self.last.is_some_and(|last| t - last < every) {
            return false;
        }
        self.last = Some(t);
        self.reading = true;
        true
    }

    /// Read again with the next samples (after a write, to show its effect soon).
    pub fn soon(&mut self) {
        self.last = None;
    }
}

/// The panels' models of one drive, one of each type, made when first asked for.
#[derive(Debug, Default)]
pub struct Panels {
    models: Vec<(TypeId, Box<dyn PanelModel>)>,
}

impl Panels {
    /// The model of type `M`, made (empty) the first time it is asked for.
    pub fn get<M: PanelModel + Default>(&mut self) -> &mut M {
        let id = TypeId::of::<M>();
        let at = match self.models.iter().position(|(t, _)| *t == id) {
            Some(at) => at,
            None => {
                self.models.push((id, Box::new(M::default())));
                self.models.len() - 1
            }
        };
        match self.models[at].1.as_mut().as_any_mut().downcast_mut::<M>() {
            Some(model) => model,
            // The box at `id` holds an `M`: put there above, under `M`'s own id.
            None => unreachable_model(),
        }
    }

    /// The model of type `M`, if one was made.
    pub fn find<M: PanelModel>(&self) -> Option<&M> {
        let id = TypeId::of::<M>();
        self.models
            .iter()
            .find(|(t, _)| *t == id)
            .and_then(|(_, m)| m.as_ref().as_any().downcast_ref::<M>())
    }

    /// An event of the drive, to every model.
    pub fn on_event(&mut self, event: &Event) {
        for (_, model) in &mut self.models {
            model.on_event(event);
        }
    }

    /// A reply to a request of the model of type `panel`; `true` when the request is over.
    pub fn on_reply(&mut self, panel: TypeId, tag: u64, event: &Event) -> bool {
        self.models
            .iter_mut()
            .find(|(t, _)| *t == panel)
            .is_some_and(|(_, m)| m.on_reply(tag, event))
    }

    /// The window's clock, to every model ([`PanelModel::tick`]).
    pub fn tick(&mut self, now: f64) {
        for (_, model) in &mut self.models {
            model.tick(now);
        }
    }

    /// What every model holds on the drive ([`PanelModel::holding`]).
    pub fn holding(&self) -> Vec<String> {
        self.models.iter().flat_map(|(_, m)| m.holding()).collect()
    }

    /// Every model gives back what it holds ([`PanelModel::let_go`]).
    pub fn let_go(&mut self) {
        for (_, model) in &mut self.models {
            model.let_go();
        }
    }

    /// Every model's requests, with the model's type and the request's tag.
    pub fn take_requests(&mut self) -> Vec<(TypeId, u64, Request)> {
        let mut out = Vec::new();
        for (id, model) in &mut self.models {
            out.extend(
                model
                    .take_requests()
                    .into_iter()
                    .map(|(tag, r)| (*id, tag, r)),
            );
        }
        out
    }
}

/// A model stored under another type's id: `Panels` never does that.
#[cold]
fn unreachable_model() -> ! {
    unreachable!("a panel model is stored under its own type's id")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, Default)]
    struct Counter {
        events: usize,
        asked: Vec<(u64, Request)>,
        replies: Vec<u64>,
    }

    impl PanelModel for Counter {
        fn on_event(&mut self, _event: &Event) {
            self.events += 1;
        }
        fn on_reply(&mut self, tag: u64, _event: &Event) -> bool {
            self.replies.push(tag);
            true
        }
        fn take_requests(&mut self) -> Vec<(u64, Request)> {
            std::mem::take(&mut self.asked)
        }
    }

    #[test]
    fn a_model_is_made_once_hears_every_event_and_its_own_replies() {
        let mut panels = Panels::default();
        assert!(panels.find::<Counter>().is_none());
        panels
            .get::<Counter>()
            .asked
            .push((7, Request::ListSerialPorts));
        panels.on_event(&Event::SerialPorts(vec![]));
        panels.on_event(&Event::Interfaces(vec![]));
        assert_eq!(panels.find::<Counter>().map(|c| c.events), Some(2));
        let asked = panels.take_requests();
        assert_eq!(asked.len(), 1);
        let (panel, tag, _) = asked[0].clone();
        assert_eq!((panel, tag), (TypeId::of::<Counter>(), 7));
        assert!(panels.on_reply(panel, tag, &Event::SerialPorts(vec![])));
        assert_eq!(panels.get::<Counter>().replies, [7]);
    }
}
