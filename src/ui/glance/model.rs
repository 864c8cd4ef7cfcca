//! The state tile's words: what a sample says the drive does ("MOVING +300 rpm", "FAULT
//! 2300h …"), how to colour it, the motion in a sentence, and the limit switch that
//! blocks travel.
//!
//! A model: no egui here.

use crate::cia::{ErrorCode, PowerState};
use crate::pdi::StatusBit;
use crate::signal::AT_REST_RPM;
use crate::worker::Sample;

/// How the tile is coloured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tone {
    /// Energised and doing what it was told.
    Go,
    /// Stopped on purpose (halt, quick stop): energised, waiting.
    Held,
    /// Power stage off.
    Off,
    /// A fault, or no link.
    Alarm,
}

/// The tile's words.
#[derive(Clone, Debug, PartialEq)]
pub struct Glance {
    /// "MOVING +300 rpm", "FAULT 2300h output current too large", "NO LINK (…)".
    pub headline: String,
    pub tone: Tone,
    /// The CiA 402 state and its meaning, or the last known state while there is no link.
    pub detail: String,
    /// A fault is active (Clear error is offered).
    pub fault: bool,
}

/// What a sample says the drive does: headline, tone, and whether it is a fault.
pub fn doing(sample: &Sample) -> (String, Tone, bool) {
    let status = sample.tx.status;
    let power = sample.statusword().and_then(PowerState::from_statusword);
    let fault = match power {
        Some(p) => matches!(p, PowerState::Fault | PowerState::FaultReactionActive),
        None => status.is_set(StatusBit::Fault),
    };
    if fault {
        let code = ErrorCode(sample.tx.error_code);
        let headline = if code.0 == 0 {
            "FAULT".to_owned()
        } else {
            format!("FAULT {:04X}h {}", code.0, code.meaning())
        };
        return (headline, Tone::Alarm, true);
    }
    let enabled = match power {
        Some(p) => p == PowerState::OperationEnabled,
        None => status.is_set(StatusBit::OperationEnabled),
    };
    let quick_stop = match power {
        Some(p) => p == PowerState::QuickStopActive,
        None => !enabled && status.is_set(StatusBit::QsHaltBit),
    };
    if quick_stop {
        return ("QUICK STOP".to_owned(), Tone::Held, false);
    }
    if !enabled {
        return ("DISABLED".to_owned(), Tone::Off, false);
    }
    let halt = status.is_set(StatusBit::QsHaltBit);
    match sample.velocity() {
        Some(v) if v.abs() >= AT_REST_RPM => {
            let verb = if halt { "HALTING" } else { "MOVING" };
            (format!("{verb} {v:+.0} rpm"), Tone::Go, false)
        }
        _ if halt => ("HALTED".to_owned(), Tone::Held, false),
        _ => ("ENABLED".to_owned(), Tone::Go, false),
    }
}

/// The CiA 402 state in words, or what PDI-Status alone tells.
pub fn power_words(sample: &Sample) -> String {
    match sample.statusword().and_then(PowerState::from_statusword) {
        Some(power) => format!("{}: {}", power.name(), power.meaning()),
        None => "CiA 402 state unknown (6041h not read): from PDI-Status".to_owned(),
    }
}

/// What the motor does, for a sentence: "moving at 300 rpm", "standing still".
pub fn motion_words(sample: &Sample) -> String {
    let halt = sample.tx.status.is_set(StatusBit::QsHaltBit);
    match sample.velocity() {
        Some(v) if v.abs() >= AT_REST_RPM && halt => format!("braking, at {v:.0} rpm"),
        Some(v) if v.abs() >= AT_REST_RPM => format!("moving at {v:.0} rpm"),
        Some(_) if halt => "halted, standing still".to_owned(),
        Some(_) => "standing still".to_owned(),
        None => "at an unknown speed (606Ch not read)".to_owned(),
    }
}

/// The limit switch that blocks travel, named by its input and the direction it blocks.
pub fn limit_words(sample: &Sample) -> Option<String> {
    let reached = sample.tx.status.is_set(StatusBit::LimitReached);
    let inputs = sample.digital_inputs();
    let (negative, positive) = match inputs {
        Some(di) => (di & 1 != 0, di & 2 != 0),
        None => (false, false),
    };
    Some(match (negative, positive) {
        (true, true) => "Both limit switches active (60FDh bits 0 and 1): travel is blocked in both directions".to_owned(),
        (true, false) => "Negative limit switch active (60FDh bit 0): travel in the negative (-) direction is blocked; move + to leave it".to_owned(),
        (false, true) => "Positive limit switch active (60FDh bit 1): travel in the positive (+) direction is blocked; move - to leave it".to_owned(),
        (false, false) if !reached => return None,
        (false, false) if inputs.is_some() => "Limit reached (PDI-Status), but no limit switch input is active in 60FDh: a software position limit (607Dh)?".to_owned(),
        (false, false) => "Limit reached (PDI-Status): which switch is unknown, 60FDh is not read on this link".to_owned(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pdi::{Status, TxImage};
    use crate::signal::{Signal, Signals};

    /// A sample with Limit reached as given and the digital inputs 60FDh if read.
    fn sample(limit_reached: bool, inputs: Option<u32>) -> Sample {
        let mut signals = Signals::default();
        if let Some(di) = inputs {
            signals.set(Signal::DigitalInputs, f64::from(di));
        }
        let status = if limit_reached {
            StatusBit::LimitReached.mask()
        } else {
            0
        };
        Sample {
            tx: TxImage {
                status: Status(status),
                error_code: 0,
                return_value: 0,
            },
            signals,
            ..Default::default()
        }
    }

    #[test]
    fn each_limit_switch_is_named_with_the_direction_it_blocks() {
        let words = |reached, inputs| limit_words(&sample(reached, inputs));
        let negative = words(true, Some(0b01)).expect("named");
        assert!(
            negative.starts_with("Negative limit switch active (60FDh bit 0)")
                && negative.contains("negative (-) direction is blocked; move + to leave it"),
            "{negative}"
        );
        let positive = words(true, Some(0b10)).expect("named");
        assert!(
            positive.starts_with("Positive limit switch active (60FDh bit 1)")
                && positive.contains("move - to leave it"),
            "{positive}"
        );
        // Other inputs (bit 2 homing switch and up) do not count as limit switches.
        let both = words(true, Some(0b111)).expect("named");
        assert!(both.starts_with("Both limit switches active"), "{both}");
        // A switch pressed while nothing is moving is still worth a line.
        assert!(words(false, Some(0b01)).is_some());
        assert_eq!(words(false, Some(0b100)), None, "no switch, no limit");
        assert_eq!(words(false, None), None);
        let software = words(true, Some(0)).expect("said");
        assert!(
            software.contains("software position limit (607Dh)"),
            "{software}"
        );
        let unknown = words(true, None).expect("said");
        assert!(
            unknown.contains("60FDh is not read on this link"),
            "{unknown}"
        );
    }
}
