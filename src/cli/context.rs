//! What the command line's flags ask of every session a run opens, built once in
//! [`super::main`] and handed down to what opens sessions: no process-wide state, so a
//! function's parameters say everything it depends on.

use crate::project::Drive;
use crate::worker::LinkLossAction;

/// What one run of the command line carries to each session it opens: how the edges are
/// handled, and which device the project expects to find.
#[derive(Clone, Debug)]
pub(super) struct Context {
    /// `--on-exit` and `--lost-after` (or the project drive's own options).
    pub(super) policy: Policy,
    /// The project's drive a one-shot command talks to (`--drive NAME`), when the project
    /// stores its identity: each session checks the device against it once connected.
    pub(super) expected: Option<Drive>,
}

impl Context {
    /// Check the device each session connects to against `drive`'s stored identity (a
    /// drive without one has nothing to be checked against).
    pub(super) fn expect_device(&mut self, drive: &Drive) {
        if drive.identity.is_some() {
            self.expected = Some(drive.clone());
        }
    }
}

/// What the command line does at the edges: what an interrupted or timed-out move, or a
/// lost link, leaves the drive in, and how many failed exchanges in a row lose the link.
/// Set from the flags (`--on-exit`, `--lost-after`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Policy {
    pub(super) on_exit: LinkLossAction,
    pub(super) lost_after: u32,
}
