//! Whether the peer tests of this `cargo test` ran their peers, said where cargo shows it.
//!
//! libtest cannot mark a test skipped at run time and hides what a passing test prints, so
//! this target has no libtest (`harness = false` in Cargo.toml): cargo shows its output as
//! it is. It makes or checks the peers as the peer tests do (`common::peers`), reads what
//! the test binaries before it in this run noted (cargo runs the test targets in name
//! order, and every peer test's name comes before this one's), and prints one line when
//! the peers are there and ran, or a block with each missing peer, why, and how many tests
//! passed without it. With `DRIVEDECK_REQUIRE_PEERS=1` a missing peer fails it.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::process::ExitCode;
use std::time::Duration;

use common::peers::{self, PeerCheck};

/// Describe the versions of a peer as installed: `pymodbus 3.16.1, pyserial 3.5`.
fn found(python: Result<common::Python, String>) -> Result<String, String> {
    python.map(|p| {
        p.versions
            .iter()
            .map(|(module, version)| format!("{} {version}", common::distribution(module)))
            .collect::<Vec<_>>()
            .join(", ")
    })
}

fn main() -> ExitCode {
    // `cargo test -- --list` (IDEs, test runners) asks what tests there are: none here.
    if std::env::args().any(|a| a == "--list") {
        return ExitCode::SUCCESS;
    }
    let pymodbus = [common::PYMODBUS, &[("serial", "")]].concat();
    let checks = [
        PeerCheck {
            peer: "pymodbus",
            python: true,
            found: found(common::check_python(&pymodbus)),
        },
        PeerCheck {
            peer: "python-canopen",
            python: true,
            found: found(common::check_python(common::PYTHON_CANOPEN)),
        },
        PeerCheck {
            peer: "pycomm3",
            python: true,
            found: found(common::check_python(common::PYCOMM3)),
        },
        PeerCheck {
            peer: "socat",
            python: false,
            found: common::check_socat().map(|_| "socat".to_owned()),
        },
        PeerCheck {
            peer: "chromium",
            python: false,
            found: common::chromium().map(|p| p.display().to_string()),
        },
        PeerCheck {
            peer: "desktop-file-validate",
            python: false,
            found: common::check_desktop_file_validate()
                .map(|_| "desktop-file-validate".to_owned()),
        },
    ];
    let run = peers::run_dir();
    let records = peers::read_records(&run);
    let required = common::peers_required();
    print!(
        "{}",
        peers::summary(&peers::interpreter(), &checks, &records, required)
    );
    // The notes of earlier runs are of no more use.
    peers::prune_runs(&peers::runs_root(), &run, Duration::from_secs(24 * 3600));
    if required && checks.iter().any(|c| c.found.is_err()) {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}
