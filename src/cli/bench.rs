//! `drivedeck bench`: how fast a link exchanges the PDI and reads objects, measured on the
//! link itself (no worker pacing), so the figures are the bus's and the drive's.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use serde::Serialize;

use super::{BenchArgs, EXIT_FAILED, EXIT_USAGE, ServedBus};
use crate::link::{self, Link, LinkSpec};
use crate::od::{Address, DataType};
use crate::sim::server::ServerThread;
use crate::sim::server::modbus::ServerOptions;

/// Round-trip statistics of one kind of request.
#[derive(Serialize, Debug)]
pub struct Figures {
    pub what: String,
    pub count: usize,
    pub seconds: f64,
    pub per_second: f64,
    pub min_ms: f64,
    pub median_ms: f64,
    pub p99_ms: f64,
    pub max_ms: f64,
}

impl Figures {
    fn from(what: &str, mut rtts: Vec<Duration>, span: Duration) -> Figures {
        rtts.sort_unstable();
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        let at = |q: f64| {
            rtts.get(((rtts.len() as f64 - 1.0) * q).round() as usize)
                .copied()
                .unwrap_or_default()
        };
        Figures {
            what: what.to_owned(),
            count: rtts.len(),
            seconds: span.as_secs_f64(),
            per_second: rtts.len() as f64 / span.as_secs_f64().max(1e-9),
            min_ms: ms(at(0.0)),
            median_ms: ms(at(0.5)),
            p99_ms: ms(at(0.99)),
            max_ms: ms(at(1.0)),
        }
    }
}

impl std::fmt::Display for Figures {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{:<34} {:>8} in {:>4.1} s = {:>8.0}/s   round trip min {:.3} ms, median {:.3} ms, p99 {:.3} ms, max {:.3} ms",
            self.what,
            self.count,
            self.seconds,
            self.per_second,
            self.min_ms,
            self.median_ms,
            self.p99_ms,
            self.max_ms
        )
    }
}

/// The figures of one link.
#[derive(Serialize, Debug)]
struct LinkReport {
    link: String,
    results: Vec<Figures>,
    /// Class 1 I/O: the production and arrival intervals under load (bench_io.rs).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    io_intervals: Vec<super::bench_io::Intervals>,
}

/// A whole run: one or more links, and the independent client on the same server.
#[derive(Serialize, Debug)]
struct Report {
    links: Vec<LinkReport>,
    /// pymodbus doing the same FC 23 exchange against the same Modbus TCP server.
    peer: Option<Figures>,
    /// Why the peer did not run, when it did not.
    peer_skipped: Option<String>,
}

/// The pymodbus side of the comparison, run by the Python found (benches/pymodbus_fc23.py
/// is compiled in, so the installed binary needs no source tree).
const PYMODBUS_FC23: &str = include_str!("../../benches/pymodbus_fc23.py");

/// The Python with pymodbus: --python, else $DRIVEDECK_PYTHON, else ./.venv (what
/// `cargo test` makes), else python3.
fn python(args: &BenchArgs) -> std::path::PathBuf {
    if let Some(p) = &args.python {
        return p.clone();
    }
    if let Some(p) = std::env::var_os("DRIVEDECK_PYTHON") {
        return p.into();
    }
    let venv = std::path::Path::new(".venv/bin/python");
    if venv.exists() {
        return venv.to_path_buf();
    }
    "python3".into()
}

/// pymodbus's FC 23 loop against `addr` for `span`.
fn pymodbus_figures(
    python: &std::path::Path,
    addr: std::net::SocketAddr,
    span: Duration,
) -> Result<Figures, String> {
    let out = std::process::Command::new(python)
        .arg("-c")
        .arg(PYMODBUS_FC23)
        .arg(addr.ip().to_string())
        .arg(addr.port().to_string())
        .arg(span.as_secs_f64().to_string())
        .output()
        .map_err(|e| format!("cannot run {}: {e}", python.display()))?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    let value: serde_json::Value = serde_json::from_str(stdout.trim()).map_err(|e| {
        format!(
            "{} gave no figures ({e}): {}{}",
            python.display(),
            stdout.trim(),
            String::from_utf8_lossy(&out.stderr).trim()
        )
    })?;
    if let Some(failed) = value["failed"].as_str() {
        return Err(format!(
            "{failed} (with {}; `python3 -m pip install pymodbus==3.16.1`, or --python PATH)",
            python.display()
        ));
    }
    let number = |key: &str| value[key].as_f64().unwrap_or(f64::NAN);
    Ok(Figures {
        what: value["what"]
            .as_str()
            .unwrap_or("pymodbus FC 23")
            .to_owned(),
        count: value["count"].as_u64().unwrap_or(0) as usize,
        seconds: number("seconds"),
        per_second: number("per_second"),
        min_ms: number("min_ms"),
        median_ms: number("median_ms"),
        p99_ms: number("p99_ms"),
        max_ms: number("max_ms"),
    })
}

