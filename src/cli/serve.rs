//! `drivedeck sim`: simulated drives on real sockets until Ctrl-C. One drive unless a
//! `--node`, `--slave`, `--modbus-tcp` or `--enip` is given more than once (see `plan`).

mod plan;

use std::process::ExitCode;
use std::time::Duration;

use super::{CliParity, CliWords, EXIT_FAILED, EXIT_USAGE, Missing, SimArgs};
use crate::cia::PowerState;
use crate::link::Parity;
use crate::proto::modbus::registers::WordOrder;
use crate::sim::Drive;
use crate::sim::server::SharedDrive;
use crate::sim::server::enip;
use crate::sim::server::modbus::{self, ServerOptions};
use crate::sim::server::modbus_rtu::{self, RtuOptions};
use plan::{Planned, listed};

pub fn run(args: &SimArgs) -> ExitCode {
    if args.modbus_tcp.is_empty()
        && args.modbus_rtu.is_none()
        && args.can.is_none()
        && args.slcan.is_none()
        && args.enip.is_empty()
    {
        eprintln!(
            "drivedeck sim: nothing to serve. Give --modbus-tcp ADDR:PORT, --modbus-rtu PATH, --can IFACE, --slcan PATH and/or --enip ADDR:PORT."
        );
        return ExitCode::from(EXIT_USAGE);
    }
    let planned = match plan::plan(args) {
        Ok(planned) => planned,
        Err(message) => {
            eprintln!("drivedeck sim: {message}");
            return ExitCode::from(EXIT_USAGE);
        }
    };
    let runtime = match tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
    {
        Ok(runtime) => runtime,
        Err(e) => {
            eprintln!("drivedeck sim: cannot start the runtime: {e}");
            return ExitCode::from(EXIT_FAILED);
        }
    };
    match runtime.block_on(serve(args, &planned)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("drivedeck sim: {message}");
            ExitCode::from(EXIT_FAILED)
        }
    }
}

/// A simulated drive being served, and what it is served as ("node 5", "Modbus TCP
/// 127.0.0.1:1502"), for `--verbose`.
/// A simulated drive with the load the command line couples to it.
fn loaded(args: &SimArgs) -> Drive {
    let mut drive = Drive::new();
    drive.set_load(crate::sim::Load {
        inertia: args.load_inertia,
        torque: args.load_torque,
    });
    drive
}

struct Served {
    drive: SharedDrive,
    names: Vec<String>,
}

async fn serve(args: &SimArgs, planned: &[Planned]) -> Result<(), String> {
    let order = match args.words {
        CliWords::High => WordOrder::High,
        CliWords::Low => WordOrder::Low,
    };
    let mut served: Vec<Served> = planned
        .iter()
        .map(|_| Served {
            drive: SharedDrive::new(loaded(args)),
            names: vec![],
        })
        .collect();
    let mut tasks = tokio::task::JoinSet::new();
    let clock = crate::sim::server::Clock::start(served.iter().map(|s| s.drive.clone()).collect())
        .map_err(|e| format!("starting the drives' clock: {e}"))?;
    for (planned, served) in planned.iter().zip(&mut served) {
        if let Some(addr) = planned.modbus_tcp {
            let local = serve_modbus_tcp(&mut tasks, &served.drive, args, addr, order).await?;
            served.names.push(format!("Modbus TCP {local}"));
        }
    }
    if let Some(path) = &args.modbus_rtu {
        let slaves = on_the_medium(planned, &mut served, |p| p.slave, "slave");
        serve_modbus_rtu(&mut tasks, slaves, args, path, order)?;
    }
    for (planned, served) in planned.iter().zip(&mut served) {
        if let Some(addr) = planned.enip {
            let local = serve_enip(&mut tasks, &served.drive, args, addr)?;
            served.names.push(format!("EtherNet/IP {local}"));
        }
    }
    if args.slcan.is_some() || args.can.is_some() {
        let nodes = on_the_medium(planned, &mut served, |p| p.node, "node");
        serve_canopen(&mut tasks, &nodes, args)?;
    }
    if args.verbose {
        tasks.spawn(print_every_second(served));
    }
    tokio::select! {
        _ = tokio::signal::ctrl_c() => {
            outln!("stopping");
        }
        _ = async { while tasks.join_next().await.is_some() {} } => {}
    }
    drop(clock);
    Ok(())
}

