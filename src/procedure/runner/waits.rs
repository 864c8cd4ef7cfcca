//! The steps that wait on the machine: an input (forced through 3240h in a rehearsal) and
//! the NanoJ program's object.

use super::*;

impl DriveRun {
    pub(super) fn input_within(&self) -> f64 {
        match self.step_kind() {
            Some(Kind::Input { within, .. }) => within.as_secs_f64(),
            _ => 10.0,
        }
    }

    /// Rehearsal: force the input the step waits for to the expected level (3240h:03/:04
    /// on the input serving that 60FDh bit), in place of the operator's hand.
    pub(super) fn force_input(&mut self, words: [Option<u32>; 2]) {
        let Some(Kind::Input { bit, expect, .. }) = self.step_kind() else {
            return;
        };
        let input = if bit < 4 {
            bit + 1
        } else {
            bit.saturating_sub(15)
        };
        let mask = 1u32 << (input - 1);
        let (Some(enable), Some(value)) = (words[0], words[1]) else {
            return self.end_step(
                Verdict::Failed,
                "rehearsal: 3240h:03/:04 could not be read to force the input".into(),
                vec![],
            );
        };
        let forced_value = if expect { value | mask } else { value & !mask };
        self.phase = Phase::InputWait {
            deadline: self.now + self.input_within(),
            next_poll: self.now,
            restore: Some([enable, value]),
            seen: None,
        };
        self.prompt = Some(Prompt::Action(format!(
            "rehearsal: input {input} is forced by 3240h in place of the operator"
        )));
        // Value first, then the enable; both answered before the first poll.
        self.requests.push((
            0,
            write(
                Address::new(0x3240, 4),
                DataType::Unsigned32,
                Value::Uint(u64::from(forced_value)),
            ),
        ));
        self.send(write(
            Address::new(0x3240, 3),
            DataType::Unsigned32,
            Value::Uint(u64::from(enable | mask)),
        ));
    }

    /// The input's wait is over: put 3240h back (rehearsal), then the verdict.
    pub(super) fn after_input(
        &mut self,
        restore: Option<[u32; 2]>,
        verdict: (Verdict, String, Vec<Figure>),
    ) {
        self.prompt = None;
        match restore {
            Some(restore) => {
                self.phase = Phase::Unforce {
                    restore,
                    verdict,
                    sub: 3,
                };
                self.send(write(
                    Address::new(0x3240, 3),
                    DataType::Unsigned32,
                    Value::Uint(u64::from(restore[0])),
                ));
            }
            None => {
                let (v, note, figures) = verdict;
                self.end_step(v, note, figures);
            }
        }
    }

    pub(super) fn nanoj_object(&self) -> Address {
        match self.procedure.steps.get(self.at).map(|s| &s.kind) {
            Some(Kind::Nanoj { object, .. }) => *object,
            _ => Address::new(0x2500, 1),
        }
    }

    pub(super) fn nanoj_expectation(&self) -> (Address, Condition) {
        match self.step_kind() {
            Some(Kind::Nanoj {
                object, condition, ..
            }) => (object, condition),
            _ => (Address::new(0x2500, 1), Condition::Above(0)),
        }
    }
}
