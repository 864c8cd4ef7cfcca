//! The trigger as typed: a status-bit edge or a threshold crossing, with pre- and
//! post-trigger time; and the trigger it describes, or why it describes none.
//!
//! A model: no egui here.

use serde::{Deserialize, Serialize};

use crate::telemetry::{Builtin, Condition, Edge, Kind, Trigger};

/// The trigger as typed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct TriggerForm {
    pub threshold: bool,
    /// The signal's id.
    pub signal: String,
    pub bit: u8,
    pub level: String,
    pub edge: Edge,
    pub pre_s: String,
    pub post_s: String,
}

impl Default for TriggerForm {
    fn default() -> Self {
        Self {
            threshold: false,
            signal: Builtin::PdiStatus.id().into(),
            bit: crate::pdi::StatusBit::TargetReached.bit(),
            level: "1000".into(),
            edge: Edge::Rising,
            pre_s: "1".into(),
            post_s: "2".into(),
        }
    }
}

pub fn edge_text(edge: Edge) -> &'static str {
    match edge {
        Edge::Rising => "rises",
        Edge::Falling => "falls",
        Edge::Either => "changes",
    }
}

impl TriggerForm {
    /// The trigger it describes, or why not.
    pub fn trigger(&self, scope: &crate::telemetry::Scope) -> Result<Trigger, String> {
        let signal = scope
            .signal(&self.signal)
            .ok_or_else(|| format!("no signal '{}' to trigger on", self.signal))?;
        let seconds = |text: &str, what: &str| {
            text.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite() && (0.0..=3600.0).contains(v))
                .ok_or_else(|| format!("{what} '{text}' is not a time of 0 to 3600 s"))
        };
        let pre_s = seconds(&self.pre_s, "pre-trigger")?;
        let post_s = seconds(&self.post_s, "post-trigger")?;
        let condition = if self.threshold {
            let level = self
                .level
                .trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| format!("level '{}' is not a number", self.level))?;
            Condition::Threshold {
                channel: signal.column,
                level,
                edge: self.edge,
            }
        } else {
            if signal.kind != Kind::Bits {
                return Err(format!(
                    "{} has no bits: pick PDI-Status or the digital inputs, or a threshold",
                    signal.info.name
                ));
            }
            Condition::Bit {
                channel: signal.column,
                bit: self.bit.min(31),
                edge: self.edge,
            }
        };
        Ok(Trigger {
            condition,
            pre_s,
            post_s,
        })
    }
}
