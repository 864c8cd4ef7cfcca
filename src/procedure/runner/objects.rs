//! The steps that read and write objects: the identity compared, a backup applied in its
//! safe order, the settings that differ from the factory's and from the project's baseline.

use super::*;

impl DriveRun {
    pub(super) fn on_written(&mut self, result: Result<(), String>) {
        match &mut self.phase {
            Phase::BackupWrite {
                plan, at, failures, ..
            } => {
                let step = &plan[*at];
                match result {
                    Ok(()) => {
                        self.written
                            .insert(step.address, (step.dtype, step.value.clone()));
                    }
                    Err(e) => failures.push(format!("{} {}: {e}", step.address, step.name)),
                }
                *at += 1;
                self.next_backup_write();
            }
            Phase::Unforce {
                restore,
                verdict,
                sub,
            } => {
                if *sub == 4 {
                    let verdict = verdict.clone();
                    let (v, note, figures) = verdict;
                    self.end_step(v, note, figures);
                } else {
                    *sub = 4;
                    let value = restore[1];
                    self.send(write(
                        Address::new(0x3240, 4),
                        DataType::Unsigned32,
                        Value::Uint(u64::from(value)),
                    ));
                }
            }
            Phase::ForceRead { .. } | Phase::InputWait { .. } => {
                // The force's writes (rehearsal): on to waiting.
                if let Err(e) = result {
                    self.end_step(
                        Verdict::Failed,
                        format!("the rehearsal could not force the input: {e}"),
                        vec![],
                    );
                }
            }
            Phase::NanojStart => match result {
                Ok(()) => {
                    self.written.insert(
                        Address::new(0x2300, 0),
                        (DataType::Unsigned32, Value::Uint(1)),
                    );
                    let within = match self.step_kind() {
                        Some(Kind::Nanoj { within, .. }) => within.as_secs_f64(),
                        _ => 3.0,
                    };
                    self.phase = Phase::NanojWait {
                        deadline: self.now + within,
                        next_poll: self.now,
                        running: false,
                        last: None,
                    };
                }
                Err(e) => self.end_step(
                    Verdict::Failed,
                    format!("the drive refused the start (2300h): {e}"),
                    vec![],
                ),
            },
            Phase::Store => match result {
                Ok(()) => self.end_step(
                    Verdict::Passed,
                    "every value stored (\"save\" to 1010h:01)".into(),
                    vec![],
                ),
                Err(e) => self.end_step(
                    Verdict::Failed,
                    format!("the drive refused to store: {e}"),
                    vec![],
                ),
            },
            _ => {}
        }
    }

    /// A request refused before it reached the drive.
    pub(super) fn refused(&mut self, why: String) {
        match &self.phase {
            Phase::Done | Phase::Ready => {}
            Phase::Final { .. } => self.finish(),
            _ => self.end_step(Verdict::Failed, why, vec![]),
        }
    }

    pub(super) fn identity_read(&mut self, reads: &BTreeMap<Address, Result<Value, String>>) {
        let now = DeviceIdentity::from_reads(reads);
        self.identity = Some(now.clone());
        if self.setup.rehearsal {
            return self.end_step(
                Verdict::Skipped,
                format!(
                    "rehearsal: a simulated drive stands in for {} ({})",
                    self.setup.name,
                    now.summary()
                ),
                vec![],
            );
        }
        let Some(expected) = self.setup.expected.clone() else {
            return self.end_step(
                Verdict::Skipped,
                format!(
                    "no identity in a project to compare with; it reports {}",
                    now.summary()
                ),
                vec![],
            );
        };
        let drive = crate::project::Drive {
            identity: Some(expected),
            ..crate::project::Drive::new(self.setup.name.clone(), crate::link::LinkSpec::Sim)
        };
        let check = crate::project::check::check(&drive, Ok(&now));
        if check.is_same() {
            self.end_step(
                Verdict::Passed,
                format!("the device the project saw: {}", now.summary()),
                vec![],
            );
        } else {
            self.end_step(
                Verdict::Failed,
                format!("not the device the project saw: {check}"),
                vec![],
            );
        }
    }

