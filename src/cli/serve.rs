//! `drivedeck sim`: the simulated drive on real sockets until Ctrl-C.

use std::process::ExitCode;
use std::time::Duration;

use super::{CliParity, CliWords, EXIT_FAILED, EXIT_USAGE, Missing, SimArgs};
use crate::cia::PowerState;
use crate::link::Parity;
use crate::proto::modbus::registers::WordOrder;
use crate::sim::Drive;
use crate::sim::server::SharedDrive;
use crate::sim::server::enip;
use crate::sim::server::modbus::{self, RtuOptions, ServerOptions};

pub fn run(args: &SimArgs) -> ExitCode {
    if args.modbus_tcp.is_none()
        && args.modbus_rtu.is_none()
        && args.can.is_none()
        && args.slcan.is_none()
        && args.enip.is_none()
    {
        eprintln!(
            "drivedeck sim: nothing to serve. Give --modbus-tcp ADDR:PORT, --modbus-rtu PATH, --can IFACE, --slcan PATH and/or --enip ADDR:PORT."
        );
        return ExitCode::from(EXIT_USAGE);
    }
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
    match runtime.block_on(serve(args)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("drivedeck sim: {message}");
            ExitCode::from(EXIT_FAILED)
        }
    }
}

async fn serve(args: &SimArgs) -> Result<(), String> {
    let order = match args.words {
        CliWords::High => WordOrder::High,
        CliWords::Low => WordOrder::Low,
    };
    let shared = SharedDrive::new(Drive::new());
    let mut tasks = tokio::task::JoinSet::new();
    let clock = tokio::spawn(shared.clone().run_clock());
    if let Some(addr) = args.modbus_tcp {
        serve_modbus_tcp(&mut tasks, &shared, args, addr, order).await?;
    }
    if let Some(path) = &args.modbus_rtu {
        serve_modbus_rtu(&mut tasks, &shared, args, path, order)?;
    }
    if let Some(addr) = args.enip {
        serve_enip(&mut tasks, &shared, args, addr)?;
    }
    serve_canopen(&mut tasks, &shared, args)?;
    if args.verbose {
        tasks.spawn(print_every_second(shared.clone()));
    }
    tokio::select! {
        _ = tokio::signal::ctrl_c() => {
            outln!("stopping");
        }
        _ = async { while tasks.join_next().await.is_some() {} } => {}
    }
    clock.abort();
    Ok(())
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

async fn serve_modbus_tcp(
    tasks: &mut Tasks,
    shared: &SharedDrive,
    args: &SimArgs,
    addr: std::net::SocketAddr,
    order: WordOrder,
) -> Result<(), String> {
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
    Ok(())
}

fn serve_modbus_rtu(
    tasks: &mut Tasks,
    shared: &SharedDrive,
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
        slave: args.slave,
    };
    let port = modbus::open_serial(&options).map_err(|e| e.to_string())?;
    outln!(
        "serving the simulated drive on Modbus RTU {path}, slave {}, {} baud, parity {}, {} stop bit(s)",
        options.slave,
        options.baud,
        options.parity.name(),
        options.stop_bits
    );
    let served = server_options(order, 1, &args.without);
    spawn_server(
        tasks,
        "Modbus RTU server",
        modbus::serve_rtu(port, options.slave, shared.clone(), served),
    );
    Ok(())
}

fn serve_enip(
    tasks: &mut Tasks,
    shared: &SharedDrive,
    args: &SimArgs,
    addr: std::net::SocketAddr,
) -> Result<(), String> {
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
    Ok(())
}

/// CANopen nodes: behind an emulated slcan adapter (--slcan) and on SocketCAN (--can).
fn serve_canopen(tasks: &mut Tasks, shared: &SharedDrive, args: &SimArgs) -> Result<(), String> {
    let node = args.node;
    if let Some(path) = &args.slcan {
        let device =
            crate::link::canopen::slcan::SlcanDevice::open(path).map_err(|e| e.to_string())?;
        outln!(
            "serving the simulated drive as CANopen node {node} behind an emulated slcan adapter on {path}"
        );
        let run = crate::sim::server::canopen::run(device, node, shared.clone());
        spawn_server(tasks, "CANopen node on slcan", run);
    }
    if let Some(iface) = &args.can {
        #[cfg(target_os = "linux")]
        {
            let bus = crate::link::canopen::socketcan::SocketCanBus::open(iface)
                .map_err(|e| e.to_string())?;
            outln!("serving the simulated drive as CANopen node {node} on {iface}");
            let run = crate::sim::server::canopen::run(bus, node, shared.clone());
            spawn_server(tasks, "CANopen node on SocketCAN", run);
        }
        #[cfg(not(target_os = "linux"))]
        return Err(format!(
            "SocketCAN ({iface}) exists only on Linux: use --slcan PATH"
        ));
    }
    Ok(())
}

/// `--verbose`: the drive's state once a second, until the program stops.
async fn print_every_second(shared: SharedDrive) {
    let mut ticker = tokio::time::interval(Duration::from_secs(1));
    loop {
        ticker.tick().await;
        let drive = shared.lock();
        let tx = drive.tx_image();
        outln!(
            "{:8.1} s  {}  position {:.0}  velocity {:.0} rpm  PDI-Status {}",
            drive.time().as_secs_f64(),
            PowerState::from_statusword(drive.statusword()).map_or("?", PowerState::name),
            drive.position(),
            drive.velocity_rpm(),
            tx.status
        );
    }
}
