//! Projects on the command line: `--project FILE --drive NAME` puts a project's drive
//! where `--link` would be (with the drive's options, unless the command line gives its
//! own); `--project FILE status` prints every drive as one table, `--project FILE od dump
//! DIR` writes one backup per drive; `project new`, `project check`, `project show`.
//!
//! Every drive is reported, one way or the other: a drive that cannot be reached is a row
//! (or a line) saying why, and the others go on. Exit codes: 0 when every drive did what
//! was asked, 1 when any did not (the rows say which), 2 for bad usage or a project file
//! that cannot be opened.

use std::path::Path;
use std::process::ExitCode;
use std::time::Duration;

use serde::Serialize;

use super::context::Context;
use super::failure::{Failure, failed, usage};
use super::od::backup_cmd;
use super::report::{self, StatusReport, print_error, print_json, print_lines};
use super::session::Session;
use super::{
    Cli, Command, EXIT_FAILED, OdArgs, OdCommand, OdDumpArgs, ProjectArgs, ProjectCheckArgs,
    ProjectCommand, ProjectNewArgs,
};
use crate::link::LinkSpec;
use crate::od::backup::{DeviceIdentity, IDENTITY};
use crate::project::check::{self, DriveCheck, Verdict};
use crate::project::{self, Drive, Project, ProjectError};
use crate::signal::AT_REST_RPM;

/// What `--project` (or `drivedeck PROJECT.json`) asks for.
pub(super) enum Target {
    /// No project: `--link` as before.
    None,
    /// The window, on this project (and, with --drive, that drive).
    Window {
        project: Project,
        path: std::path::PathBuf,
        drive: Option<Drive>,
    },
    /// A one-shot command on one drive of the project.
    Drive(Drive),
    /// `status` or `od dump DIR` on every drive of this project (with --drive, one).
    Every(Project),
}

/// The project file at `path`, opened and checked; its error names the file.
pub(super) fn load(path: &Path) -> Result<Project, Failure> {
    project::open(path).map_err(|e| match e {
        ProjectError::Read { .. } | ProjectError::TooLarge { .. } | ProjectError::NotAFile(_) => {
            usage(e.to_string())
        }
        _ => usage(format!("{}: {e}", path.display())),
    })
}

/// The command's name, as typed.
fn command_name(command: &Command) -> &'static str {
    match command {
        Command::Status => "status",
        Command::Read(_) => "read",
        Command::Write(_) => "write",
        Command::MoveAbs(_) => "move-abs",
        Command::MoveRel(_) => "move-rel",
        Command::Velocity(_) => "velocity",
        Command::Torque(_) => "torque",
        Command::Enable => "enable",
        Command::Halt(_) => "halt",
        Command::Resume(_) => "resume",
        Command::Quickstop => "quickstop",
        Command::SwitchOff => "switch-off",
        Command::ClearError => "clear-error",
        Command::Home(_) => "home",
        Command::HomeHere(_) => "home-here",
        Command::AutoSetup(_) => "auto-setup",
        Command::Scan => "scan",
        Command::Discover(_) => "discover",
        Command::Sim(_) => "sim",
        Command::Spectrum(_) => "spectrum",
        Command::Store => "store",
        Command::Nanoj(_) => "nanoj",
        Command::Commission(_) => "commission",
        Command::Verify(_) => "verify",
        Command::InstallFiles { .. } => "install-files",
        Command::Io => "io",
        Command::Output(_) => "output",
        Command::Defaults(_) => "defaults",
        Command::Reboot => "reboot",
        Command::Record(_) => "record",
        Command::Bench(_) => "bench",
        Command::TestMove(_) => "test-move",
        Command::TestVelocity(_) => "test-velocity",
        Command::Gains => "gains",
        Command::Od(_) => "od",
        Command::Project(_) => "project",
    }
}