/// One link to measure, with the server that serves the simulated drive for it.
struct Target {
    server: Option<ServerThread>,
    spec: LinkSpec,
}

fn serve(bus: ServedBus, rpi: u32) -> std::io::Result<Target> {
    let loopback = ([127, 0, 0, 1], 0).into();
    match bus {
        ServedBus::Modbus => {
            let server = ServerThread::modbus_tcp(loopback, ServerOptions::default())?;
            let spec = LinkSpec::ModbusTcp {
                host: server.addr.ip().to_string(),
                port: server.addr.port(),
                unit: 0,
                words: Default::default(),
            };
            Ok(Target {
                server: Some(server),
                spec,
            })
        }
        ServedBus::Enip | ServedBus::EnipExplicit => {
            let options = crate::sim::server::enip::AdapterOptions {
                io_port: 0,
                ..Default::default()
            };
            let server = ServerThread::enip(loopback, options)?;
            let io = if bus == ServedBus::Enip {
                "pdi"
            } else {
                "explicit"
            };
            let text = format!("enip://{}?io={io}&rpi={rpi}&udp=0", server.addr);
            let spec = text
                .parse::<LinkSpec>()
                .map_err(|e| std::io::Error::other(e.to_string()))?;
            Ok(Target {
                server: Some(server),
                spec,
            })
        }
        ServedBus::Canopen => Ok(Target {
            server: None,
            spec: LinkSpec::CanopenSim {
                can: Default::default(),
            },
        }),
        ServedBus::All => Err(std::io::Error::other("not one bus")),
    }
}

pub fn run(link: Option<LinkSpec>, args: &BenchArgs, json: bool) -> ExitCode {
    if let Some(runs) = args.startup {
        return super::bench_start::run(runs);
    }
    let runtime = match tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
    {
        Ok(runtime) => runtime,
        Err(e) => {
            eprintln!("drivedeck bench: cannot start the runtime: {e}");
            return ExitCode::from(EXIT_FAILED);
        }
    };
    let targets = match targets(link, args) {
        Ok(targets) => targets,
        Err(code) => return code,
    };
    let seconds = Duration::from_secs_f64(args.seconds.clamp(0.2, 600.0));
    let mut report = Report {
        links: vec![],
        peer: None,
        peer_skipped: None,
    };
    for target in &targets {
        if !json {
            outln!("link {}", target.spec);
        }
        let results = match runtime.block_on(measure(&target.spec, seconds)) {
            Ok(results) => results,
            Err(e) => {
                eprintln!("drivedeck bench: {}: {e}", target.spec);
                return ExitCode::from(EXIT_FAILED);
            }
        };
        if !json {
            for figures in &results {
                outln!("  {figures}");
            }
        }
        let io_intervals = match super::bench_io::run(&runtime, &target.spec, seconds, json) {
            Ok(intervals) => intervals,
            Err(e) => {
                eprintln!("drivedeck bench: {} (class 1 intervals): {e}", target.spec);
                return ExitCode::from(EXIT_FAILED);
            }
        };
        report.links.push(LinkReport {
            link: target.spec.to_string(),
            results,
            io_intervals,
        });
        // The independent client on the same Modbus TCP server, after ours let go of
        // it (the server, like the drive, takes one client at a time).
        if let (Some(server), LinkSpec::ModbusTcp { .. }, false) =
            (&target.server, &target.spec, args.no_peer)
        {
            compare_with_peer(&python(args), server.addr, seconds, json, &mut report);
        }
    }
    print_report(&report, json);
    ExitCode::SUCCESS
}

