//! The commissioning record as data: the machine and each drive's identity, who ran what
//! procedure when with which tool, every step's verdict with its measured values against
//! their limits and its plot, the settings that differ from the factory's and from the
//! project's baseline, the fault timeline, and a SHA-256 over all of it. Written as JSON
//! beside the HTML page (`html`) that shows the same data.

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

/// How a step ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Verdict {
    Passed,
    Failed,
    Skipped,
    Aborted,
}

impl Verdict {
    pub fn word(self) -> &'static str {
        match self {
            Verdict::Passed => "passed",
            Verdict::Failed => "failed",
            Verdict::Skipped => "skipped",
            Verdict::Aborted => "aborted",
        }
    }
}

/// One measured value against its limit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Figure {
    /// What it is ("overshoot", "settling time").
    pub name: String,
    /// As measured (the worst step's); `None` when it could not be measured.
    pub value: Option<f64>,
    pub unit: String,
    /// "≤ 5" where a limit applies.
    pub limit: Option<String>,
    /// Whether it kept its limit (None: no limit).
    pub passed: Option<bool>,
}

impl Figure {
    /// The value in words: "0.449 s", "yes", "active", "not measured".
    pub fn shown(&self) -> String {
        match self.value {
            Some(_)
                if self.name == "answer" || self.unit == "active" || self.unit == "inactive" =>
            {
                self.unit.clone()
            }
            Some(v) => {
                let number = if v.fract() == 0.0 && v.abs() < 1e12 {
                    format!("{v:.0}")
                } else if v.abs() >= 100.0 {
                    format!("{v:.1}")
                } else {
                    format!("{v:.3}")
                };
                if self.unit.is_empty() {
                    number
                } else {
                    format!("{number} {}", self.unit)
                }
            }
            None => "not measured".into(),
        }
    }
}

/// A step's plot: the measured signal over time and where each of its steps began.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Plot {
    pub signal: String,
    pub unit: String,
    /// (t in s, value).
    pub points: Vec<[f64; 2]>,
    pub step_starts: Vec<f64>,
}

/// One step as it ran.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StepRecord {
    pub number: usize,
    pub kind: String,
    pub title: String,
    pub verdict: Verdict,
    /// What happened, in a sentence (why it failed, was skipped or aborted).
    pub note: String,
    pub figures: Vec<Figure>,
    /// Seconds from the drive's run start.
    pub started_s: f64,
    pub duration_s: f64,
    pub plot: Option<Plot>,
}

/// A setting that differs from a reference (the factory's, the project's baseline).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Difference {
    pub object: String,
    pub name: String,
    pub value: String,
    pub reference: String,
}

/// One entry of the fault timeline.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Event {
    pub wall: String,
    pub severity: String,
    pub text: String,
}

/// One drive's run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DriveRecord {
    pub name: String,
    pub link: String,
    /// The identity read, in words (vendor, product, revision, serial, name, software).
    pub identity: Vec<(String, String)>,
    pub steps: Vec<StepRecord>,
    pub differs_from_factory: Vec<Difference>,
    /// `None` where the project holds no baseline for the drive.
    pub differs_from_baseline: Option<Vec<Difference>>,
    pub timeline: Vec<Event>,
    pub verdict: Verdict,
}

/// The whole record.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Record {
    pub procedure: String,
    pub procedure_file: String,
    /// SHA-256 of the procedure file as run.
    pub procedure_sha256: String,
    pub description: String,
    /// The project file, or the link, that was commissioned.
    pub machine: String,
    pub tool: String,
    pub operator: String,
    pub started: String,
    pub finished: String,
    /// Run against simulated drives standing in for the project's.
    pub rehearsal: bool,
    pub drives: Vec<DriveRecord>,
    pub verdict: Verdict,
    /// SHA-256 of this record's JSON with this field empty.
    pub sha256: String,
}

/// The user logged in, for the record: $USER (or $USERNAME, $LOGNAME), else the name
/// /etc/passwd gives this process's user id.
pub fn os_user() -> String {
    if let Some(name) = ["USER", "USERNAME", "LOGNAME"]
        .iter()
        .find_map(|v| std::env::var(v).ok().filter(|s| !s.trim().is_empty()))
    {
        return name;
    }
    let uid = std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("Uid:"))
                .and_then(|l| l.split_whitespace().nth(1).map(str::to_owned))
        });
    let passwd = std::fs::read_to_string("/etc/passwd").unwrap_or_default();
    uid.and_then(|uid| {
        passwd.lines().find_map(|line| {
            let fields: Vec<&str> = line.split(':').collect();
            (fields.get(2) == Some(&uid.as_str())).then(|| fields[0].to_owned())
        })
    })
    .unwrap_or_else(|| "unknown".into())
}

/// The SHA-256 of `bytes`, in lowercase hex.
pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// A whole run's verdict from its steps: aborted if any step was, failed if any failed,
/// else passed (skipped steps alone do not fail a run).
pub fn overall<'a>(verdicts: impl Iterator<Item = &'a Verdict>) -> Verdict {
    let mut result = Verdict::Passed;
    for v in verdicts {
        match v {
            Verdict::Aborted => return Verdict::Aborted,
            Verdict::Failed => result = Verdict::Failed,
            _ => {}
        }
    }
    result
}

/// Who ran a procedure and on what, for [`Record::new`].
#[derive(Clone, Debug, Default)]
pub struct RunInfo {
    /// "project machine.json", "link modbus-tcp://…".
    pub machine: String,
    pub operator: String,
    pub started: String,
    pub finished: String,
    pub rehearsal: bool,
}