/// What the command line's project flags ask for.
pub(super) fn target(cli: &Cli) -> Result<Target, Failure> {
    let path = match (&cli.project, &cli.open, &cli.command) {
        (None, None, _) => return Ok(Target::None),
        (Some(_), Some(open), _) => {
            return Err(usage(format!(
                "give the project once: --project FILE or {} alone, not both",
                open.display()
            )));
        }
        (None, Some(open), Some(command)) => {
            return Err(usage(format!(
                "{}: a project is given to a command with --project {} (and --drive NAME)",
                command_name(command),
                open.display()
            )));
        }
        (None, Some(open), None) => open,
        (Some(path), None, _) => path,
    };
    let project = load(path)?;
    let drive = match &cli.drive {
        Some(name) => Some(
            project
                .drive(name)
                .cloned()
                .map_err(|e| usage(format!("{}: {e}", path.display())))?,
        ),
        None => None,
    };
    let Some(command) = &cli.command else {
        if let Err(e) = project::recent::remember(path) {
            eprintln!("warning: the project will not reopen by itself next time: {e}");
        }
        return Ok(Target::Window {
            project,
            path: path.clone(),
            drive,
        });
    };
    let every = matches!(command, Command::Status)
        || matches!(command, Command::Od(OdArgs { command: OdCommand::Dump(d) }) if d.dir.is_some());
    match (command, drive) {
        (
            Command::Sim(_)
            | Command::Discover(_)
            | Command::Project(_)
            | Command::Spectrum(_)
            | Command::Verify(_),
            _,
        ) => Err(usage(format!(
            "{} does not use --project or --drive",
            command_name(command)
        ))),
        (Command::Status, Some(drive)) => Ok(Target::Drive(drive)),
        (_, Some(drive)) if every => Ok(Target::Every(Project {
            drives: vec![drive],
            plot: None,
        })),
        (_, Some(drive)) => Ok(Target::Drive(drive)),
        (_, None) if every => Ok(Target::Every(project)),
        (
            Command::Od(OdArgs {
                command: OdCommand::Dump(_),
            }),
            None,
        ) => Err(usage(format!(
            "od dump on a project: give a folder for one backup per drive (od dump DIR), or --drive NAME and --out FILE.json (the project's drives: {})",
            project.names()
        ))),
        (_, None) => Err(usage(format!(
            "{} talks to one drive: give --drive NAME (the project's drives: {})",
            command_name(command),
            project.names()
        ))),
    }
}

/// `status` or `od dump DIR` on every drive of `project`.
pub(super) fn every_drive(project: &Project, cli: &Cli, context: &Context) -> ExitCode {
    let timeout = super::timeout(cli);
    match &cli.command {
        Some(Command::Status) => status(project, cli.json, timeout, cli.trace, context),
        Some(Command::Od(OdArgs {
            command: OdCommand::Dump(args),
        })) => dump(project, args, cli.json, timeout, cli.trace, context),
        _ => {
            print_error("only status and od dump DIR cover every drive", cli.json);
            ExitCode::from(super::EXIT_USAGE)
        }
    }
}

/// `f` for every drive at once, each on its own thread (a drive that does not answer
/// does not hold the others up); the results in the project's order.
fn each_drive<T: Send>(drives: &[Drive], f: impl Fn(&Drive) -> T + Sync) -> Vec<T> {
    std::thread::scope(|scope| {
        let f = &f;
        let handles: Vec<_> = drives
            .iter()
            .map(|drive| scope.spawn(move || f(drive)))
            .collect();
        handles
            .into_iter()
            .zip(drives)
            .map(|(handle, drive)| match handle.join() {
                Ok(result) => result,
                // A panic is a bug; the others still report.
                Err(_) => std::panic::resume_unwind(Box::new(format!(
                    "the thread of drive {} panicked",
                    drive.name
                ))),
            })
            .collect()
    })
}

