//! What the command line does at the edges, set once from its flags.

use crate::worker::{self, LinkLossAction};

/// What the command line does at the edges: what an interrupted or timed-out move, or a
/// lost link, leaves the drive in, and how many failed exchanges in a row lose the link.
/// Set once from the flags (`--on-exit`, `--lost-after`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Policy {
    pub on_exit: LinkLossAction,
    pub lost_after: u32,
}

impl Default for Policy {
    fn default() -> Self {
        Policy {
            on_exit: LinkLossAction::Halt,
            lost_after: worker::LOST_AFTER,
        }
    }
}

static POLICY: std::sync::OnceLock<Policy> = std::sync::OnceLock::new();

/// Set the policy from the command line's flags (once; later calls change nothing).
pub fn set_policy(policy: Policy) {
    let _ = POLICY.set(policy);
}

pub(super) fn policy() -> Policy {
    POLICY.get().copied().unwrap_or_default()
}

/// What an interrupted command leaves the drive in (`--on-exit`).
pub(super) fn on_exit() -> LinkLossAction {
    policy().on_exit
}
