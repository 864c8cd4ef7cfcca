//! Triggered captures: wait for a condition on one channel (a status bit changing, a value
//! crossing a level), then report the window around it so the caller can cut a
//! [`super::recording::Recording`] out of the ring.
//!
//! Feed [`Capture::feed`] every row in order as it is pushed into the ring. It reports
//! [`CaptureEvent::Fired`] at the trigger sample and [`CaptureEvent::Complete`] once `post_s`
//! seconds have passed, with the window `[at - pre_s, at + post_s]` to record.

use serde::{Deserialize, Serialize};

/// Which direction of change fires a trigger.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Edge {
    Rising,
    Falling,
    Either,
}

/// What to wait for.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Condition {
    /// A bit of an integer channel (status word, digital inputs) changes.
    Bit { channel: usize, bit: u8, edge: Edge },
    /// A channel crosses a level.
    Threshold {
        channel: usize,
        level: f64,
        edge: Edge,
    },
}

/// A condition and how much to keep before and after the moment it fires.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Trigger {
    pub condition: Condition,
    /// Seconds kept before the trigger (negative or NaN count as 0).
    pub pre_s: f64,
    /// Seconds kept after the trigger (negative or NaN count as 0).
    pub post_s: f64,
}

/// Where a capture stands.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CaptureState {
    /// Not looking for the condition.
    Idle,
    /// Looking for the condition.
    Armed,
    /// The condition held at `at`; waiting for the post-trigger time to pass.
    Fired { at: f64 },
    /// The window `[from, to]` around the trigger at `at` is all in.
    Complete { from: f64, at: f64, to: f64 },
}

/// What one fed row did to a capture.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CaptureEvent {
    Nothing,
    /// The trigger fired at this row's time.
    Fired {
        at: f64,
    },
    /// The window `[from, to]` is complete: record it now.
    Complete {
        from: f64,
        at: f64,
        to: f64,
    },
}

/// A trigger being watched for.
#[derive(Debug, Clone)]
pub struct Capture {
    trigger: Trigger,
    state: CaptureState,
    /// The last non-NaN value of the trigger channel since arming.
    previous: Option<f64>,
}

impl Capture {
    /// A capture of `trigger`, idle until [`Capture::arm`].
    pub fn new(trigger: Trigger) -> Capture {
        Capture {
            trigger,
            state: CaptureState::Idle,
            previous: None,
        }
    }

    pub fn trigger(&self) -> &Trigger {
        &self.trigger
    }

    pub fn state(&self) -> CaptureState {
        self.state
    }

    /// Start looking for the condition. The previous sample is forgotten, so the first row
    /// after arming never fires, even when the level is already exceeded.
    pub fn arm(&mut self) {
        self.state = CaptureState::Armed;
        self.previous = None;
    }

    /// Stop looking.
    pub fn disarm(&mut self) {
        self.state = CaptureState::Idle;
        self.previous = None;
    }

    /// Feed every row in order, as it is pushed into the ring. Fires on the first sample at
    /// which the condition holds after a crossing: a rising threshold fires when the previous
    /// non-NaN value was below the level and this one is at or above it, a falling one when
    /// the previous was above and this one is at or below; a rising bit fires when the
    /// previous value had the bit 0 and this one 1 (values read as `u32`), and so on. Rows
    /// where the trigger channel is NaN (or missing) are skipped: they neither fire nor
    /// replace the previous value. `Complete` comes with the first row whose `t >= at +
    /// post_s` (the firing row itself when `post_s` is 0, which then reports `Complete`
    /// rather than `Fired`), and the capture stays complete until armed again.
    pub fn feed(&mut self, t: f64, row: &[f64]) -> CaptureEvent {
        match self.state {
            CaptureState::Idle | CaptureState::Complete { .. } => CaptureEvent::Nothing,
            CaptureState::Armed => {
                let Some(&v) = row.get(self.trigger.condition.channel()) else {
                    return CaptureEvent::Nothing;
                };
                if v.is_nan() {
                    return CaptureEvent::Nothing;
                }
                let fired = self
                    .previous
                    .is_some_and(|p| self.trigger.condition.crossed(p, v));
                self.previous = Some(v);
                if !fired {
                    return CaptureEvent::Nothing;
                }
                self.state = CaptureState::Fired { at: t };
                self.complete_if_due(t, t)
                    .unwrap_or(CaptureEvent::Fired { at: t })
            }
            CaptureState::Fired { at } => {
                self.complete_if_due(at, t).unwrap_or(CaptureEvent::Nothing)
            }
        }
    }

    fn complete_if_due(&mut self, at: f64, t: f64) -> Option<CaptureEvent> {
        let to = at + self.trigger.post_s.max(0.0);
        if t < to {
            return None;
        }
        let from = at - self.trigger.pre_s.max(0.0);
        self.state = CaptureState::Complete { from, at, to };
        Some(CaptureEvent::Complete { from, at, to })
    }
}