/// The drives with an address on a shared medium (`address` of their plan: node id, slave
/// address), each then named by it ("node 5").
fn on_the_medium(
    planned: &[Planned],
    served: &mut [Served],
    address: impl Fn(&Planned) -> Option<u8>,
    word: &str,
) -> Vec<(u8, SharedDrive)> {
    planned
        .iter()
        .zip(served)
        .filter_map(|(planned, served)| {
            let id = address(planned)?;
            served.names.push(format!("{word} {id}"));
            Some((id, served.drive.clone()))
        })
        .collect()
}

/// The servers' tasks; each reports its own end on stderr.
type Tasks = tokio::task::JoinSet<()>;

/// Run a server until it stops; why it stopped, if it failed, on stderr.
fn spawn_server<E: std::fmt::Display + 'static>(
    tasks: &mut Tasks,
    what: &'static str,
    server: impl Future<Output = Result<(), E>> + Send + 'static,
) {
    tasks.spawn(async move {
        if let Err(e) = server.await {
            eprintln!("drivedeck sim: {what} stopped: {e}");
        }
    });
}

/// The Modbus server's options: `max_clients` at a time, less the function codes left out.
fn server_options(order: WordOrder, max_clients: usize, without: &[Missing]) -> ServerOptions {
    ServerOptions {
        order,
        max_clients,
        fc23: !without.contains(&Missing::Fc23),
        fc43: !without.contains(&Missing::Fc43),
    }
}

/// Serve one drive on Modbus TCP at `addr`; the address it listens on.
async fn serve_modbus_tcp(
    tasks: &mut Tasks,
    shared: &SharedDrive,
    args: &SimArgs,
    addr: std::net::SocketAddr,
    order: WordOrder,
) -> Result<std::net::SocketAddr, String> {
    let listener = tokio::net::TcpListener::bind(addr)
        .await
        .map_err(|e| format!("cannot listen on {addr}: {e}"))?;
    let local = listener.local_addr().map_err(|e| e.to_string())?;
    outln!(
        "serving the simulated drive on Modbus TCP {local} ({} client{} at a time, {} word first)",
        args.max_clients,
        if args.max_clients == 1 { "" } else { "s" },
        order
    );
    let options = server_options(order, args.max_clients.max(1), &args.without);
    spawn_server(
        tasks,
        "Modbus TCP server",
        modbus::serve_tcp(listener, shared.clone(), options),
    );
    Ok(local)
}

/// Serve `slaves` (address, drive) on the RTU line at `path`.
fn serve_modbus_rtu(
    tasks: &mut Tasks,
    slaves: Vec<(u8, SharedDrive)>,
    args: &SimArgs,
    path: &str,
    order: WordOrder,
) -> Result<(), String> {
    let options = RtuOptions {
        path: path.to_owned(),
        baud: args.baud,
        parity: match args.parity {
            CliParity::None => Parity::None,
            CliParity::Even => Parity::Even,
            CliParity::Odd => Parity::Odd,
        },
        stop_bits: args.stop_bits,
    };
    let port = modbus_rtu::open_serial(&options).map_err(|e| e.to_string())?;
    let addresses: Vec<u8> = slaves.iter().map(|(address, _)| *address).collect();
    let who = match addresses.as_slice() {
        [one] => format!("the simulated drive on Modbus RTU {path}, slave {one}"),
        many => format!(
            "the simulated drives on Modbus RTU {path}, slaves {}",
            listed(many)
        ),
    };
    outln!(
        "serving {who}, {} baud, parity {}, {} stop bit(s)",
        options.baud,
        options.parity.name(),
        options.stop_bits
    );
    let served = server_options(order, 1, &args.without);
    spawn_server(
        tasks,
        "Modbus RTU server",
        modbus_rtu::serve_rtu(port, slaves, served),
    );
    Ok(())
}

