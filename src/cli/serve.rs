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
        let options = ServerOptions {
            order,
            max_clients: args.max_clients.max(1),
            fc23: !args.without.contains(&Missing::Fc23),
            fc43: !args.without.contains(&Missing::Fc43),
        };
        let shared = shared.clone();
        tasks.spawn(async move {
            if let Err(e) = modbus::serve_tcp(listener, shared, options).await {
                eprintln!("drivedeck sim: Modbus TCP server stopped: {e}");
            }
        });
    }
    if let Some(path) = &args.modbus_rtu {
        let options = RtuOptions {
            path: path.clone(),
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
        let shared = shared.clone();
        let missing = args.without.clone();
        tasks.spawn(async move {
            let served = ServerOptions {
                order,
                max_clients: 1,
                fc23: !missing.contains(&Missing::Fc23),
                fc43: !missing.contains(&Missing::Fc43),
            };
            if let Err(e) = modbus::serve_rtu(port, options.slave, shared, served).await {
                eprintln!("drivedeck sim: Modbus RTU server stopped: {e}");
            }
        });
    }
    if let Some(addr) = args.enip {
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
        let shared = shared.clone();
        tasks.spawn(async move {
            if let Err(e) = enip::serve(sockets, shared, options).await {
                eprintln!("drivedeck sim: EtherNet/IP adapter stopped: {e}");
            }
        });
    }
    if let Some(path) = &args.slcan {
        let device =
            crate::link::canopen::slcan::SlcanDevice::open(path).map_err(|e| e.to_string())?;
        outln!(
            "serving the simulated drive as CANopen node {} behind an emulated slcan adapter on {path}",
            args.node
        );
        let shared = shared.clone();
        let node = args.node;
        tasks.spawn(async move {
            if let Err(e) = crate::sim::server::canopen::run(device, node, shared).await {
                eprintln!("drivedeck sim: CANopen node on slcan stopped: {e}");
            }
        });
    }
    if let Some(iface) = &args.can {
        #[cfg(target_os = "linux")]
        {
            let bus = crate::link::canopen::socketcan::SocketCanBus::open(iface)
                .map_err(|e| e.to_string())?;
            outln!(
                "serving the simulated drive as CANopen node {} on {iface}",
                args.node
            );
            let shared = shared.clone();
            let node = args.node;
            tasks.spawn(async move {
                if let Err(e) = crate::sim::server::canopen::run(bus, node, shared).await {
                    eprintln!("drivedeck sim: CANopen node on SocketCAN stopped: {e}");
                }
            });
        }
        #[cfg(not(target_os = "linux"))]
        return Err(format!(
            "SocketCAN ({iface}) exists only on Linux: use --slcan PATH"
        ));
    }
    if args.verbose {
        let shared = shared.clone();
        tasks.spawn(async move {
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
        });
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