impl Condition {
    /// The channel the condition watches.
    pub fn channel(&self) -> usize {
        match *self {
            Condition::Bit { channel, .. } | Condition::Threshold { channel, .. } => channel,
        }
    }

    /// Whether going from `previous` to `current` (both non-NaN) meets the condition.
    fn crossed(&self, previous: f64, current: f64) -> bool {
        match *self {
            Condition::Threshold { level, edge, .. } => {
                let rises = previous < level && current >= level;
                let falls = previous > level && current <= level;
                match edge {
                    Edge::Rising => rises,
                    Edge::Falling => falls,
                    Edge::Either => rises || falls,
                }
            }
            Condition::Bit { bit, edge, .. } => {
                let (was, is) = (bit_of(previous, bit), bit_of(current, bit));
                match edge {
                    Edge::Rising => !was && is,
                    Edge::Falling => was && !is,
                    Edge::Either => was != is,
                }
            }
        }
    }

    /// The condition in words, e.g. "position rises through 1000" or "bit 10 of pdi_status
    /// rises". Channels without a name are called "channel N".
    pub fn describe(&self, channel_names: &[&str]) -> String {
        let name = |channel: usize| {
            channel_names
                .get(channel)
                .map_or_else(|| format!("channel {channel}"), |n| (*n).to_string())
        };
        match *self {
            Condition::Threshold {
                channel,
                level,
                edge,
            } => {
                let verb = match edge {
                    Edge::Rising => "rises through",
                    Edge::Falling => "falls through",
                    Edge::Either => "crosses",
                };
                format!("{} {verb} {level}", name(channel))
            }
            Condition::Bit { channel, bit, edge } => {
                let verb = match edge {
                    Edge::Rising => "rises",
                    Edge::Falling => "falls",
                    Edge::Either => "changes",
                };
                format!("bit {bit} of {} {verb}", name(channel))
            }
        }
    }
}

/// Bit `bit` of a channel value read as `u32` (saturating; bits past 31 are always 0).
fn bit_of(value: f64, bit: u8) -> bool {
    (value as u32).checked_shr(u32::from(bit)).unwrap_or(0) & 1 == 1
}

#[cfg(test)]
mod tests {
    use super::super::recording::{ChannelInfo, Metadata, Recording};
    use super::super::ring::Ring;
    use super::*;

    fn threshold(level: f64, edge: Edge) -> Trigger {
        Trigger {
            condition: crossing(1, level, edge),
            pre_s: 0.5,
            post_s: 2.0,
        }
    }

    fn crossing(channel: usize, level: f64, edge: Edge) -> Condition {
        Condition::Threshold {
            channel,
            level,
            edge,
        }
    }

    fn bit_edge(channel: usize, bit: u8, edge: Edge) -> Condition {
        Condition::Bit { channel, bit, edge }
    }

    /// A trigger on bit `bit` of channel 1, with 1 s after it.
    fn bit_trigger(bit: u8, edge: Edge) -> Trigger {
        Trigger {
            condition: bit_edge(1, bit, edge),
            pre_s: 0.0,
            post_s: 1.0,
        }
    }

    /// Arm, feed `values` of channel 1 at t = 0, 1, 2, ...; the times at which it fired.
    fn fires(trigger: Trigger, values: &[f64]) -> Vec<f64> {
        let mut capture = Capture::new(trigger);
        capture.arm();
        let mut fired = Vec::new();
        for (i, &v) in values.iter().enumerate() {
            let t = i as f64;
            if let CaptureEvent::Fired { at } = capture.feed(t, &[99.0, v]) {
                assert_eq!(at, t);
                fired.push(at);
                // Re-arm to see every crossing.
                capture.arm();
                capture.feed(t, &[99.0, v]);
            }
        }
        fired
    }

    #[test]
    fn thresholds_fire_on_the_first_sample_past_the_level() {
        let values = [0.0, 5.0, 10.0, 12.0, 10.0, 3.0, 10.0, 20.0, 9.0];
        assert_eq!(fires(threshold(10.0, Edge::Rising), &values), [2.0, 6.0]);
        // Falling: 12 -> 10 reaches the level; 10 -> 3 was not above it.
        assert_eq!(fires(threshold(10.0, Edge::Falling), &values), [4.0, 8.0]);
        assert_eq!(
            fires(threshold(10.0, Edge::Either), &values),
            [2.0, 4.0, 6.0, 8.0]
        );
        // Negative levels and fractional values.
        let values = [0.0, -0.4, -0.5, -0.6, -0.2];
        assert_eq!(fires(threshold(-0.5, Edge::Falling), &values), [2.0]);
        assert_eq!(fires(threshold(-0.5, Edge::Rising), &values), [4.0]);
    }

