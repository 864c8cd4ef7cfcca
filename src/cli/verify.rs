//! `drivedeck verify RECORD`: whether a commissioning record is as it was written — its
//! seal (SHA-256 over its JSON) checked, the HTML page's `.json` taken where the page is
//! given. Exit 0 the seal holds, 1 it does not, 2 the file cannot be read or is no record.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::Args;
use serde::Serialize;

use crate::procedure::record::{Record, SealError};

/// A record is small; more than this is not one.
const MAX_RECORD_BYTES: u64 = 64 << 20;

#[derive(Args, Debug, Clone)]
pub struct VerifyArgs {
    /// The record: its `.json`, or the `.html` page beside it.
    pub record: PathBuf,
}

#[derive(Serialize)]
struct Verified<'a> {
    file: String,
    seal_holds: bool,
    why: Option<String>,
    procedure: Option<&'a str>,
    verdict: Option<&'a str>,
    finished: Option<&'a str>,
    operator: Option<&'a str>,
    rehearsal: Option<bool>,
    sha256: Option<&'a str>,
}

/// The JSON file of the record at `path` (the page's `.json` for an `.html`).
fn json_of(path: &Path) -> PathBuf {
    match path.extension().and_then(|e| e.to_str()) {
        Some(e) if e.eq_ignore_ascii_case("html") || e.eq_ignore_ascii_case("htm") => {
            path.with_extension("json")
        }
        _ => path.to_path_buf(),
    }
}

pub fn run(args: &VerifyArgs, json: bool) -> ExitCode {
    let file = json_of(&args.record);
    let text = match crate::file::read_given(&file, MAX_RECORD_BYTES, "a commissioning record") {
        Ok(bytes) => String::from_utf8_lossy(&bytes).into_owned(),
        Err(e) => {
            super::report::print_error(&format!("cannot read the record: {e}"), json);
            return ExitCode::from(2);
        }
    };
    let checked = Record::check_sealed(&text);
    let record = checked.as_ref().ok();
    if json {
        super::report::print_json(
            &Verified {
                file: file.display().to_string(),
                seal_holds: checked.is_ok(),
                why: checked.as_ref().err().map(ToString::to_string),
                procedure: record.map(|r| r.procedure.as_str()),
                verdict: record.map(|r| r.verdict.word()),
                finished: record.map(|r| r.finished.as_str()),
                operator: record.map(|r| r.operator.as_str()),
                rehearsal: record.map(|r| r.rehearsal),
                sha256: record.map(|r| r.sha256.as_str()),
            },
            "verify",
        );
    }
    match checked {
        Ok(r) => {
            if !json {
                outln!("the seal holds: {}", file.display());
                outln!(
                    "  {} — {}{}, finished {} by {}",
                    r.procedure,
                    r.verdict.word(),
                    if r.rehearsal { " (a rehearsal)" } else { "" },
                    r.finished,
                    r.operator
                );
                outln!("  sha256 {}", r.sha256);
            }
            ExitCode::SUCCESS
        }
        Err(SealError::NotARecord(why)) => {
            if !json {
                eprintln!(
                    "drivedeck verify: {} is not a drivedeck commissioning record: {why}",
                    file.display()
                );
            }
            ExitCode::from(2)
        }
        Err(e) => {
            if !json {
                eprintln!("drivedeck verify: {}: {e}", file.display());
            }
            ExitCode::from(1)
        }
    }
}
