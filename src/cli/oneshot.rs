//! One action against one drive: connect through the worker, do it, report, exit.

use std::process::ExitCode;
use std::sync::Arc;
use std::time::{Duration, Instant};

use super::context::Context;
use super::failure::{Failure, failed, usage};
use super::report::{self, Report};
use super::session::Session;
use super::stop::STOP_WAIT;
use super::{Command, DiscoverArgs, EXIT_FAILED, EXIT_USAGE, Via};
use crate::link::LinkSpec;
use crate::od::{self, Address, DataType, Value};
use crate::pdi::{Action, Opcode};
use crate::worker::{self, Event, ObjectPath, Request, Worker};

pub fn run(
    link: &LinkSpec,
    command: &Command,
    json: bool,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> ExitCode {
    match execute(link, command, timeout, trace, context) {
        Ok(report) => {
            report::print(&report, json);
            ExitCode::SUCCESS
        }
        Err(f) => {
            report::print_error(&f.message, json);
            ExitCode::from(f.code)
        }
    }
}

fn path(via: Via) -> ObjectPath {
    match via {
        Via::Auto => ObjectPath::Auto,
        Via::Pdi => ObjectPath::Pdi,
        Via::Native => ObjectPath::Native,
    }
}

fn action(opcode: Opcode, inputs: &[i64]) -> Result<Action, Failure> {
    Action::from_inputs(opcode, inputs).map_err(|e| usage(e.to_string()))
}

/// The PDI request a command makes, checked, and whether it waits for completion.
fn planned_request(command: &Command) -> Result<Option<(Request, bool)>, Failure> {
    Ok(match command {
        Command::MoveAbs(a) => Some((
            Request::Command(action(Opcode::MoveAbsolute, &[a.position, a.speed])?),
            a.wait,
        )),
        Command::MoveRel(a) => Some((
            Request::Command(action(Opcode::MoveRelative, &[a.position, a.speed])?),
            a.wait,
        )),
        Command::Velocity(a) => Some((
            Request::Command(action(Opcode::Velocity, &[a.speed])?),
            a.wait,
        )),
        Command::Torque(a) => Some((
            Request::Command(action(Opcode::Torque, &[a.torque, a.max_speed])?),
            a.wait,
        )),
        Command::Enable => Some((Request::Command(Action::Velocity { speed: 0 }), true)),
        Command::Halt(w) => Some((Request::Halt, w.wait)),
        Command::Resume(w) => Some((Request::Resume, w.wait)),
        Command::Quickstop => Some((Request::Command(Action::Quickstop), true)),
        Command::SwitchOff => Some((Request::Command(Action::SwitchOff), true)),
        Command::ClearError => Some((Request::Command(Action::ClearError), true)),
        Command::Home(a) => Some((
            Request::Command(action(Opcode::Homing, &[a.method])?),
            a.wait,
        )),
        Command::HomeHere(a) => Some((
            Request::Command(action(Opcode::HomeHere, &[a.position])?),
            true,
        )),
        Command::AutoSetup(w) => Some((Request::Command(Action::AutoSetup), w.wait)),
        Command::Status
        | Command::Read(_)
        | Command::Write(_)
        | Command::Scan
        | Command::Discover(_)
        | Command::Sim(_)
        | Command::Spectrum(_)
        | Command::Store
        | Command::Nanoj(_)
        | Command::Commission(_)
        | Command::Verify(_)
        | Command::InstallFiles { .. }
        | Command::Io
        | Command::Output(_)
        | Command::Defaults(_)
        | Command::Reboot
        | Command::Bench(_)
        | Command::TestMove(_)
        | Command::TestVelocity(_)
        | Command::Gains
        | Command::Record(_)
        | Command::Od(_)
        | Command::Project(_) => None,
    })
}

/// The value a `write` command writes, checked against the catalog's type and limits.
fn value_to_write(command: &Command) -> Result<Option<(DataType, Value)>, Failure> {
    Ok(match command {
        Command::Write(w) => {
            let dtype = w
                .dtype
                .or_else(|| od::builtin().get(w.address).map(|e| e.dtype))
                .ok_or_else(|| {
                    usage(format!(
                        "{} is not in the catalog: give its type with --type (e.g. --type u32)",
                        w.address
                    ))
                })?;
            let value =
                Value::parse(dtype, &w.value).map_err(|e| usage(format!("{}: {e}", w.address)))?;
            if let Some(entry) = od::builtin().get(w.address) {
                if !entry.access.writable() {
                    return Err(usage(format!(
                        "{} {} is read-only",
                        w.address,
                        entry.full_name()
                    )));
                }
                entry
                    .check(&value)
                    .map_err(|e| usage(format!("{}: {e}", w.address)))?;
            }
            Some((dtype, value))
        }
        _ => None,
    })
}

fn execute(
    link: &LinkSpec,
    command: &Command,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> Result<Report, Failure> {
    // Check the inputs before connecting: a typo never touches the drive.
    let planned = planned_request(command)?;
    let write_value = value_to_write(command)?;
    if let Command::Scan = command {
        return scan(link, timeout, trace);
    }
    refuse_still_moves(command)?;
    let mut session = Session::open(link, timeout, trace, context)?;
    if let Some((request, _)) = &planned {
        check_ramps(&mut session, request, timeout)?;
    }
    let mut report = match (command, planned) {
        (Command::Status, _) => {
            session.refresh();
            Report::Status(report::status(link, session.latest))
        }
        (Command::Read(r), _) => {
            let dtype = r
                .dtype
                .or_else(|| od::builtin().get(r.address).map(|e| e.dtype));
            let value = session.read(r.address, dtype, path(r.via), timeout)?;
            Report::Object(report::object(r.address, dtype, &value, false))
        }
        (Command::Write(w), _) => {
            let (dtype, value) = write_value.ok_or_else(|| usage("no value"))?;
            session.write(w.address, dtype, value.clone(), path(w.via), timeout)?;
            Report::Object(report::object(w.address, Some(dtype), &value, true))
        }
        (Command::Enable, Some((request, _))) => enable(&mut session, request, timeout)?,
        (Command::Torque(t), Some((request, wait))) => {
            torque_slope(&mut session, t.slope, timeout)?;
            motion(&mut session, request, wait, timeout)?
        }
        (command, Some((request, wait))) if moves(command) => {
            motion(&mut session, request, wait, timeout)?
        }
        (_, Some((request, wait))) => {
            let (what, image, progress) = session.command(request, wait, timeout)?;
            Report::Command(report::command(what, image, &progress))
        }
        (_, None) => return Err(usage("nothing to do")),
    };
    report.set_warnings(std::mem::take(&mut session.warnings));
    report.set_notes(std::mem::take(&mut session.notes));
    Ok(report)
}

/// `enable`: Profile Velocity at 0 rpm switches the power stage on and holds the motor
/// where it stands (PDI spec §2.2.2); the report says what the drive shows after. A motor
/// that turns is not touched: velocity 0 would brake it.
fn enable(session: &mut Session, request: Request, timeout: Duration) -> Result<Report, Failure> {
    session.refresh();
    if let Some(v) = session.latest.and_then(|s| s.velocity())
        && v.abs() >= crate::signal::AT_REST_RPM
    {
        return Err(failed(format!(
            "enable refused, nothing was sent: the motor turns at {v:.0} rpm and enable would brake it to 0 (halt or quickstop stops it)"
        )));
    }
    let (what, image, progress) = session.command(request, true, timeout)?;
    session.refresh();
    let mut command = report::command(what, image, &progress);
    command.drive = session.latest.map(|s| report::drive_after(&s));
    Ok(Report::Command(command))
}

/// Profile Torque's slope 6087h: set to `--slope`, or else checked, since the factory's 0
/// never builds up a torque (a warning, not a refusal).
fn torque_slope(
    session: &mut Session,
    slope: Option<u32>,
    timeout: Duration,
) -> Result<(), Failure> {
    let address = Address::new(0x6087, 0);
    if let Some(slope) = slope {
        return session.write(
            address,
            DataType::Unsigned32,
            Value::Uint(u64::from(slope)),
            ObjectPath::Auto,
            timeout,
        );
    }
    match session.read(address, Some(DataType::Unsigned32), ObjectPath::Auto, timeout) {
        Ok(v) if v.as_i128() == Some(0) => session.warnings.push(
            "torque slope 6087h is 0 (the factory value): the torque will not build up and the motor will not move; give --slope N (‰/s)".into(),
        ),
        Ok(_) => {}
        Err(e) => session.warnings.push(format!("could not check the torque slope: {}", e.message)),
    }
    Ok(())
}

/// Commands that start motion or wait on it: an interrupt, or a --wait that times out,
/// stops the drive by the `--on-exit` policy on the way out.
fn moves(command: &Command) -> bool {
    matches!(
        command,
        Command::MoveAbs(_)
            | Command::MoveRel(_)
            | Command::Velocity(_)
            | Command::Torque(_)
            | Command::Home(_)
            | Command::AutoSetup(_)
            | Command::Resume(_)
    )
}

/// Run a command that moves the motor: signals are caught while it runs, and whatever
/// ends it early (a signal, a --wait timed out) stops the drive first, saying how that
/// went. The exit code of an interrupt is 130.
fn motion(
    session: &mut Session,
    request: Request,
    wait: bool,
    timeout: Duration,
) -> Result<Report, Failure> {
    if let Err(e) = session.catch_signals() {
        session.warnings.push(format!(
            "{e}: Ctrl-C will end drivedeck without stopping the drive"
        ));
    }
    match session.command(request, wait, timeout) {
        Ok((what, image, progress)) => Ok(Report::Command(report::command(what, image, &progress))),
        Err(f) if f.stop => {
            let done = session.stop_drive(session.on_exit(), timeout.min(STOP_WAIT));
            Err(f.and(done))
        }
        Err(f) => Err(f),
    }
}

/// A move that cannot move, refused before anything is sent: a max speed of 0 (for a
/// torque command, with a torque to apply: torque 0 at speed 0 is a way to hold still).
fn refuse_still_moves(command: &Command) -> Result<(), Failure> {
    let (what, flag) = match command {
        Command::MoveAbs(a) if a.speed == 0 => ("move-abs", "--speed N"),
        Command::MoveRel(a) if a.speed == 0 => ("move-rel", "--speed N"),
        Command::Torque(t) if t.max_speed == 0 && t.torque != 0 => ("torque", "--max-speed N"),
        _ => return Ok(()),
    };
    Err(usage(format!(
        "{what}: a max speed of 0 rpm never moves the motor; nothing was sent (give {flag}, rpm)"
    )))
}

/// 6083h profile acceleration and 6084h profile deceleration: a profile move or velocity
/// with either at 0 never starts, or once started never brakes (not even for a halt).
const RAMPS: [(Address, &str); 2] = [
    (Address::new(0x6083, 0), "profile acceleration 6083h"),
    (Address::new(0x6084, 0), "profile deceleration 6084h"),
];

/// Refuse a profile move or velocity, before anything is sent, when the drive's ramps
/// are 0. A ramp that cannot be read is a warning only.
fn check_ramps(session: &mut Session, request: &Request, timeout: Duration) -> Result<(), Failure> {
    let what = match request {
        Request::Command(Action::MoveAbsolute { .. }) => "move-abs",
        Request::Command(Action::MoveRelative { .. }) => "move-rel",
        Request::Command(Action::Velocity { speed }) if *speed != 0 => "velocity",
        _ => return Ok(()),
    };
    for (address, name) in RAMPS {
        match session.try_read(
            address,
            Some(DataType::Unsigned32),
            ObjectPath::Auto,
            timeout,
        )? {
            Ok(value) if value.as_i128() == Some(0) => {
                return Err(failed(format!(
                    "{what} refused, nothing was sent: the {name} is 0 on the drive, so the motor would {} (set it first, e.g. `drivedeck write {:04X} 1000`)",
                    if address.index == 0x6083 {
                        "never start"
                    } else {
                        "never brake, not even for a halt"
                    },
                    address.index
                )));
            }
            Ok(_) => {}
            Err(e) => session
                .warnings
                .push(format!("could not check the {name}: {e}")),
        }
    }
    Ok(())
}

/// `drivedeck discover`: EtherNet/IP adapters by ListIdentity.
pub fn discover(args: &DiscoverArgs, json: bool) -> ExitCode {
    let runtime = match tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
    {
        Ok(runtime) => runtime,
        Err(e) => {
            eprintln!("drivedeck discover: cannot start the runtime: {e}");
            return ExitCode::from(EXIT_FAILED);
        }
    };
    let discovery = crate::link::enip::discovery::Discovery {
        port: args.port,
        interface: args.interface.clone(),
        unicast: args.host.iter().cloned().collect(),
        wait: Duration::from_secs_f64(args.wait.clamp(0.1, 60.0)),
        ..Default::default()
    };
    match runtime.block_on(crate::link::enip::discovery::discover(&discovery)) {
        Ok(devices) => {
            let place = match (&args.interface, &args.host) {
                (Some(i), _) => format!("EtherNet/IP on {i}"),
                (None, Some(h)) => format!("EtherNet/IP on every interface and at {h}"),
                (None, None) => "EtherNet/IP on every interface".to_owned(),
            };
            let mut scan = report::scan(&LinkSpec::Sim, devices);
            scan.bus = place;
            report::print(&Report::Scan(scan), json);
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("drivedeck discover: {e}");
            ExitCode::from(EXIT_USAGE)
        }
    }
}

/// A bus scan through the worker, without connecting to a node.
fn scan(link: &LinkSpec, timeout: Duration, trace: bool) -> Result<Report, Failure> {
    let worker = Worker::spawn(
        worker::Config {
            reconnect: false,
            trace,
            ..worker::Config::default()
        },
        Arc::new(|| {}),
    )
    .map_err(|e| usage(format!("cannot start the worker thread: {e}")))?;
    let id = worker
        .send(Request::Scan(link.clone()))
        .map_err(|e| usage(e.to_string()))?;
    let deadline = Instant::now() + timeout;
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        match worker.recv_timeout(left) {
            Ok(Event::Frames(frames)) => super::session::print_frames(&frames),
            Ok(Event::Scanned { id: i, result }) if i == id => {
                return result
                    .map(|devices| Report::Scan(report::scan(link, devices)))
                    .map_err(|e| usage(e.to_string()));
            }
            Ok(_) => {}
            Err(_) => return Err(failed("the scan did not finish in time")),
        }
    }
}