    #[test]
    fn bits_fire_on_the_first_sample_with_the_new_state() {
        let bit = |edge| bit_trigger(10, edge);
        let on = f64::from(1u32 << 10);
        // Other bits changing do not count.
        let values = [0.0, 1.0, on + 1.0, on, on + 7.0, 7.0, 0.0, on];
        assert_eq!(fires(bit(Edge::Rising), &values), [2.0, 7.0]);
        assert_eq!(fires(bit(Edge::Falling), &values), [5.0]);
        assert_eq!(fires(bit(Edge::Either), &values), [2.0, 5.0, 7.0]);
        // A 32-bit digital-input word, top bit.
        let top = bit_trigger(31, Edge::Rising);
        assert_eq!(fires(top, &[0.0, f64::from(u32::MAX)]), [1.0]);
        // Bits past 31 never change.
        let past = bit_trigger(40, Edge::Either);
        assert!(fires(past, &[0.0, 1e12, f64::from(u32::MAX)]).is_empty());
    }

    #[test]
    fn arming_when_already_past_the_level_does_not_fire() {
        let mut capture = Capture::new(threshold(10.0, Edge::Rising));
        assert_eq!(capture.state(), CaptureState::Idle);
        assert_eq!(capture.feed(0.0, &[0.0, 0.0]), CaptureEvent::Nothing);
        assert_eq!(capture.feed(1.0, &[0.0, 20.0]), CaptureEvent::Nothing);
        assert_eq!(capture.state(), CaptureState::Idle);
        capture.arm();
        assert_eq!(capture.state(), CaptureState::Armed);
        assert_eq!(capture.feed(2.0, &[0.0, 20.0]), CaptureEvent::Nothing);
        assert_eq!(capture.feed(3.0, &[0.0, 25.0]), CaptureEvent::Nothing);
        assert_eq!(capture.feed(4.0, &[0.0, 5.0]), CaptureEvent::Nothing);
        assert_eq!(
            capture.feed(5.0, &[0.0, 15.0]),
            CaptureEvent::Fired { at: 5.0 }
        );
        // Re-arming forgets the sample before: no fire from 5 -> 15 across the arm.
        let mut capture = Capture::new(threshold(10.0, Edge::Rising));
        capture.arm();
        capture.feed(0.0, &[0.0, 5.0]);
        capture.arm();
        assert_eq!(capture.feed(1.0, &[0.0, 15.0]), CaptureEvent::Nothing);
    }

    #[test]
    fn nan_rows_are_skipped() {
        let values = [5.0, f64::NAN, f64::NAN, 15.0];
        assert_eq!(fires(threshold(10.0, Edge::Rising), &values), [3.0]);
        // NaN does not reset the previous value either way.
        let values = [15.0, f64::NAN, 5.0];
        assert_eq!(fires(threshold(10.0, Edge::Falling), &values), [2.0]);
        // A row too short for the channel is skipped too.
        let mut capture = Capture::new(threshold(10.0, Edge::Rising));
        capture.arm();
        capture.feed(0.0, &[0.0, 5.0]);
        assert_eq!(capture.feed(1.0, &[20.0]), CaptureEvent::Nothing);
        assert_eq!(
            capture.feed(2.0, &[0.0, 20.0]),
            CaptureEvent::Fired { at: 2.0 }
        );
    }

    #[test]
    fn completes_after_the_post_trigger_time_and_stays_complete() {
        let mut capture = Capture::new(threshold(10.0, Edge::Rising));
        capture.arm();
        capture.feed(0.0, &[0.0, 0.0]);
        assert_eq!(
            capture.feed(1.0, &[0.0, 11.0]),
            CaptureEvent::Fired { at: 1.0 }
        );
        assert_eq!(capture.state(), CaptureState::Fired { at: 1.0 });
        // Rows keep coming whatever the trigger channel holds.
        assert_eq!(capture.feed(2.0, &[0.0, f64::NAN]), CaptureEvent::Nothing);
        assert_eq!(capture.feed(2.999, &[0.0, 0.0]), CaptureEvent::Nothing);
        let done = CaptureEvent::Complete {
            from: 0.5,
            at: 1.0,
            to: 3.0,
        };
        assert_eq!(capture.feed(3.0, &[0.0, 0.0]), done);
        assert_eq!(
            capture.state(),
            CaptureState::Complete {
                from: 0.5,
                at: 1.0,
                to: 3.0
            }
        );
        assert_eq!(capture.feed(4.0, &[0.0, 20.0]), CaptureEvent::Nothing);
        capture.arm();
        capture.feed(5.0, &[0.0, 0.0]);
        assert_eq!(
            capture.feed(6.0, &[0.0, 20.0]),
            CaptureEvent::Fired { at: 6.0 }
        );
        capture.disarm();
        assert_eq!(capture.state(), CaptureState::Idle);
        assert_eq!(capture.feed(9.0, &[0.0, 0.0]), CaptureEvent::Nothing);
    }

