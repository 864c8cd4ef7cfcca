//! Every request a drive's worker is asked for leaves with its owner — who asked and what
//! for — and gets the worker's id; the replies (`Rejected`, `Sent`, `Progress`,
//! `ObjectRead`, `ObjectWritten`, `Cancelled`, `Scanned`) come back with that id and are
//! handed to the owner from one place, [`super::Drive::apply`]. Nothing is matched by
//! comparing requests, so two panels may ask the same thing at once.
//!
//! A model: no egui here.

use std::any::TypeId;
use std::collections::BTreeMap;

use crate::ui::browser;
use crate::worker::{Request, RequestId};

/// Who asked for a request, and what for: its replies go back there.
#[derive(Clone, Debug, PartialEq)]
pub enum Owner {
    /// The user (a button, a key, a restore, leaving): logged, its outcome shown in the
    /// log, a refusal or failure said on the state tile.
    User,
    /// The window's own settings for the link (poll rate, trace, link-loss policy), the
    /// connection, the lists of ports and interfaces: reported by their own events, not
    /// logged.
    Window,
    /// The device's identity (1008h, 1018h, …) read on connecting: the exports' header,
    /// another-drive markers, the project check.
    Identity,
    /// 1001h and 1003h, read on connecting and on every new fault, for the timeline.
    Diagnosis,
    /// 6087h read on connecting, so a torque command with slope 0 is warned about.
    TorqueSlope,
    /// The object dictionary browser, with its own note of what the request is for.
    Browser(browser::Pending),
    /// The watch panel's cyclic read.
    Watch,
    /// A panel whose model the drive keeps for it (`ui::panel`), by the model's type, with
    /// the panel's own tag.
    Panel { panel: TypeId, tag: u64 },
}

impl Owner {
    /// Whether the log lists the request.
    pub fn is_logged(&self) -> bool {
        *self == Owner::User
    }
}

/// The most owners remembered: a request whose replies never all came (a link that went
/// away mid-read) is forgotten once this many newer ones were sent.
const REMEMBERED: usize = 16_384;

/// A drive's requests: the ones waiting to be handed to its worker, and the owner of every
/// one handed over, by id.
#[derive(Clone, Debug, Default)]
pub struct Requests {
    outbox: Vec<(Owner, Request)>,
    owners: BTreeMap<RequestId, Owner>,
}

impl Requests {
    /// Queue `request` for the worker on behalf of `owner`.
    pub fn push(&mut self, owner: Owner, request: Request) {
        self.outbox.push((owner, request));
    }

    /// Queue `request` ahead of everything waiting (a stop).
    pub fn push_first(&mut self, owner: Owner, request: Request) {
        self.outbox.insert(0, (owner, request));
    }

    /// The request queued last, taken back.
    pub fn take_last(&mut self) -> Option<(Owner, Request)> {
        self.outbox.pop()
    }

    /// Take what waits: only the urgent requests (stops, halt) when `urgent`, all of it
    /// otherwise.
    pub fn take(&mut self, urgent: bool) -> Vec<(Owner, Request)> {
        if !urgent {
            return std::mem::take(&mut self.outbox);
        }
        let (urgent, rest) = std::mem::take(&mut self.outbox)
            .into_iter()
            .partition(|(_, r)| r.is_urgent());
        self.outbox = rest;
        urgent
    }

    /// The requests waiting to be handed over.
    pub fn waiting(&self) -> impl Iterator<Item = &(Owner, Request)> {
        self.outbox.iter()
    }

    /// Whether a request of `owner` waits.
    pub fn waits_for(&self, owner: &Owner) -> bool {
        self.outbox.iter().any(|(o, _)| o == owner)
    }

    /// The worker took a request as `id`: its replies go to `owner`.
    pub fn sent(&mut self, id: RequestId, owner: Owner) {
        self.owners.insert(id, owner);
        while self.owners.len() > REMEMBERED {
            self.owners.pop_first();
        }
    }

    /// Who asked for request `id`, to be told of a reply.
    pub fn owner_mut(&mut self, id: RequestId) -> Option<&mut Owner> {
        self.owners.get_mut(&id)
    }

    pub fn owner(&self, id: RequestId) -> Option<&Owner> {
        self.owners.get(&id)
    }

    /// Request `id` is over: no more replies are expected.
    pub fn done(&mut self, id: RequestId) {
        self.owners.remove(&id);
    }

    /// Every owner of a request still on its way (a new connection makes a panel's old
    /// ones stale).
    pub fn owners_mut(&mut self) -> impl Iterator<Item = &mut Owner> {
        self.owners.values_mut()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pdi::Action;

    #[test]
    fn the_same_request_from_two_owners_keeps_both_apart() {
        let mut requests = Requests::default();
        let read = Request::ReadMany {
            objects: vec![],
            path: crate::worker::ObjectPath::Auto,
        };
        requests.push(Owner::Watch, read.clone());
        requests.push(Owner::Identity, read.clone());
        requests.push_first(Owner::User, Request::Command(Action::Quickstop));
        let urgent = requests.take(true);
        assert_eq!(urgent.len(), 1);
        let rest = requests.take(false);
        assert_eq!(
            rest.iter().map(|(o, _)| o.clone()).collect::<Vec<_>>(),
            [Owner::Watch, Owner::Identity]
        );
        requests.sent(7, Owner::Watch);
        requests.sent(8, Owner::Identity);
        assert_eq!(requests.owner(7), Some(&Owner::Watch));
        assert_eq!(requests.owner(8), Some(&Owner::Identity));
        requests.done(7);
        assert_eq!(requests.owner(7), None);
    }

    #[test]
    fn owners_of_requests_never_answered_are_forgotten_in_the_end() {
        let mut requests = Requests::default();
        for id in 0..(REMEMBERED as u64 + 10) {
            requests.sent(id, Owner::User);
        }
        assert_eq!(requests.owner(0), None);
        assert_eq!(requests.owner(REMEMBERED as u64 + 9), Some(&Owner::User));
    }
}
