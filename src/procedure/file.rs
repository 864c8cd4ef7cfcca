//! The procedure file: TOML, a `[procedure]` table and an ordered `[[step]]` array, each
//! step a `kind` with its parameters and acceptance limits (the user guide's
//! `docs/guide/09-procedures-and-records.md`, the commented example in `assets/procedures/`). Read whole and checked before anything
//! moves: a bad file is refused with the line of the step and what is wrong with it.

use std::path::{Path, PathBuf};
use std::time::Duration;

use serde::Deserialize;
use thiserror::Error;

use crate::od::io::{PHYSICAL, SPECIAL};
use crate::od::{Address, builtin};
use crate::telemetry::test_run::{MoveTest, Plan, VelocityTest, move_plan, velocity_plan};

#[derive(Debug, Error)]
pub enum ProcedureError {
    #[error("cannot read {path}: {source}")]
    Read {
        path: String,
        source: std::io::Error,
    },
    /// The TOML itself, or a field of the wrong type or name (the toml crate's message
    /// names the line and shows it).
    #[error("{path}: {message}")]
    Syntax { path: String, message: String },
    /// A step that reads but cannot run.
    #[error("{path}, line {line} (step {number}, {kind}): {message}")]
    Step {
        path: String,
        line: usize,
        number: usize,
        kind: String,
        message: String,
    },
    #[error("{path}: {message}")]
    Whole { path: String, message: String },
}

/// What a failed step means for the steps after it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum OnFailure {
    /// The drive's run ends there; the steps after are skipped.
    Stop,
    /// The next step runs all the same.
    #[default]
    Continue,
}

/// Acceptance limits on a test's figures, each the worst step's against its limit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Limits {
    /// Overshoot in % of the step, at most.
    pub overshoot_percent: Option<f64>,
    /// Settling time into the band, seconds, at most.
    pub settling_s: Option<f64>,
    /// Rise time 10–90 %, seconds, at most.
    pub rise_s: Option<f64>,
    /// Peak following error (position units), at most.
    pub peak_following_error: Option<f64>,
    /// Steady-state error (the signal's units), at most.
    pub steady_state_error: Option<f64>,
}

impl Limits {
    /// Every limit given: (figure's name, limit).
    pub fn given(&self) -> Vec<(&'static str, f64)> {
        [
            ("overshoot_percent", self.overshoot_percent),
            ("settling_s", self.settling_s),
            ("rise_s", self.rise_s),
            ("peak_following_error", self.peak_following_error),
            ("steady_state_error", self.steady_state_error),
        ]
        .into_iter()
        .filter_map(|(name, limit)| limit.map(|l| (name, l)))
        .collect()
    }
}

/// What a NanoJ step expects of an object once the program runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Condition {
    Equals(i64),
    Above(i64),
    Below(i64),
}

impl Condition {
    pub fn holds(self, value: i64) -> bool {
        match self {
            Condition::Equals(v) => value == v,
            Condition::Above(v) => value > v,
            Condition::Below(v) => value < v,
        }
    }

    /// "> 0", "= 5".
    pub fn text(self) -> String {
        match self {
            Condition::Equals(v) => format!("= {v}"),
            Condition::Above(v) => format!("> {v}"),
            Condition::Below(v) => format!("< {v}"),
        }
    }
}

/// One step, checked.
#[derive(Clone, Debug, PartialEq)]
pub enum Kind {
    /// The drive is the device the project saw (1018h, 1008h…).
    Identity,
    /// The configuration of a backup written (the restore rules: settings only); `None`:
    /// the project's own backup of the drive.
    ApplyBackup {
        file: Option<PathBuf>,
    },
    AutoSetup {
        timeout: Duration,
    },
    /// A question to the operator, with the answer that passes.
    Question {
        text: String,
        expect: bool,
    },
    /// A test move or velocity steps with limits on their figures.
    Test {
        plan: Plan,
        limits: Limits,
    },
    /// A 60FDh bit expected to reach `expect` within `within`, the operator asked to make
    /// it so.
    Input {
        bit: u8,
        name: String,
        expect: bool,
        within: Duration,
        prompt: String,
    },
    /// The NanoJ program started, and an object it writes expected to meet `condition`.
    Nanoj {
        object: Address,
        condition: Condition,
        within: Duration,
    },
    /// Every value stored for the next power-on.
    Store,
    /// A restart; the objects in `verify` (none given: those this run wrote) must come
    /// back as they were.
    Reboot {
        verify: Vec<Address>,
        timeout: Duration,
    },
}