    #[test]
    fn no_post_trigger_time_completes_at_once() {
        let mut trigger = threshold(10.0, Edge::Rising);
        trigger.post_s = 0.0;
        trigger.pre_s = -1.0;
        let mut capture = Capture::new(trigger);
        capture.arm();
        capture.feed(0.0, &[0.0, 0.0]);
        assert_eq!(
            capture.feed(1.0, &[0.0, 10.0]),
            CaptureEvent::Complete {
                from: 1.0,
                at: 1.0,
                to: 1.0
            }
        );
    }

    #[test]
    fn descriptions() {
        let names = ["position", "pdi_status"];
        for (condition, described) in [
            (
                crossing(0, 1000.0, Edge::Rising),
                "position rises through 1000",
            ),
            (
                crossing(0, -2.5, Edge::Falling),
                "position falls through -2.5",
            ),
            (crossing(5, 0.0, Edge::Either), "channel 5 crosses 0"),
            (bit_edge(1, 10, Edge::Rising), "bit 10 of pdi_status rises"),
            (bit_edge(1, 3, Edge::Falling), "bit 3 of pdi_status falls"),
            (bit_edge(1, 0, Edge::Either), "bit 0 of pdi_status changes"),
        ] {
            assert_eq!(condition.describe(&names), described);
        }
    }

    #[test]
    fn triggers_round_trip_through_json() {
        for condition in [
            bit_edge(3, 10, Edge::Either),
            crossing(0, 1000.5, Edge::Falling),
        ] {
            let trigger = Trigger {
                condition,
                pre_s: 0.25,
                post_s: 1.5,
            };
            let text = serde_json::to_string(&trigger).unwrap();
            assert_eq!(serde_json::from_str::<Trigger>(&text).unwrap(), trigger);
        }
    }

    /// Feed a 1 kHz ramp into a ring and a capture side by side; cut the recording when the
    /// capture completes. Returns the recording, the capture window and the ring.
    fn capture_into_recording(pre_s: f64, capacity: usize) -> (Recording, [f64; 3], Ring) {
        let mut ring = Ring::new(capacity, 2);
        let mut capture = Capture::new(Trigger {
            condition: crossing(0, 1500.0, Edge::Rising),
            pre_s,
            post_s: 0.2,
        });
        capture.arm();
        let columns = [
            (
                0,
                ChannelInfo {
                    id: "position".into(),
                    name: "Position 6064h".into(),
                    unit: "0.1°".into(),
                },
            ),
            (
                1,
                ChannelInfo {
                    id: "status".into(),
                    name: "Status word 6041h".into(),
                    unit: String::new(),
                },
            ),
        ];
        for i in 0..10_000u32 {
            let t = f64::from(i) / 1000.0;
            let status = if i % 2 == 0 {
                f64::NAN
            } else {
                f64::from(i % 16)
            };
            let row = [f64::from(i), status];
            ring.push(t, &row).unwrap();
            if let CaptureEvent::Complete { from, at, to } = capture.feed(t, &row) {
                let recording =
                    Recording::from_ring(&ring, &columns, from, to, Metadata::default());
                return (recording, [from, at, to], ring);
            }
        }
        panic!("the capture never completed");
    }

    #[test]
    fn a_completed_capture_records_the_pre_trigger_rows() {
        // Enough history: the recording starts at at - pre_s.
        let (recording, [from, at, to], _) = capture_into_recording(0.3, 1000);
        assert_eq!(at, 1.5);
        let expected: Vec<f64> = (0..10_000)
            .map(|i| f64::from(i) / 1000.0)
            .filter(|&t| t >= from && t <= to)
            .collect();
        assert_eq!(recording.times, expected);
        assert_eq!(recording.times.first(), Some(&1.2));
        assert_eq!(recording.times.last(), Some(&1.7));
        assert_eq!(recording.columns.len(), 2);
        assert_eq!(recording.columns[0][0], 1200.0);
        assert!(recording.columns[1][0].is_nan());
        assert_eq!(recording.columns[1][1], f64::from(1201 % 16));
        // More pre-trigger time than the ring holds: it starts at the oldest row.
        let (recording, [from, _, _], ring) = capture_into_recording(5.0, 1000);
        assert!(from < ring.first_time().unwrap());
        assert_eq!(recording.times.first().copied(), ring.first_time());
        assert_eq!(recording.times.last().copied(), ring.last_time());
        assert_eq!(recording.len(), 1000);
        assert_eq!(recording.columns[0][0], 701.0);
    }
}
