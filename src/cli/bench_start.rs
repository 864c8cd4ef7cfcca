//! `drivedeck bench --startup N`: the window started N times per case, timed from outside.
//! Each start is this same program with `DRIVEDECK_TIMINGS=exit` in a fresh home folder
//! (no saved settings, no last project: a first start), which prints when it laid out its
//! first frame and when it first showed the drive's status, then closes itself (see
//! `ui::timings`). The launcher subtracts the wall-clock time it spawned the process at,
//! so "launch" includes loading the program, the display connection and the GL context.
//! Cases alternate run by run, so a noisy moment hits them alike.

use std::io::{BufRead, BufReader};
use std::process::{Command, ExitCode, Stdio};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use super::EXIT_FAILED;
use crate::link::LinkSpec;
use crate::sim::server::ServerThread;
use crate::sim::server::modbus::ServerOptions;
use crate::ui::timings::{VARIABLE, parse_line};

/// A start that has not shown the drive's status by then failed.
const GIVE_UP_AFTER: Duration = Duration::from_secs(30);

/// One start's figures, ms.
#[derive(Clone, Copy, Debug, Default)]
struct Start {
    first_frame: f64,
    first_status: f64,
    connect_to_status: f64,
}

/// A fresh home folder for one start, removed after it.
struct Home(std::path::PathBuf);

impl Home {
    fn new() -> Result<Home, String> {
        static NEXT: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
        let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!("drivedeck-start-{}-{n}", std::process::id()));
        std::fs::create_dir_all(&dir)
            .map_err(|e| format!("a home folder {}: {e}", dir.display()))?;
        Ok(Home(dir))
    }

    fn path(&self) -> &std::path::Path {
        &self.0
    }
}

impl Drop for Home {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Start the window once with `link` (none: the demo) and time it.
fn start_once(link: Option<&LinkSpec>) -> Result<Start, String> {
    let exe = std::env::current_exe().map_err(|e| format!("this program's path: {e}"))?;
    let home = Home::new()?;
    let mut command = Command::new(exe);
    if let Some(link) = link {
        command.arg("--link").arg(link.to_string());
    }
    command
        .env(VARIABLE, "exit")
        .env("HOME", home.path())
        .env("XDG_DATA_HOME", home.path().join("data"))
        .env("XDG_CONFIG_HOME", home.path().join("config"))
        .env("RUST_LOG", "off")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped());
    let spawned_at = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_err(|e| e.to_string())?
        .as_nanos();
    let started = Instant::now();
    let mut child = command
        .spawn()
        .map_err(|e| format!("cannot start the window: {e}"))?;
    let Some(stderr) = child.stderr.take() else {
        let _ = child.kill();
        return Err("no stderr from the window".into());
    };
    let since_spawn = |unix: u128| unix.saturating_sub(spawned_at) as f64 / 1e6;
    let mut start = Start::default();
    let (mut frame, mut status) = (false, false);
    let mut last_lines = Vec::new();
    for line in BufReader::new(stderr).lines() {
        let Ok(line) = line else { break };
        match parse_line(&line) {
            Some((event, _, unix, _)) if event == "first-frame" => {
                start.first_frame = since_spawn(unix);
                frame = true;
            }
            Some((event, _, unix, since)) if event == "first-status" => {
                start.first_status = since_spawn(unix);
                start.connect_to_status = since.unwrap_or(f64::NAN);
                status = true;
            }
            _ => {
                last_lines.push(line);
                if last_lines.len() > 5 {
                    last_lines.remove(0);
                }
            }
        }
        if frame && status || started.elapsed() > GIVE_UP_AFTER {
            break;
        }
    }
    // It closes itself; a window that does not is not waited for.
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        match child.try_wait() {
            Ok(Some(_)) => break,
            Ok(None) if Instant::now() < deadline => std::thread::sleep(Duration::from_millis(20)),
            _ => {
                let _ = child.kill();
                let _ = child.wait();
                break;
            }
        }
    }
    if frame && status {
        Ok(start)
    } else {
        Err(format!(
            "the window did not report its first {} (no display? run under Xvfb); it said: {}",
            if frame { "status" } else { "frame" },
            last_lines.join(" | ")
        ))
    }
}

fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied().unwrap_or(f64::NAN)
}

/// Start the window `runs` times on the demo and on a Modbus TCP drive served on loopback,
/// alternating, and print min / median / max of each figure.
pub fn run(runs: u32) -> ExitCode {
    let server =
        match ServerThread::modbus_tcp(([127, 0, 0, 1], 0).into(), ServerOptions::default()) {
            Ok(server) => server,
            Err(e) => {
                eprintln!("drivedeck bench: cannot serve the simulated drive: {e}");
                return ExitCode::from(EXIT_FAILED);
            }
        };
    let served = LinkSpec::ModbusTcp {
        host: server.addr.ip().to_string(),
        port: server.addr.port(),
        unit: 0,
        words: Default::default(),
    };
    let cases: [(&str, Option<&LinkSpec>); 2] = [
        ("demo: two built-in simulated drives", None),
        ("one drive, Modbus TCP served on loopback", Some(&served)),
    ];
    let mut figures: Vec<Vec<Start>> = vec![Vec::new(); cases.len()];
    for run in 0..runs.max(1) {
        for (i, (name, link)) in cases.iter().enumerate() {
            match start_once(*link) {
                Ok(start) => {
                    outln!(
                        "run {} {name}: first frame {:.0} ms, first status {:.0} ms after launch ({:.0} ms after the connect request)",
                        run + 1,
                        start.first_frame,
                        start.first_status,
                        start.connect_to_status
                    );
                    figures[i].push(start);
                }
                Err(e) => {
                    eprintln!("drivedeck bench: {name}: {e}");
                    return ExitCode::from(EXIT_FAILED);
                }
            }
        }
    }
    outln!();
    outln!("| start | launch → first frame | launch → first status | connect → first status |");
    outln!("| --- | ---: | ---: | ---: |");
    for ((name, _), starts) in cases.iter().zip(&figures) {
        let spread = |pick: fn(&Start) -> f64| {
            let mut values: Vec<f64> = starts.iter().map(pick).collect();
            let min = values.iter().copied().fold(f64::INFINITY, f64::min);
            let max = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            format!("{:.0} ms ({min:.0}–{max:.0})", median(&mut values))
        };
        outln!(
            "| {name} | {} | {} | {} |",
            spread(|s| s.first_frame),
            spread(|s| s.first_status),
            spread(|s| s.connect_to_status)
        );
    }
    outln!(
        "median (min–max) of {} runs each; the first frame is the first one laid out (painting follows in the same pass)",
        runs.max(1)
    );
    ExitCode::SUCCESS
}
