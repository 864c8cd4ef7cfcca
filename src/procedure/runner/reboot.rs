//! The reboot step: "boot" to 2800h:01, the link gone and back, the stored values read
//! again and compared.

use super::*;

impl DriveRun {
    pub(super) fn send_boot(
        &mut self,
        expected: BTreeMap<Address, Value>,
        verify: Vec<(Address, DataType)>,
    ) {
        let timeout = match self.step_kind() {
            Some(Kind::Reboot { timeout, .. }) => timeout.as_secs_f64(),
            _ => 20.0,
        };
        self.phase = Phase::RebootSent {
            expected,
            verify,
            sent_at: self.now,
            deadline: self.now + timeout,
            lost: false,
            back: false,
        };
        // The drive may restart before it answers: the reply is not waited for.
        let tag = self.next_tag;
        self.next_tag += 1;
        self.requests.push((
            tag,
            write(
                Address::new(0x2800, 1),
                DataType::Unsigned32,
                Value::Uint(BOOT),
            ),
        ));
    }

    pub(super) fn reboot_verified(&mut self) {
        let Phase::RebootVerify {
            expected,
            reads,
            back_after,
            ..
        } = std::mem::replace(&mut self.phase, Phase::Ready)
        else {
            return;
        };
        let mut lost = vec![];
        let mut figures = vec![Figure {
            name: "back after".into(),
            value: Some((back_after * 10.0).round() / 10.0),
            unit: "s".into(),
            limit: None,
            passed: None,
        }];
        for (address, want) in &expected {
            let now = reads.get(address).cloned();
            let same = match &now {
                Some(Ok(v)) => match (v.as_i128(), want.as_i128()) {
                    (Some(a), Some(b)) => a == b,
                    _ => v == want,
                },
                _ => false,
            };
            if !same {
                let shown = match now {
                    Some(Ok(v)) => v.to_string(),
                    Some(Err(e)) => format!("unreadable ({e})"),
                    None => "not read".into(),
                };
                lost.push(format!("{address} is {shown} (was {want})"));
            }
        }
        figures.push(Figure {
            name: "values not back".into(),
            value: Some(lost.len() as f64),
            unit: format!("of {}", expected.len()),
            limit: Some("= 0".into()),
            passed: Some(lost.is_empty()),
        });
        if lost.is_empty() {
            self.end_step(
                Verdict::Passed,
                format!(
                    "the drive is back after {back_after:.1} s with all {} value(s) as stored",
                    expected.len()
                ),
                figures,
            );
        } else {
            self.end_step(
                Verdict::Failed,
                format!(
                    "the drive is back after {back_after:.1} s, but {} value(s) did not come back: {}",
                    lost.len(),
                    lost.join("; ")
                ),
                figures,
            );
        }
    }
}