impl Kind {
    /// The kind's name as the file gives it.
    pub fn name(&self) -> &'static str {
        match self {
            Kind::Identity => "identity",
            Kind::ApplyBackup { .. } => "apply-backup",
            Kind::AutoSetup { .. } => "auto-setup",
            Kind::Question { .. } => "question",
            Kind::Test { plan, .. } if plan.signal == crate::signal::Signal::Velocity => {
                "velocity-step"
            }
            Kind::Test { .. } => "test-move",
            Kind::Input { .. } => "input",
            Kind::Nanoj { .. } => "nanoj",
            Kind::Store => "store",
            Kind::Reboot { .. } => "reboot",
        }
    }
}

/// One step of the procedure.
#[derive(Clone, Debug, PartialEq)]
pub struct Step {
    /// Its line in the file.
    pub line: usize,
    /// The title shown and recorded.
    pub title: String,
    pub kind: Kind,
    pub on_failure: OnFailure,
}

/// A procedure, read and checked.
#[derive(Clone, Debug, PartialEq)]
pub struct Procedure {
    pub name: String,
    pub description: String,
    pub steps: Vec<Step>,
    /// Where the file is (backups named in it are relative to it).
    pub path: PathBuf,
    /// The file's bytes, for the record's fingerprint.
    pub text: String,
}

