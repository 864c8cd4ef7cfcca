//! What goes wrong with an EDS: [`Warning`]s an import reads past, [`EdsError`]s it stops at.

use std::fmt;
use std::path::PathBuf;

use serde::Serialize;

use super::MAX_SIZE;

/// Something in the file that was skipped or read with a guess; the import went on.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Warning {
    /// 1-based line in the file.
    pub line: usize,
    pub message: String,
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "line {}: {}", self.line, self.message)
    }
}

/// Why an EDS could not be read or written at all.
#[derive(Debug, thiserror::Error)]
pub enum EdsError {
    #[error("cannot read {}: {source}", path.display())]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },

    /// A FIFO, a device, a directory: refused before anything waits on it.
    #[error("{0}")]
    NotAFile(String),

    #[error("cannot write {}: {source}", path.display())]
    Write {
        path: PathBuf,
        source: std::io::Error,
    },

    #[error("line {line}: a NUL byte: this is a binary file, not an EDS (CiA 306 files are text)")]
    Binary { line: usize },

    #[error("the file has {size} bytes, more than any EDS ({MAX_SIZE} at most): is it one?")]
    TooLarge { size: usize },

    #[error("{}", nothing_usable(*lines, first.as_ref()))]
    NothingUsable {
        /// Lines read.
        lines: usize,
        /// The first problem found, if any.
        first: Option<Warning>,
    },
}

fn nothing_usable(lines: usize, first: Option<&Warning>) -> String {
    let mut text = format!(
        "no object could be imported from the {lines} lines: an EDS has [1000]-style sections with ParameterName, DataType and AccessType"
    );
    if let Some(first) = first {
        text.push_str(&format!("; the first problem is at {first}"));
    }
    text
}