/// The whole run as JSON, or the table when there is more than one line to compare.
fn print_report(report: &Report, json: bool) {
    if json {
        match serde_json::to_string_pretty(report) {
            Ok(text) => outln!("{text}"),
            Err(e) => eprintln!("drivedeck bench: {e}"),
        }
    } else if report.links.len() > 1 || report.peer.is_some() {
        print_table(report);
    }
}

/// The links to measure: the simulated drive served on loopback in this process for each
/// bus of --serve-sim, else the --link given. `Err` is the exit code of a failed start.
fn targets(link: Option<LinkSpec>, args: &BenchArgs) -> Result<Vec<Target>, ExitCode> {
    let buses: Vec<ServedBus> = match (args.serve_sim, &link) {
        (Some(ServedBus::All), _) => vec![
            ServedBus::Modbus,
            ServedBus::Enip,
            ServedBus::EnipExplicit,
            ServedBus::Canopen,
        ],
        (Some(bus), _) => vec![bus],
        (None, Some(_)) => vec![],
        (None, None) => {
            eprintln!(
                "drivedeck bench: give --link URL, or --serve-sim [all|modbus|enip|enip-explicit|canopen] to bench the simulated drive on loopback"
            );
            return Err(ExitCode::from(EXIT_USAGE));
        }
    };
    let mut targets = vec![];
    for bus in buses {
        match serve(bus, args.rpi) {
            Ok(target) => targets.push(target),
            Err(e) => {
                eprintln!("drivedeck bench: cannot start the simulated server: {e}");
                return Err(ExitCode::from(EXIT_FAILED));
            }
        }
    }
    if let (true, Some(spec)) = (targets.is_empty(), link) {
        targets.push(Target { server: None, spec });
    }
    Ok(targets)
}

/// pymodbus on the server at `addr`, into the report (or why it did not run).
fn compare_with_peer(
    python: &std::path::Path,
    addr: std::net::SocketAddr,
    seconds: Duration,
    json: bool,
    report: &mut Report,
) {
    match pymodbus_figures(python, addr, seconds) {
        Ok(figures) => {
            if !json {
                outln!("  {figures}");
            }
            report.peer = Some(figures);
        }
        Err(why) => {
            if !json {
                outln!("  pymodbus comparison skipped: {why}");
            }
            report.peer_skipped = Some(why);
        }
    }
}

/// The PDI exchanges side by side.
fn print_table(report: &Report) {
    outln!();
    outln!(
        "{:<58} {:>10} {:>9} {:>9} {:>9}",
        "PDI exchange",
        "cycles/s",
        "min ms",
        "median",
        "p99"
    );
    let row = |name: &str, f: &Figures| {
        outln!(
            "{:<58} {:>10.0} {:>9.3} {:>9.3} {:>9.3}",
            name,
            f.per_second,
            f.min_ms,
            f.median_ms,
            f.p99_ms
        );
    };
    for link in &report.links {
        if let Some(f) = link.results.first() {
            row(&format!("drivedeck, {}", link.link), f);
        }
    }
    if let Some(f) = &report.peer {
        row(&f.what, f);
    }
}

async fn measure(spec: &LinkSpec, span: Duration) -> Result<Vec<Figures>, link::Error> {
    let mut link = crate::connect::open(spec).await?;
    // Write back what the drive holds: the bench never commands anything.
    let rx = link.read_rx().await?;
    let mut results = vec![];

    let mut rtts = vec![];
    let start = Instant::now();
    while start.elapsed() < span {
        let sent = Instant::now();
        link.exchange(rx.as_ref()).await?;
        rtts.push(sent.elapsed());
    }
    let what = if rx.is_some() {
        "PDI exchange (write + read)"
    } else {
        "PDI exchange (read)"
    };
    results.push(Figures::from(what, rtts, start.elapsed()));

    if link.info().native_objects {
        let mut rtts = vec![];
        let start = Instant::now();
        while start.elapsed() < span {
            let sent = Instant::now();
            let read = link
                .read_object(Address::new(0x6064, 0), DataType::Integer32)
                .await?;
            if read.is_err() {
                break;
            }
            rtts.push(sent.elapsed());
        }
        if !rtts.is_empty() {
            results.push(Figures::from(
                "object read 6064h (without PDI)",
                rtts,
                start.elapsed(),
            ));
        }
    }
    let _ = link.close().await;
    Ok(results)
}