// ---------------------------------------------------------------------------------------
// The file as written.

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFile {
    procedure: RawHead,
    #[serde(default)]
    step: Vec<toml::Spanned<RawStep>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawHead {
    name: String,
    #[serde(default)]
    description: String,
}

#[derive(Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
enum RawStep {
    Identity {
        title: Option<String>,
        on_failure: Option<OnFailure>,
    },
    ApplyBackup {
        title: Option<String>,
        on_failure: Option<OnFailure>,
        file: Option<String>,
    },
    AutoSetup {
        title: Option<String>,
        on_failure: Option<OnFailure>,
        timeout_s: Option<f64>,
    },
    Question {
        title: Option<String>,
        on_failure: Option<OnFailure>,
        text: String,
        expect: String,
    },
    TestMove {
        title: Option<String>,
        on_failure: Option<OnFailure>,
        from: i64,
        to: i64,
        speed: i64,
        dwell_s: Option<f64>,
        cycles: Option<u32>,
        band: Option<f64>,
        #[serde(default)]
        limits: Limits,
    },
    VelocityStep {
        title: Option<String>,
        on_failure: Option<OnFailure>,
        speed: i64,
        hold_s: Option<f64>,
        cycles: Option<u32>,
        band: Option<f64>,
        #[serde(default)]
        limits: Limits,
    },
    Input {
        title: Option<String>,
        on_failure: Option<OnFailure>,
        input: String,
        expect: Option<bool>,
        within_s: Option<f64>,
        prompt: Option<String>,
    },
    Nanoj {
        title: Option<String>,
        on_failure: Option<OnFailure>,
        object: String,
        equals: Option<i64>,
        above: Option<i64>,
        below: Option<i64>,
        within_s: Option<f64>,
    },
    Store {
        title: Option<String>,
        on_failure: Option<OnFailure>,
    },
    Reboot {
        title: Option<String>,
        on_failure: Option<OnFailure>,
        #[serde(default)]
        verify: Vec<String>,
        timeout_s: Option<f64>,
    },
}

/// A duration in seconds from the file: given (checked) or the default.
fn seconds(given: Option<f64>, default: f64, name: &str) -> Result<Duration, String> {
    let s = given.unwrap_or(default);
    if !(0.0..=3600.0).contains(&s) || !s.is_finite() {
        return Err(format!(
            "{name} = {s} is out of range: give 0 to 3600 seconds"
        ));
    }
    Ok(Duration::from_secs_f64(s))
}

/// An object address as written: "2500:02", "2500h:02h", "0x2500:2".
pub fn parse_address(text: &str) -> Result<Address, String> {
    let (index, sub) = text
        .split_once(':')
        .ok_or_else(|| format!("{text:?} is not an object address like \"2500:02\""))?;
    let hex = |t: &str| {
        let t = t.trim().trim_end_matches(['h', 'H']);
        let t = t.trim_start_matches("0x").trim_start_matches("0X");
        u32::from_str_radix(t, 16).ok()
    };
    let index = hex(index)
        .and_then(|i| u16::try_from(i).ok())
        .ok_or_else(|| format!("{text:?}: the index is not a hexadecimal number up to FFFF"))?;
    let sub = hex(sub)
        .and_then(|s| u8::try_from(s).ok())
        .ok_or_else(|| format!("{text:?}: the subindex is not a hexadecimal number up to FF"))?;
    Ok(Address::new(index, sub))
}

/// An input by its name ("positive limit switch", "input 3"): its 60FDh bit.
pub fn input_bit(name: &str) -> Result<u8, String> {
    let wanted = name.trim().to_lowercase();
    if let Some(bit) = SPECIAL.iter().position(|s| *s == wanted) {
        return Ok(bit as u8);
    }
    if let Some(n) = wanted
        .strip_prefix("input ")
        .and_then(|n| n.trim().parse::<u8>().ok())
        .filter(|n| (1..=PHYSICAL).contains(n))
    {
        return Ok(15 + n);
    }
    Err(format!(
        "unknown input {name:?}: give one of {}, or \"input 1\" to \"input {PHYSICAL}\"",
        SPECIAL
            .iter()
            .map(|s| format!("{s:?}"))
            .collect::<Vec<_>>()
            .join(", ")
    ))
}

fn yes_no(text: &str) -> Result<bool, String> {
    match text.trim().to_lowercase().as_str() {
        "yes" => Ok(true),
        "no" => Ok(false),
        other => Err(format!("expect = {other:?}: give \"yes\" or \"no\"")),
    }
}

fn check_limits(limits: &Limits) -> Result<(), String> {
    for (name, value) in limits.given() {
        if !value.is_finite() || value < 0.0 {
            return Err(format!(
                "limits.{name} = {value}: a limit is a number of 0 or more"
            ));
        }
    }
    Ok(())
}

/// The checked step of a raw one: its kind, title and failure rule, or what is wrong.
fn check_step(raw: RawStep) -> Result<(Kind, Option<String>, Option<OnFailure>), String> {
    Ok(match raw {
        RawStep::Identity { title, on_failure } => (Kind::Identity, title, on_failure),
        RawStep::ApplyBackup {
            title,
            on_failure,
            file,
        } => (
            Kind::ApplyBackup {
                file: file.map(PathBuf::from),
            },
            title,
            on_failure,
        ),
        RawStep::AutoSetup {
            title,
            on_failure,
            timeout_s,
        } => (
            Kind::AutoSetup {
                timeout: seconds(timeout_s, 30.0, "timeout_s")?,
            },
            title,
            on_failure,
        ),
        RawStep::Question {
            title,
            on_failure,
            text,
            expect,
        } => {
            if text.trim().is_empty() {
                return Err("text is empty: write the question the operator answers".into());
            }
            (
                Kind::Question {
                    text,
                    expect: yes_no(&expect)?,
                },
                title,
                on_failure,
            )
        }
        RawStep::TestMove {
            title,
            on_failure,
            from,
            to,
            speed,
            dwell_s,
            cycles,
            band,
            limits,
        } => {
            check_limits(&limits)?;
            let plan = move_plan(&MoveTest {
                from,
                to,
                speed,
                dwell: dwell_s.unwrap_or(0.5),
                cycles: cycles.unwrap_or(1),
                band,
            })?;
            (Kind::Test { plan, limits }, title, on_failure)
        }
        RawStep::VelocityStep {
            title,
            on_failure,
            speed,
            hold_s,
            cycles,
            band,
            limits,
        } => {
            check_limits(&limits)?;
            if limits.peak_following_error.is_some() {
                return Err(
                    "limits.peak_following_error: velocity steps have no following error; \
                     limit their overshoot, settling or rise time"
                        .into(),
                );
            }
            let plan = velocity_plan(&VelocityTest {
                speed,
                hold: hold_s.unwrap_or(0.5),
                cycles: cycles.unwrap_or(1),
                band,
            })?;
            (Kind::Test { plan, limits }, title, on_failure)
        }
        RawStep::Input {
            title,
            on_failure,
            input,
            expect,
            within_s,
            prompt,
        } => {
            let bit = input_bit(&input)?;
            let expect = expect.unwrap_or(true);
            let prompt = prompt.unwrap_or_else(|| {
                format!(
                    "Make the {} {}",
                    input.trim(),
                    if expect { "active" } else { "inactive" }
                )
            });
            (
                Kind::Input {
                    bit,
                    name: input.trim().to_owned(),
                    expect,
                    within: seconds(within_s, 10.0, "within_s")?,
                    prompt,
                },
                title,
                on_failure,
            )
        }
        RawStep::Nanoj {
            title,
            on_failure,
            object,
            equals,
            above,
            below,
            within_s,
        } => {
            let object = parse_address(&object)?;
            let condition = match (equals, above, below) {
                (Some(v), None, None) => Condition::Equals(v),
                (None, Some(v), None) => Condition::Above(v),
                (None, None, Some(v)) => Condition::Below(v),
                _ => {
                    return Err(
                        "give one of equals, above or below: what the object must show once the program runs"
                            .into(),
                    );
                }
            };
            (
                Kind::Nanoj {
                    object,
                    condition,
                    within: seconds(within_s, 3.0, "within_s")?,
                },
                title,
                on_failure,
            )
        }
        RawStep::Store { title, on_failure } => (Kind::Store, title, on_failure),
        RawStep::Reboot {
            title,
            on_failure,
            verify,
            timeout_s,
        } => {
            let verify = verify
                .iter()
                .map(|a| parse_address(a))
                .collect::<Result<Vec<_>, _>>()?;
            for address in &verify {
                if builtin().get(*address).is_none() {
                    return Err(format!(
                        "verify: {address} is not in the catalog, so its type is unknown"
                    ));
                }
            }
            (
                Kind::Reboot {
                    verify,
                    timeout: seconds(timeout_s, 20.0, "timeout_s")?,
                },
                title,
                on_failure,
            )
        }
    })
}

/// A step's title where the file gives none.
fn default_title(kind: &Kind) -> String {
    match kind {
        Kind::Identity => "Check the drive's identity".into(),
        Kind::ApplyBackup { file: None } => "Apply the project's backup".into(),
        Kind::ApplyBackup { file: Some(f) } => format!("Apply the backup {}", f.display()),
        Kind::AutoSetup { .. } => "Auto setup".into(),
        Kind::Question { text, .. } => text.clone(),
        Kind::Test { plan, .. } if plan.signal == crate::signal::Signal::Velocity => format!(
            "Velocity steps 0 → {v} → −{v} → 0 rpm ({} cycle(s))",
            plan.cycles,
            v = plan.speed
        ),
        Kind::Test { plan, .. } => match plan.steps.first() {
            Some((from, to, _)) => format!(
                "Test move {from} ↔ {to} at {} rpm ({} cycle(s))",
                plan.speed, plan.cycles
            ),
            None => "Test move".into(),
        },
        Kind::Input { prompt, .. } => prompt.clone(),
        Kind::Nanoj {
            object, condition, ..
        } => format!(
            "Start the NanoJ program and see {object} {}",
            condition.text()
        ),
        Kind::Store => "Store the values for the next power-on".into(),
        Kind::Reboot { .. } => "Restart and check the stored values came back".into(),
    }
}

/// The failure rule where the file gives none: a wrong drive, a backup that did not go
/// in or a motor not measured stop the drive's run; the rest go on.
fn default_on_failure(kind: &Kind) -> OnFailure {
    match kind {
        Kind::Identity | Kind::ApplyBackup { .. } | Kind::AutoSetup { .. } => OnFailure::Stop,
        _ => OnFailure::Continue,
    }
}

/// The line (from 1) of byte `at` in `text`.
fn line_of(text: &str, at: usize) -> usize {
    text.as_bytes()[..at.min(text.len())]
        .iter()
        .filter(|b| **b == b'\n')
        .count()
        + 1
}

impl Procedure {
    /// Read and check the file at `path`.
    pub fn load(path: &Path) -> Result<Procedure, ProcedureError> {
        let text = std::fs::read_to_string(path).map_err(|source| ProcedureError::Read {
            path: path.display().to_string(),
            source,
        })?;
        Procedure::parse(&text, path)
    }

    /// Check `text` (the file at `path`).
    pub fn parse(text: &str, path: &Path) -> Result<Procedure, ProcedureError> {
        let shown = path.display().to_string();
        let raw: RawFile = toml::from_str(text).map_err(|e| ProcedureError::Syntax {
            path: shown.clone(),
            message: e.to_string().trim_end().to_owned(),
        })?;
        if raw.procedure.name.trim().is_empty() {
            return Err(ProcedureError::Whole {
                path: shown,
                message: "[procedure] name is empty".into(),
            });
        }
        if raw.step.is_empty() {
            return Err(ProcedureError::Whole {
                path: shown,
                message: "no [[step]]: a procedure needs at least one step".into(),
            });
        }
        let mut steps = Vec::with_capacity(raw.step.len());
        for (i, spanned) in raw.step.into_iter().enumerate() {
            let line = line_of(text, spanned.span().start);
            let raw = spanned.into_inner();
            let kind_name = raw_kind_name(&raw);
            let (kind, title, on_failure) =
                check_step(raw).map_err(|message| ProcedureError::Step {
                    path: shown.clone(),
                    line,
                    number: i + 1,
                    kind: kind_name.into(),
                    message,
                })?;
            steps.push(Step {
                line,
                title: title
                    .filter(|t| !t.trim().is_empty())
                    .unwrap_or_else(|| default_title(&kind)),
                on_failure: on_failure.unwrap_or_else(|| default_on_failure(&kind)),
                kind,
            });
        }
        Ok(Procedure {
            name: raw.procedure.name,
            description: raw.procedure.description,
            steps,
            path: path.to_path_buf(),
            text: text.to_owned(),
        })
    }

    /// A backup file named by a step, for drive `drive`: `{drive}` replaced by its file
    /// stem, relative to the procedure's folder.
    pub fn backup_path(&self, file: &Path, drive_stem: &str) -> PathBuf {
        let named = PathBuf::from(file.to_string_lossy().replace("{drive}", drive_stem));
        if named.is_absolute() {
            named
        } else {
            self.path
                .parent()
                .map_or_else(|| named.clone(), |dir| dir.join(&named))
        }
    }
}

fn raw_kind_name(raw: &RawStep) -> &'static str {
    match raw {
        RawStep::Identity { .. } => "identity",
        RawStep::ApplyBackup { .. } => "apply-backup",
        RawStep::AutoSetup { .. } => "auto-setup",
        RawStep::Question { .. } => "question",
        RawStep::TestMove { .. } => "test-move",
        RawStep::VelocityStep { .. } => "velocity-step",
        RawStep::Input { .. } => "input",
        RawStep::Nanoj { .. } => "nanoj",
        RawStep::Store { .. } => "store",
        RawStep::Reboot { .. } => "reboot",
    }
}