    pub(super) fn backup_read(&mut self, reads: &BTreeMap<Address, Result<Value, String>>) {
        let Some(backup) = self.setup.backups.get(&self.at) else {
            return;
        };
        let plan = backup::restore_plan(backup, builtin(), reads);
        let (plan, left_out): (Vec<backup::Step>, Vec<backup::Step>) =
            plan.into_iter().partition(|s| s.warning.is_none());
        let left_out = left_out
            .iter()
            .map(|s| {
                format!(
                    "{} {} (it changes how the drive is reached)",
                    s.address, s.name
                )
            })
            .collect();
        self.phase = Phase::BackupWrite {
            plan,
            at: 0,
            failures: vec![],
            left_out,
        };
        self.next_backup_write();
    }

    pub(super) fn next_backup_write(&mut self) {
        let Phase::BackupWrite {
            plan,
            at,
            failures,
            left_out,
        } = &self.phase
        else {
            return;
        };
        if let Some(step) = plan.get(*at) {
            let request = write(step.address, step.dtype, step.value.clone());
            return self.send(request);
        }
        let written = plan.len() - failures.len();
        let mut note = format!("{written} setting(s) written to match the backup");
        if plan.is_empty() {
            note = "the drive already matches the backup".into();
        }
        if !left_out.is_empty() {
            note.push_str(&format!("; left out: {}", left_out.join(", ")));
        }
        let figures = vec![Figure {
            name: "settings refused".into(),
            value: Some(failures.len() as f64),
            unit: String::new(),
            limit: Some("= 0".into()),
            passed: Some(failures.is_empty()),
        }];
        if failures.is_empty() {
            self.end_step(Verdict::Passed, note, figures);
        } else {
            let refused = failures.join("; ");
            self.end_step(
                Verdict::Failed,
                format!("{note}; refused: {refused}"),
                figures,
            );
        }
    }
}

pub(super) fn identity_rows(identity: &DeviceIdentity) -> Vec<(String, String)> {
    let hex = |v: Option<u32>| v.map_or("?".to_owned(), |v| format!("{v:08X}h"));
    let text = |v: &Option<String>| v.clone().unwrap_or_else(|| "?".into());
    vec![
        ("device name (1008h)".into(), text(&identity.name)),
        ("vendor (1018h:01)".into(), hex(identity.vendor)),
        ("product (1018h:02)".into(), hex(identity.product)),
        ("revision (1018h:03)".into(), hex(identity.revision)),
        ("serial (1018h:04)".into(), hex(identity.serial)),
        ("hardware (1009h)".into(), text(&identity.hardware)),
        ("software (100Ah)".into(), text(&identity.software)),
    ]
}

/// The settings read that differ from the catalog's factory value.
pub(super) fn differs_from_factory(
    reads: &BTreeMap<Address, Result<Value, String>>,
) -> Vec<Difference> {
    reads
        .iter()
        .filter_map(|(address, read)| {
            let entry = builtin().get(*address)?;
            let factory = entry.default.as_ref()?;
            let value = read.as_ref().ok()?;
            let same = match (value.as_i128(), factory.as_i128()) {
                (Some(a), Some(b)) => a == b,
                _ => value == factory,
            };
            (!same).then(|| Difference {
                object: address.to_string(),
                name: entry.full_name(),
                value: backup::shown(value, entry),
                reference: backup::shown(factory, entry),
            })
        })
        .collect()
}

/// The settings read that differ from the project's backup of the drive.
pub(super) fn differs_from_baseline(
    baseline: &Backup,
    reads: &BTreeMap<Address, Result<Value, String>>,
) -> Vec<Difference> {
    backup::compare(baseline, builtin(), reads)
        .into_iter()
        .filter_map(|d| match d.device {
            backup::Comparison::Differs(now) => Some(Difference {
                object: d.address.to_string(),
                name: d.name,
                value: now.to_string(),
                reference: d.file.to_string(),
            }),
            _ => None,
        })
        .collect()
}