/// The identity a drive reports now (1018h and its names), or why it did not answer.
fn identify(
    link: &LinkSpec,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> Result<DeviceIdentity, String> {
    let mut session = Session::open(link, timeout, trace, context).map_err(|f| f.message)?;
    read_identity(&mut session, timeout)
}

fn read_identity(session: &mut Session, timeout: Duration) -> Result<DeviceIdentity, String> {
    let (reads, failure) = session.read_many(IDENTITY.to_vec(), timeout, |_, _| {});
    match failure {
        Some(f) => Err(f.message),
        None => Ok(DeviceIdentity::from_reads(&reads)),
    }
}

/// A check's verdict in a few words, for a table's column.
fn verdict_words(check: &DriveCheck) -> String {
    match &check.verdict {
        Verdict::Same => "same device".into(),
        Verdict::NotRecorded(_) => "not recorded".into(),
        Verdict::NoAnswer(reason) => format!("no answer ({reason})"),
        Verdict::Changed(changes) => changes
            .iter()
            .map(ToString::to_string)
            .collect::<Vec<_>>()
            .join(", "),
    }
}

/// One drive's row of `--project FILE status`.
#[derive(Serialize, Debug)]
struct DriveStatus {
    name: String,
    link: String,
    /// Whether the drive answered (then `error` is null).
    reached: bool,
    /// Its CiA 402 state.
    state: Option<&'static str>,
    /// 603Fh, when not 0.
    error_code: Option<u16>,
    /// 603Fh in words, when not 0.
    fault: Option<String>,
    /// Actual position, 0.1°.
    position: Option<f64>,
    /// Actual velocity, rpm.
    velocity: Option<f64>,
    moving: Option<bool>,
    /// The device against the identity the project stores.
    device: Option<String>,
    /// Why the drive could not be reached.
    error: Option<String>,
    /// What `status` prints for one drive.
    status: Option<StatusReport>,
}

#[derive(Serialize, Debug)]
struct ProjectStatus {
    drives: Vec<DriveStatus>,
    /// How many drives could not be reached.
    unreachable: usize,
}

fn drive_status(drive: &Drive, timeout: Duration, trace: bool, context: &Context) -> DriveStatus {
    let mut row = DriveStatus {
        name: drive.name.clone(),
        link: drive.link.to_string(),
        reached: false,
        state: None,
        error_code: None,
        fault: None,
        position: None,
        velocity: None,
        moving: None,
        device: None,
        error: None,
        status: None,
    };
    let mut session = match Session::open(&drive.link, timeout, trace, context) {
        Ok(session) => session,
        Err(f) => {
            row.error = Some(f.message);
            return row;
        }
    };
    session.refresh();
    let mut status = report::status(&drive.link, session.latest);
    let check = check::check(
        drive,
        read_identity(&mut session, timeout)
            .as_ref()
            .map_err(String::as_str),
    );
    status.warnings = std::mem::take(&mut session.warnings);
    status.notes = std::mem::take(&mut session.notes);
    status.notes.extend(session.take_notes());
    row.reached = true;
    row.state = status.state;
    if status.error_code != 0 {
        row.error_code = Some(status.error_code);
        row.fault = Some(format!(
            "{:04X}h {}",
            status.error_code, status.error_meaning
        ));
    }
    row.position = status.position;
    row.velocity = status.velocity;
    row.moving = status.velocity.map(|v| v.abs() >= AT_REST_RPM);
    row.device = Some(verdict_words(&check));
    if let Verdict::Changed(_) = check.verdict {
        status.warnings.push(format!(
            "not the device the project saw: {}",
            verdict_words(&check)
        ));
    }
    row.status = Some(status);
    row
}

/// `--project FILE status`: every drive as one table.
fn status(
    project: &Project,
    json: bool,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> ExitCode {
    let drives = each_drive(&project.drives, |d| {
        drive_status(d, timeout, trace, context)
    });
    for row in &drives {
        if let Some(status) = &row.status {
            let name = |line: &String| format!("{}: {line}", row.name);
            print_lines(
                &status.notes.iter().map(name).collect::<Vec<_>>(),
                &status.warnings.iter().map(name).collect::<Vec<_>>(),
            );
        }
    }
    let unreachable = drives.iter().filter(|d| !d.reached).count();
    let report = ProjectStatus {
        drives,
        unreachable,
    };
    if json {
        print_json(&report, "status");
    } else {
        print_table(&report.drives);
    }
    if unreachable == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(EXIT_FAILED)
    }
}

fn print_table(rows: &[DriveStatus]) {
    let head = [
        "drive", "link", "state", "fault", "position", "moving", "device",
    ];
    let cells: Vec<Vec<String>> = rows
        .iter()
        .map(|r| match &r.error {
            Some(error) => vec![
                r.name.clone(),
                r.link.clone(),
                format!("unreachable: {error}"),
            ],
            None => vec![
                r.name.clone(),
                r.link.clone(),
                r.state.unwrap_or("unknown").to_owned(),
                r.fault.clone().unwrap_or_else(|| "none".into()),
                r.position.map_or("-".into(), |p| format!("{p:.0}")),
                r.moving
                    .map_or("-", |m| if m { "yes" } else { "no" })
                    .to_owned(),
                r.device.clone().unwrap_or_default(),
            ],
        })
        .collect();
    // Widths from the rows that have every column; a reason runs to the line's end.
    let mut widths: Vec<usize> = head.iter().map(|h| h.chars().count()).collect();
    for row in cells.iter().filter(|r| r.len() == head.len()) {
        for (w, cell) in widths.iter_mut().zip(row) {
            *w = (*w).max(cell.chars().count());
        }
    }
    for row in cells.iter().filter(|r| r.len() < head.len()) {
        for (w, cell) in widths.iter_mut().zip(&row[..2]) {
            *w = (*w).max(cell.chars().count());
        }
    }
    let line = |row: &[String]| {
        let last = row.len() - 1;
        let text: Vec<String> = row
            .iter()
            .enumerate()
            .map(|(i, cell)| {
                if i == last {
                    cell.clone()
                } else {
                    format!("{cell:<w$}", w = widths[i])
                }
            })
            .collect();
        outln!("{}", text.join("  "));
    };
    line(&head.map(str::to_owned));
    for row in &cells {
        line(row);
    }
}

/// One drive's part of `--project FILE od dump DIR`.
#[derive(Serialize)]
struct DriveDump {
    name: String,
    link: String,
    file: String,
    saved: bool,
    dump: Option<backup_cmd::DumpReport>,
    /// Why nothing was saved.
    error: Option<String>,
}

#[derive(Serialize)]
struct ProjectDump {
    folder: String,
    drives: Vec<DriveDump>,
}

/// `--project FILE od dump DIR`: one backup per drive, named after the drive.
fn dump(
    project: &Project,
    args: &OdDumpArgs,
    json: bool,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> ExitCode {
    match dump_all(project, args, json, timeout, trace, context) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::from(EXIT_FAILED),
        Err(f) => {
            print_error(&f.message, json);
            ExitCode::from(f.code)
        }
    }
}

fn dump_all(
    project: &Project,
    args: &OdDumpArgs,
    json: bool,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> Result<bool, Failure> {
    let dir = args
        .dir
        .as_deref()
        .ok_or_else(|| usage("od dump with --project needs a folder: od dump DIR"))?;
    // Two names that make one file name would overwrite each other: refused first.
    let stems: Vec<String> = project.drives.iter().map(Drive::file_stem).collect();
    for (i, stem) in stems.iter().enumerate() {
        if let Some(j) = stems[..i].iter().position(|s| s.eq_ignore_ascii_case(stem)) {
            return Err(usage(format!(
                "drives \"{}\" and \"{}\" would both be saved as {stem}.json: rename one",
                project.drives[j].name, project.drives[i].name
            )));
        }
    }
    std::fs::create_dir_all(dir)
        .map_err(|e| failed(format!("cannot make the folder {}: {e}", dir.display())))?;
    let mut warnings = vec![];
    let catalog = backup_cmd::dictionary(args.eds.as_deref(), args.node, &mut warnings)?;
    print_lines(&[], &warnings);
    let mut drives = vec![];
    for (drive, stem) in project.drives.iter().zip(&stems) {
        let out = dir.join(format!("{stem}.json"));
        let (dump, error) =
            match backup_cmd::dump_to(&drive.link, &catalog, &out, timeout, trace, context) {
                Ok(dump) => (Some(dump), None),
                Err(f) => (None, Some(f.message)),
            };
        if let Some(d) = &dump {
            let name = |line: &String| format!("{}: {line}", drive.name);
            print_lines(&d.notes.iter().map(name).collect::<Vec<_>>(), &[]);
        }
        drives.push(DriveDump {
            name: drive.name.clone(),
            link: drive.link.to_string(),
            file: out.display().to_string(),
            saved: dump.is_some(),
            dump,
            error,
        });
    }
    let complete = drives
        .iter()
        .all(|d| d.dump.as_ref().is_some_and(|r| r.unreadable.is_empty()));
    let report = ProjectDump {
        folder: dir.display().to_string(),
        drives,
    };
    if json {
        print_json(&report, "dump");
    } else {
        for d in &report.drives {
            match (&d.dump, &d.error) {
                (Some(r), _) => {
                    outln!(
                        "{}: saved {} settings of {} to {}",
                        d.name,
                        r.objects,
                        r.identity.summary(),
                        d.file
                    );
                    for (address, reason) in &r.unreadable {
                        outln!("{}: not saved: {address}: {reason}", d.name);
                    }
                }
                (None, Some(error)) => outln!("{}: nothing saved: {error}", d.name),
                (None, None) => outln!("{}: nothing saved", d.name),
            }
        }
    }
    Ok(complete)
}

/// `drivedeck project …`.
pub(super) fn run(args: &ProjectArgs, cli: &Cli, context: &Context) -> ExitCode {
    let timeout = super::timeout(cli);
    let outcome = match &args.command {
        ProjectCommand::New(new) => make(new, cli.json, timeout, cli.trace, context),
        ProjectCommand::Check(check) => check_drives(check, cli.json, timeout, cli.trace, context),
        ProjectCommand::Show(show) => load(&show.file).map(|p| {
            show_project(&p, cli.json);
            true
        }),
        ProjectCommand::Backup(backup) => {
            back_up(&backup.file, cli.json, timeout, cli.trace, context)
        }
    };
    match outcome {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::from(EXIT_FAILED),
        Err(f) => {
            print_error(&f.message, cli.json);
            ExitCode::from(f.code)
        }
    }
}

/// One drive's part of `project backup`.
#[derive(Serialize)]
struct DriveBackup {
    name: String,
    /// Settings saved; null when the drive could not be read.
    objects: Option<usize>,
    /// Settings that could not be read, with the reason.
    unreadable: Vec<(String, String)>,
    error: Option<String>,
}

/// `project backup FILE`: every drive's settings into the project, one drive after the
/// other (each with its progress bar); written once, after the last.
fn back_up(
    file: &Path,
    json: bool,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> Result<bool, Failure> {
    let mut project = load(file)?;
    let catalog = crate::od::builtin().clone();
    let mut rows = vec![];
    for drive in &mut project.drives {
        let row = match backup_cmd::read_backup(&drive.link, &catalog, timeout, trace, context) {
            Ok((backup, _, notes)) => {
                let name = |line: &String| format!("{}: {line}", drive.name);
                print_lines(&notes.iter().map(name).collect::<Vec<_>>(), &[]);
                let row = DriveBackup {
                    name: drive.name.clone(),
                    objects: Some(backup.objects.len()),
                    unreadable: backup.unreadable.clone(),
                    error: None,
                };
                drive.identity = Some(backup.identity.clone());
                drive.backup = Some(backup);
                row
            }
            Err(f) => DriveBackup {
                name: drive.name.clone(),
                objects: None,
                unreadable: vec![],
                error: Some(f.message),
            },
        };
        rows.push(row);
    }
    if rows.iter().any(|r| r.objects.is_some()) {
        project::save(&project, file).map_err(|e| failed(e.to_string()))?;
    }
    if json {
        print_json(&rows, "backup");
    } else {
        for row in &rows {
            match (&row.objects, &row.error) {
                (Some(n), _) => outln!("{}: {n} settings saved in {}", row.name, file.display()),
                (None, Some(e)) => outln!("{}: not backed up, the old backup stays: {e}", row.name),
                (None, None) => outln!("{}: not backed up", row.name),
            }
            for (address, reason) in &row.unreadable {
                outln!("{}: not saved: {address}: {reason}", row.name);
            }
        }
    }
    Ok(rows
        .iter()
        .all(|r| r.objects.is_some() && r.unreadable.is_empty()))
}

/// `NAME=CONNECTION` as a drive.
fn parse_drive(text: &str) -> Result<Drive, Failure> {
    let (name, link) = text.split_once('=').ok_or_else(|| {
        usage(format!(
            "'{text}': give a drive as NAME=CONNECTION, e.g. \"X axis=modbus-tcp://192.168.2.100:502\""
        ))
    })?;
    let name = name.trim();
    if let Some(problem) = project::name_problem(name) {
        return Err(usage(format!(
            "'{}': the name {problem}",
            crate::text::shown(text)
        )));
    }
    let link: LinkSpec = link
        .parse()
        .map_err(|e| usage(format!("drive \"{name}\": {e}")))?;
    Ok(Drive::new(name, link))
}

/// `project new FILE NAME=URL…`.
fn make(
    args: &ProjectNewArgs,
    json: bool,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> Result<bool, Failure> {
    let drives = args
        .drives
        .iter()
        .map(|d| parse_drive(d))
        .collect::<Result<Vec<_>, _>>()?;
    let mut project = Project::new(drives).map_err(|e| usage(e.to_string()))?;
    if args.file.exists() && !args.force {
        return Err(usage(format!(
            "{} exists: give --force to replace it",
            args.file.display()
        )));
    }
    if args.identify {
        let found = each_drive(&project.drives, |d| {
            identify(&d.link, timeout, trace, context)
        });
        let mut silent = vec![];
        for (drive, identity) in project.drives.iter_mut().zip(found) {
            match identity {
                Ok(identity) => drive.identity = Some(identity),
                Err(reason) => silent.push(format!("{}: no answer ({reason})", drive.name)),
            }
        }
        if !silent.is_empty() {
            return Err(failed(format!(
                "nothing was written: {}",
                silent.join("; ")
            )));
        }
    }
    project::save(&project, &args.file).map_err(|e| failed(e.to_string()))?;
    if json {
        print_json(&ShownProject::of(&project, &args.file), "project");
    } else {
        outln!(
            "wrote {} with {} drives",
            args.file.display(),
            project.drives.len()
        );
        show_project(&project, false);
    }
    Ok(true)
}

#[derive(Serialize)]
struct CheckRow {
    name: String,
    /// `same`, `changed`, `no answer` or `not recorded`.
    verdict: &'static str,
    text: String,
}

#[derive(Serialize)]
struct CheckReport {
    drives: Vec<CheckRow>,
    /// With --update: the project file written.
    updated: Option<String>,
}

/// `project check FILE [--update]`.
fn check_drives(
    args: &ProjectCheckArgs,
    json: bool,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> Result<bool, Failure> {
    let mut project = load(&args.file)?;
    let found = each_drive(&project.drives, |d| {
        identify(&d.link, timeout, trace, context)
    });
    let checks: Vec<DriveCheck> = project
        .drives
        .iter()
        .zip(&found)
        .map(|(d, now)| check::check(d, now.as_ref().map_err(String::as_str)))
        .collect();
    let mut updated = None;
    if args.update {
        for (drive, now) in project.drives.iter_mut().zip(found) {
            if let Ok(identity) = now {
                drive.identity = Some(identity);
            }
        }
        project::save(&project, &args.file).map_err(|e| failed(e.to_string()))?;
        updated = Some(args.file.display().to_string());
    }
    let report = CheckReport {
        drives: checks
            .iter()
            .map(|c| CheckRow {
                name: c.name.clone(),
                verdict: match c.verdict {
                    Verdict::Same => "same",
                    Verdict::Changed(_) => "changed",
                    Verdict::NoAnswer(_) => "no answer",
                    Verdict::NotRecorded(_) => "not recorded",
                },
                text: c.to_string(),
            })
            .collect(),
        updated,
    };
    if json {
        print_json(&report, "check");
    } else {
        for row in &report.drives {
            outln!("{}", row.text);
        }
        if let Some(file) = &report.updated {
            outln!("stored the identities seen now in {file}");
        }
    }
    Ok(checks.iter().all(DriveCheck::is_same))
}

/// A project as `project show` and `project new` print it.
#[derive(Serialize)]
struct ShownProject {
    file: Option<String>,
    drives: Vec<ShownDrive>,
    plot_layout: bool,
}

#[derive(Serialize)]
struct ShownDrive {
    name: String,
    link: String,
    options: project::DriveOptions,
    watch: Vec<String>,
    identity: Option<DeviceIdentity>,
    backup_objects: Option<usize>,
}

impl ShownProject {
    fn of(project: &Project, file: &Path) -> ShownProject {
        ShownProject {
            file: Some(file.display().to_string()),
            drives: project
                .drives
                .iter()
                .map(|d| ShownDrive {
                    name: d.name.clone(),
                    link: d.link.to_string(),
                    options: d.options.clone(),
                    watch: d.watch.iter().map(|p| p.address.to_string()).collect(),
                    identity: d.identity.clone(),
                    backup_objects: d.backup.as_ref().map(|b| b.objects.len()),
                })
                .collect(),
            plot_layout: project.plot.is_some(),
        }
    }
}

fn show_project(project: &Project, json: bool) {
    if json {
        let mut shown = ShownProject::of(project, Path::new(""));
        shown.file = None;
        print_json(&shown, "project");
        return;
    }
    for d in &project.drives {
        outln!("{}  {}", d.name, d.link);
        outln!(
            "    poll {} Hz, on link loss {:?}, lost after {} failed exchanges",
            d.options.poll_rate,
            d.options.on_link_loss,
            d.options.lost_after
        );
        if !d.watch.is_empty() {
            let pins: Vec<String> = d.watch.iter().map(|p| p.address.to_string()).collect();
            outln!("    watches {}", pins.join(", "));
        }
        match &d.identity {
            Some(identity) => outln!("    last seen: {}", identity.summary()),
            None => outln!("    last seen: never asked"),
        }
        if let Some(backup) = &d.backup {
            outln!("    backup of {} settings", backup.objects.len());
        }
    }
}