/// Serve one drive as an EtherNet/IP adapter at `addr`; the address it listens on.
fn serve_enip(
    tasks: &mut Tasks,
    shared: &SharedDrive,
    args: &SimArgs,
    addr: std::net::SocketAddr,
) -> Result<std::net::SocketAddr, String> {
    let sockets = enip::Sockets::bind(addr, args.enip_io_port)
        .map_err(|e| format!("cannot serve EtherNet/IP on {addr}: {e}"))?;
    let local = sockets.tcp_addr().map_err(|e| e.to_string())?;
    let io = sockets.io_addr().map_err(|e| e.to_string())?;
    outln!(
        "serving the simulated drive on EtherNet/IP {local} (class 1 I/O on UDP {io}, vendor {:X}h)",
        crate::proto::enip::identity::NANOTEC_VENDOR
    );
    let options = enip::AdapterOptions {
        max_sessions: args.max_sessions.max(1),
        io_port: io.port(),
    };
    spawn_server(
        tasks,
        "EtherNet/IP adapter",
        enip::serve(sockets, shared.clone(), options),
    );
    Ok(local)
}

/// CANopen nodes (node id, drive): behind an emulated slcan adapter (--slcan) and on
/// SocketCAN (--can), all on one bus each, with one reader of it.
fn serve_canopen(
    tasks: &mut Tasks,
    nodes: &[(u8, SharedDrive)],
    args: &SimArgs,
) -> Result<(), String> {
    let ids: Vec<u8> = nodes.iter().map(|(id, _)| *id).collect();
    let who = match ids.as_slice() {
        [one] => format!("the simulated drive as CANopen node {one}"),
        many => format!("the simulated drives as CANopen nodes {}", listed(many)),
    };
    if let Some(path) = &args.slcan {
        let device =
            crate::link::canopen::slcan::SlcanDevice::open(path).map_err(|e| e.to_string())?;
        outln!("serving {who} behind an emulated slcan adapter on {path}");
        let run = crate::sim::server::canopen::run_many(device, nodes.to_vec());
        spawn_server(tasks, "CANopen node on slcan", run);
    }
    if let Some(iface) = &args.can {
        #[cfg(target_os = "linux")]
        {
            let bus = crate::link::canopen::socketcan::SocketCanBus::open(iface)
                .map_err(|e| e.to_string())?;
            outln!("serving {who} on {iface}");
            let run = crate::sim::server::canopen::run_many(bus, nodes.to_vec());
            spawn_server(tasks, "CANopen node on SocketCAN", run);
        }
        #[cfg(not(target_os = "linux"))]
        return Err(format!(
            "SocketCAN ({iface}) exists only on Linux: use --slcan PATH"
        ));
    }
    Ok(())
}

/// `--verbose`: each drive's state once a second, until the program stops; with several
/// drives each line starts with what the drive is served as.
async fn print_every_second(served: Vec<Served>) {
    let names: Vec<String> = served.iter().map(|s| s.names.join(", ") + ":").collect();
    let width = names.iter().map(String::len).max().unwrap_or(0);
    let mut ticker = tokio::time::interval(Duration::from_secs(1));
    loop {
        ticker.tick().await;
        for (one, name) in served.iter().zip(&names) {
            let line = state_line(&one.drive);
            if served.len() == 1 {
                outln!("{line}");
            } else {
                outln!("{name:<width$}{line}");
            }
        }
    }
}

/// Time, CiA 402 state, position, velocity and PDI status of a drive.
fn state_line(shared: &SharedDrive) -> String {
    let drive = shared.lock();
    let tx = drive.tx_image();
    format!(
        "{:8.1} s  {}  position {:.0}  velocity {:.0} rpm  PDI-Status {}",
        drive.time().as_secs_f64(),
        PowerState::from_statusword(drive.statusword()).map_or("?", PowerState::name),
        drive.position(),
        drive.velocity_rpm(),
        tx.status
    )
}