impl Record {
    /// The record of `procedure` run on `drives`, sealed.
    pub fn new(procedure: &super::Procedure, info: RunInfo, drives: Vec<DriveRecord>) -> Record {
        let verdict = overall(drives.iter().map(|d| &d.verdict));
        let mut record = Record {
            procedure: procedure.name.clone(),
            procedure_file: procedure.path.display().to_string(),
            procedure_sha256: sha256_hex(procedure.text.as_bytes()),
            description: procedure.description.clone(),
            machine: info.machine,
            tool: format!("drivedeck {}", env!("CARGO_PKG_VERSION")),
            operator: info.operator,
            started: info.started,
            finished: info.finished,
            rehearsal: info.rehearsal,
            drives,
            verdict,
            sha256: String::new(),
        };
        record.seal();
        record
    }

    /// Write the HTML page at `html_path` and the JSON beside it (`.json`), each whole:
    /// the JSON's path, or why it could not be written.
    pub fn write(&self, html_path: &std::path::Path) -> Result<std::path::PathBuf, String> {
        let json_path = html_path.with_extension("json");
        crate::file::write_whole(html_path, super::html::render(self).as_bytes())
            .map_err(|e| format!("cannot write {}: {e}", html_path.display()))?;
        crate::file::write_whole(&json_path, self.to_json().as_bytes())
            .map_err(|e| format!("cannot write {}: {e}", json_path.display()))?;
        Ok(json_path)
    }

    /// The JSON the fingerprint is taken over: the record with `sha256` empty.
    fn fingerprinted(&self) -> String {
        let mut copy = self.clone();
        copy.sha256.clear();
        serde_json::to_string(&copy).unwrap_or_default()
    }

    /// Set `sha256` over the record's data.
    pub fn seal(&mut self) {
        self.sha256 = sha256_hex(self.fingerprinted().as_bytes());
    }

    /// Whether `sha256` matches the data (a record edited after the run does not).
    pub fn verify(&self) -> bool {
        self.sha256 == sha256_hex(self.fingerprinted().as_bytes())
    }

    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_default()
    }

    /// The record in `json` (a record's `.json` file), if its seal holds: nothing added,
    /// removed or changed since it was written. A field the record does not know counts as
    /// a change (it would not be covered by the seal).
    pub fn check_sealed(json: &str) -> Result<Record, SealError> {
        let record: Record =
            serde_json::from_str(json).map_err(|e| SealError::NotARecord(e.to_string()))?;
        let as_read: serde_json::Value =
            serde_json::from_str(json).map_err(|e| SealError::NotARecord(e.to_string()))?;
        let known =
            serde_json::to_value(&record).map_err(|e| SealError::NotARecord(e.to_string()))?;
        if as_read != known {
            return Err(SealError::Unknown);
        }
        if record.sha256.is_empty() {
            return Err(SealError::Unsealed);
        }
        if !record.verify() {
            return Err(SealError::Broken {
                sealed: record.sha256.clone(),
                now: sha256_hex(record.fingerprinted().as_bytes()),
            });
        }
        Ok(record)
    }
}

/// Why a record's seal does not hold.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SealError {
    #[error("not a drivedeck commissioning record: {0}")]
    NotARecord(String),
    #[error("the record has no seal (its sha256 is empty)")]
    Unsealed,
    #[error(
        "the record holds fields a drivedeck record does not have: something was added after it was sealed"
    )]
    Unknown,
    #[error(
        "the record was changed after it was sealed: sealed {sealed}, its contents now give {now}"
    )]
    Broken { sealed: String, now: String },
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sha256_of_the_standard_test_vector() {
        assert_eq!(
            sha256_hex(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }

    fn sealed() -> Record {
        let mut record = Record {
            procedure: "Axis".into(),
            procedure_file: "axis.toml".into(),
            procedure_sha256: sha256_hex(b"[procedure]"),
            description: "a \"quoted\" line".into(),
            machine: "link sim".into(),
            tool: "drivedeck 0.1.0".into(),
            operator: "<closed> & locked".into(),
            started: "2026-12-06T10:00:00Z".into(),
            finished: "2026-12-06T10:01:00Z".into(),
            rehearsal: false,
            drives: vec![],
            verdict: Verdict::Passed,
            sha256: String::new(),
        };
        record.seal();
        record
    }

    #[test]
    fn a_sealed_record_checks_and_any_edit_breaks_it() {
        let record = sealed();
        let json = record.to_json();
        assert_eq!(Record::check_sealed(&json), Ok(record.clone()));
        // Pretty or compact, the same record.
        let compact = serde_json::to_string(&record).unwrap();
        assert!(Record::check_sealed(&compact).is_ok());
        // A verdict changed by hand.
        let edited = json.replace("\"verdict\": \"passed\"", "\"verdict\": \"failed\"");
        assert_ne!(edited, json);
        assert!(matches!(
            Record::check_sealed(&edited),
            Err(SealError::Broken { .. })
        ));
        // A field added, which the seal could not have covered.
        let added = json.replacen('{', "{\"approved_by\": \"me\",", 1);
        assert_eq!(Record::check_sealed(&added), Err(SealError::Unknown));
        // The seal emptied, and not a record at all.
        let unsealed = json.replace(&record.sha256, "");
        assert_eq!(Record::check_sealed(&unsealed), Err(SealError::Unsealed));
        assert!(matches!(
            Record::check_sealed("[1, 2]"),
            Err(SealError::NotARecord(_))
        ));
    }

    #[test]
    fn the_overall_verdict_is_the_worst_step() {
        use Verdict::*;
        assert_eq!(overall([Passed, Skipped].iter()), Passed);
        assert_eq!(overall([Passed, Failed, Skipped].iter()), Failed);
        assert_eq!(overall([Failed, Aborted, Passed].iter()), Aborted);
    }
}
