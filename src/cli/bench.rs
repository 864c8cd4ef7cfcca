//! `drivedeck bench`: how fast a link exchanges the PDI and reads objects, measured on the
//! link itself (no worker pacing), so the figures are the bus's and the drive's.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use serde::Serialize;

use super::{BenchArgs, EXIT_FAILED, EXIT_USAGE, ServedBus};
use crate::link::{self, Link, LinkSpec};
use crate::od::{Address, DataType};
use crate::sim::server::ServerThread;
use crate::sim::server::modbus::Options;

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

#[derive(Serialize, Debug)]
struct Report {
    link: String,
    results: Vec<Figures>,
}

pub fn run(link: Option<LinkSpec>, args: &BenchArgs, json: bool) -> ExitCode {
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
    // --serve-sim BUS: the simulated drive served on loopback, in this process.
    let loopback = ([127, 0, 0, 1], 0).into();
    let served = match args.serve_sim {
        None => None,
        Some(ServedBus::Modbus) => Some(
            ServerThread::modbus_tcp(loopback, Options::default()).map(|server| {
                let spec = LinkSpec::ModbusTcp {
                    host: server.addr.ip().to_string(),
                    port: server.addr.port(),
                    unit: 0,
                    words: Default::default(),
                };
                (Some(server), spec)
            }),
        ),
        Some(bus @ (ServedBus::Enip | ServedBus::EnipExplicit)) => {
            let options = crate::sim::server::enip::Options {
                io_port: 0,
                ..Default::default()
            };
            Some(ServerThread::enip(loopback, options).and_then(|server| {
                let io = if bus == ServedBus::Enip {
                    "pdi"
                } else {
                    "explicit"
                };
                let text = format!("enip://{}?io={io}&rpi={}&udp=0", server.addr, args.rpi);
                text.parse::<LinkSpec>()
                    .map(|spec| (Some(server), spec))
                    .map_err(|e| std::io::Error::other(e.to_string()))
            }))
        }
        Some(ServedBus::Canopen) => Some(Ok((
            None,
            LinkSpec::CanopenSim {
                can: Default::default(),
            },
        ))),
    };
    let (_server, spec) = match (served, link) {
        (Some(Ok((server, spec))), _) => (server, spec),
        (Some(Err(e)), _) => {
            eprintln!("drivedeck bench: cannot start the simulated server: {e}");
            return ExitCode::from(EXIT_FAILED);
        }
        (None, Some(spec)) => (None, spec),
        (None, None) => {
            eprintln!(
                "drivedeck bench: give --link URL, or --serve-sim [modbus|enip|enip-explicit|canopen] to bench the simulated drive on loopback"
            );
            return ExitCode::from(EXIT_USAGE);
        }
    };
    let seconds = Duration::from_secs_f64(args.seconds.clamp(0.2, 600.0));
    match runtime.block_on(measure(&spec, seconds)) {
        Ok(results) => {
            let report = Report {
                link: spec.to_string(),
                results,
            };
            if json {
                match serde_json::to_string_pretty(&report) {
                    Ok(text) => println!("{text}"),
                    Err(e) => eprintln!("drivedeck bench: {e}"),
                }
            } else {
                println!("link {}", report.link);
                for figures in &report.results {
                    println!("{figures}");
                }
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("drivedeck bench: {e}");
            ExitCode::from(EXIT_FAILED)
        }
    }
}

async fn measure(spec: &LinkSpec, span: Duration) -> Result<Vec<Figures>, link::Error> {
    let mut link = link::open(spec).await?;
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
