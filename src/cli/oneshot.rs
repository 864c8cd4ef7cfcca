//! One action against one drive: connect through the worker, do it, report, exit.

use std::collections::BTreeMap;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::{Duration, Instant};

use super::report::{self, Report};
use super::{Command, DiscoverArgs, EXIT_FAILED, EXIT_USAGE, Via};
use crate::link::LinkSpec;
use crate::od::{self, Address, DataType, Value};
use crate::pdi::{Action, Opcode, Timing};
use crate::worker::{self, CommandProgress, Event, ObjectPath, Request, Sample, Worker};

/// Why a one-shot command did not succeed: the message and the exit code.
pub(super) struct Failure {
    pub(super) code: u8,
    pub(super) message: String,
}

pub(super) fn usage(message: impl Into<String>) -> Failure {
    Failure {
        code: EXIT_USAGE,
        message: message.into(),
    }
}

pub(super) fn failed(message: impl Into<String>) -> Failure {
    Failure {
        code: EXIT_FAILED,
        message: message.into(),
    }
}

pub fn run(
    link: &LinkSpec,
    command: &Command,
    json: bool,
    timeout: Duration,
    trace: bool,
) -> ExitCode {
    match execute(link, command, timeout, trace) {
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

/// The session of one command.
pub(super) struct Session {
    worker: Worker,
    latest: Option<Sample>,
    warnings: Vec<String>,
    notes: Vec<String>,
}

impl Session {
    pub(super) fn open(
        link: &LinkSpec,
        timeout: Duration,
        trace: bool,
    ) -> Result<Session, Failure> {
        Session::open_at(link, timeout, trace, 200.0)
    }

    /// A session whose worker polls (and samples) `poll_rate` times a second.
    pub(super) fn open_at(
        link: &LinkSpec,
        timeout: Duration,
        trace: bool,
        poll_rate: f64,
    ) -> Result<Session, Failure> {
        let config = worker::Config {
            poll_rate,
            timing: Timing {
                ack_timeout: timeout.min(Duration::from_secs(5)),
                done_timeout: Some(timeout),
                ..Timing::default()
            },
            reconnect: false,
            trace,
            ..worker::Config::default()
        };
        let worker = Worker::spawn(config, Arc::new(|| {}))
            .map_err(|e| usage(format!("cannot start the worker thread: {e}")))?;
        let mut session = Session {
            worker,
            latest: None,
            warnings: vec![],
            notes: vec![],
        };
        session.send(Request::Connect(link.clone()))?;
        let deadline = Instant::now() + timeout;
        loop {
            match session.next(deadline)? {
                Event::Connected(_) => break,
                Event::ConnectFailed { error, .. } => {
                    return Err(usage(format!("cannot connect to {link}: {error}")));
                }
                _ => {}
            }
        }
        // A status before anything else: commands are judged against it.
        while session.latest.is_none() {
            session.next(deadline)?;
        }
        Ok(session)
    }

    /// Hand the worker a request without waiting for its outcome.
    pub(super) fn send_request(&self, request: Request) -> Result<u64, Failure> {
        self.send(request)
    }

    /// The next event (samples included) before `deadline`.
    pub(super) fn next_event(&mut self, deadline: Instant) -> Result<Event, Failure> {
        self.next(deadline)
    }

    fn send(&self, request: Request) -> Result<u64, Failure> {
        self.worker
            .send(request)
            .map_err(|e| usage(format!("the worker refused the request: {e}")))
    }

    /// The next event before `deadline`, keeping the newest sample.
    fn next(&mut self, deadline: Instant) -> Result<Event, Failure> {
        let left = deadline.saturating_duration_since(Instant::now());
        let event = self
            .worker
            .recv_timeout(left)
            .map_err(|_| failed("no answer from the drive in time (raise --timeout?)"))?;
        match &event {
            Event::Samples(samples) => {
                for sample in samples {
                    self.latest = Some(match &self.latest {
                        Some(older) => sample.merged_over(older),
                        None => *sample,
                    });
                }
            }
            Event::Disconnected {
                reason: Some(reason),
            } => {
                return Err(failed(format!("the link was lost: {reason}")));
            }
            Event::Notice(text) => self.notes.push(text.clone()),
            Event::Frames(frames) => {
                for f in frames {
                    eprintln!(
                        "{} {:<24} {}",
                        if f.sent { "tx" } else { "rx" },
                        f.raw,
                        f.text
                    );
                }
            }
            _ => {}
        }
        Ok(event)
    }

    /// Send a PDI request and wait for acceptance, or completion with `wait`.
    fn command(
        &mut self,
        request: Request,
        wait: bool,
        timeout: Duration,
    ) -> Result<(String, Option<[u8; 8]>, CommandProgress), Failure> {
        let what = request.to_string();
        let id = self.send(request)?;
        let deadline = Instant::now() + timeout + Duration::from_secs(1);
        let mut image = None;
        loop {
            match self.next(deadline)? {
                Event::Rejected { id: i, reason, .. } if i == id => {
                    return Err(failed(format!("{what}: {reason}")));
                }
                Event::Sent {
                    id: i, image: sent, ..
                } if i == id => image = Some(sent.to_bytes()),
                Event::Progress { id: i, progress } if i == id => {
                    if !progress.is_success() {
                        return Err(failed(format!("{what}: {progress}")));
                    }
                    if progress.is_final() || !wait {
                        return Ok((what, image, progress));
                    }
                }
                _ => {}
            }
        }
    }

    fn read(
        &mut self,
        address: Address,
        dtype: Option<DataType>,
        path: ObjectPath,
        timeout: Duration,
    ) -> Result<Value, Failure> {
        self.try_read(address, dtype, path, timeout)?
            .map_err(|e| failed(format!("read {address}: {e}")))
    }

    /// Read an object, keeping a refusal (the device's or the worker's: `Ok(Err(text))`)
    /// apart from a broken link or a timeout (`Err`).
    pub(super) fn try_read(
        &mut self,
        address: Address,
        dtype: Option<DataType>,
        path: ObjectPath,
        timeout: Duration,
    ) -> Result<Result<Value, String>, Failure> {
        let id = self.send(Request::ReadObject {
            address,
            dtype,
            path,
        })?;
        let deadline = Instant::now() + timeout;
        loop {
            match self.next(deadline)? {
                Event::ObjectRead { id: i, result, .. } if i == id => return Ok(result),
                Event::Rejected { id: i, reason, .. } if i == id => return Ok(Err(reason)),
                _ => {}
            }
        }
    }

    /// Read many objects in one queued request, in order; `progress(done, total)` after
    /// each. A refusal stays with its object. A broken link or a stalled read (no answer
    /// within `timeout` of the previous one) ends the reading: the objects read until then
    /// come back with the failure.
    pub(super) fn read_many(
        &mut self,
        objects: Vec<(Address, DataType)>,
        timeout: Duration,
        mut progress: impl FnMut(usize, usize),
    ) -> (BTreeMap<Address, Result<Value, String>>, Option<Failure>) {
        let total = objects.len();
        let mut reads = BTreeMap::new();
        if total == 0 {
            return (reads, None);
        }
        let id = match self.send(Request::ReadMany {
            objects,
            path: ObjectPath::Auto,
        }) {
            Ok(id) => id,
            Err(f) => return (reads, Some(f)),
        };
        let mut deadline = Instant::now() + timeout;
        while reads.len() < total {
            match self.next(deadline) {
                Ok(Event::ObjectRead {
                    id: i,
                    address,
                    result,
                }) if i == id => {
                    reads.insert(address, result);
                    progress(reads.len(), total);
                    deadline = Instant::now() + timeout;
                }
                Ok(Event::Rejected { id: i, reason, .. }) if i == id => {
                    return (
                        reads,
                        Some(failed(format!("reading {total} objects: {reason}"))),
                    );
                }
                Ok(_) => {}
                Err(f) => {
                    let _ = self.send(Request::Cancel(id));
                    return (reads, Some(f));
                }
            }
        }
        (reads, None)
    }

    /// Write an object, keeping a refusal (`Ok(Err(text))`) apart from a broken link or a
    /// timeout (`Err`).
    pub(super) fn try_write(
        &mut self,
        address: Address,
        dtype: DataType,
        value: Value,
        timeout: Duration,
    ) -> Result<Result<(), String>, Failure> {
        let id = self.send(Request::WriteObject {
            address,
            dtype,
            value,
            path: ObjectPath::Auto,
        })?;
        let deadline = Instant::now() + timeout;
        loop {
            match self.next(deadline)? {
                Event::ObjectWritten { id: i, result, .. } if i == id => return Ok(result),
                Event::Rejected { id: i, reason, .. } if i == id => return Ok(Err(reason)),
                _ => {}
            }
        }
    }

    /// Notices the worker gave (fallbacks, mapping changes), for the report.
    pub(super) fn take_notes(&mut self) -> Vec<String> {
        std::mem::take(&mut self.notes)
    }

    fn write(
        &mut self,
        address: Address,
        dtype: DataType,
        value: Value,
        path: ObjectPath,
        timeout: Duration,
    ) -> Result<(), Failure> {
        let shown = value.to_string();
        let id = self.send(Request::WriteObject {
            address,
            dtype,
            value,
            path,
        })?;
        let deadline = Instant::now() + timeout;
        loop {
            match self.next(deadline)? {
                Event::ObjectWritten { id: i, result, .. } if i == id => {
                    return result.map_err(|e| failed(format!("write {shown} to {address}: {e}")));
                }
                Event::Rejected { id: i, reason, .. } if i == id => {
                    return Err(failed(format!("write {shown} to {address}: {reason}")));
                }
                _ => {}
            }
        }
    }

    /// Let a few more samples arrive, so a status printed after a command shows its effect.
    fn refresh(&mut self) {
        let deadline = Instant::now() + Duration::from_millis(60);
        while self.next(deadline).is_ok() {}
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

fn execute(
    link: &LinkSpec,
    command: &Command,
    timeout: Duration,
    trace: bool,
) -> Result<Report, Failure> {
    // Check the inputs before connecting: a typo never touches the drive.
    let planned: Option<(Request, bool)> = match command {
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
        | Command::Bench(_)
        | Command::Record(_)
        | Command::Od(_) => None,
    };
    let write_value = match command {
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
    };

    if let Command::Scan = command {
        return scan(link, timeout);
    }
    let mut session = Session::open(link, timeout, trace)?;
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
        (Command::Torque(t), Some((request, wait))) => {
            if let Some(slope) = t.slope {
                session.write(
                    Address::new(0x6087, 0),
                    DataType::Unsigned32,
                    Value::Uint(u64::from(slope)),
                    ObjectPath::Auto,
                    timeout,
                )?;
            } else {
                match session.read(Address::new(0x6087, 0), Some(DataType::Unsigned32), ObjectPath::Auto, timeout) {
                    Ok(v) if v.as_i128() == Some(0) => session.warnings.push(
                        "torque slope 6087h is 0 (the factory value): the torque will not build up and the motor will not move; give --slope N (‰/s)".into(),
                    ),
                    Ok(_) => {}
                    Err(e) => session.warnings.push(format!("could not check the torque slope: {}", e.message)),
                }
            }
            let (what, image, progress) = session.command(request, wait, timeout)?;
            Report::Command(report::command(what, image, &progress))
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
fn scan(link: &LinkSpec, timeout: Duration) -> Result<Report, Failure> {
    let worker = Worker::spawn(
        worker::Config {
            reconnect: false,
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
            Ok(Event::Scanned { id: i, result }) if i == id => {
                return result
                    .map(|devices| Report::Scan(report::scan(link, devices)))
                    .map_err(usage);
            }
            Ok(_) => {}
            Err(_) => return Err(failed("the scan did not finish in time")),
        }
    }
}
