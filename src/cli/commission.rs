//! `drivedeck commission PROCEDURE.toml (--link URL | --project F [--drive NAME])
//! --record OUT.html [--answers FILE] [--rehearse] [--operator NAME]`: a procedure run on
//! one drive, or on every drive of a project in turn (or those named), its record written
//! as a self-contained HTML page and a JSON file beside it. Exit 0 when every step passed
//! (or was skipped), 1 when any failed or a run aborted on its own (a lost link, a stop
//! from elsewhere), 130 when interrupted (Ctrl-C: the drive is halted and the record says
//! the run was aborted).
//!
//! The procedure is read and checked, and every backup it names loaded, before anything
//! moves. With `--rehearse` (and for `--link sim`) simulated drives served on loopback
//! Modbus TCP stand in for the project's, same names, same steps, so a procedure is proven
//! before it touches a machine — restarts included.

use std::collections::BTreeMap;
use std::io::{BufRead, IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::time::{Duration, Instant};

use clap::Args;

use super::context::Context;
use super::failure::{Failure, failed, usage};
use super::report;
use super::session::Session;
use crate::link::LinkSpec;
use crate::od::backup::Backup;
use crate::procedure::record::{self, DriveRecord, Record, RunInfo, StepRecord, Verdict};
use crate::procedure::runner::{DriveRun, DriveSetup, Prompt};
use crate::procedure::{Kind, Procedure};
use crate::project::Project;
use crate::sim::server::ServerThread;

#[derive(Args, Debug, Clone)]
pub struct CommissionArgs {
    /// The procedure file (TOML; see assets/procedures/ for a commented example).
    pub procedure: PathBuf,
    /// Where the record goes: an HTML page, and the same data as JSON beside it
    /// (OUT.json).
    #[arg(long, value_name = "OUT.html")]
    pub record: PathBuf,
    /// Answers to the operator's questions, one per line ("yes" or "no", in the order
    /// asked; # starts a comment): for rehearsals and tests. Without it the questions are
    /// asked on the terminal.
    #[arg(long, value_name = "FILE")]
    pub answers: Option<PathBuf>,
    /// Run against simulated drives standing in for the project's (same names, same
    /// steps): the procedure proven before it touches the machine.
    #[arg(long)]
    pub rehearse: bool,
    /// Who runs it, for the record (default: the user logged in).
    #[arg(long)]
    pub operator: Option<String>,
    /// The project's drives to commission, by name, comma-separated (default: every drive,
    /// or the one of --drive).
    #[arg(long, value_name = "NAMES")]
    pub drives: Option<String>,
}

/// The answers to the operator's questions.
enum Answers {
    /// From a file, in order.
    File { path: PathBuf, left: Vec<bool> },
    /// Asked on the terminal.
    Terminal,
    /// Neither: every question fails, named.
    None,
}

impl Answers {
    fn load(path: Option<&Path>) -> Result<Answers, Failure> {
        let Some(path) = path else {
            return Ok(if std::io::stdin().is_terminal() {
                Answers::Terminal
            } else {
                Answers::None
            });
        };
        let text = std::fs::read_to_string(path)
            .map_err(|e| usage(format!("cannot read the answers {}: {e}", path.display())))?;
        let mut left = vec![];
        for (n, line) in text.lines().enumerate() {
            let line = line.split('#').next().unwrap_or("").trim().to_lowercase();
            match line.as_str() {
                "" => {}
                "yes" | "y" => left.push(true),
                "no" | "n" => left.push(false),
                other => {
                    return Err(usage(format!(
                        "{}, line {}: {other:?} is no answer: write yes or no",
                        path.display(),
                        n + 1
                    )));
                }
            }
        }
        left.reverse();
        Ok(Answers::File {
            path: path.to_path_buf(),
            left,
        })
    }

    /// The answer to `question`, or why there is none.
    fn next(&mut self, question: &str) -> Result<bool, String> {
        match self {
            Answers::File { path, left } => left
                .pop()
                .ok_or_else(|| format!("the answers file {} has no answer left", path.display())),
            Answers::Terminal => loop {
                eprint!("? {question} [yes/no] ");
                let _ = std::io::stderr().flush();
                let mut line = String::new();
                match std::io::stdin().lock().read_line(&mut line) {
                    Ok(0) | Err(_) => return Err("the terminal closed".into()),
                    Ok(_) => match line.trim().to_lowercase().as_str() {
                        "yes" | "y" => return Ok(true),
                        "no" | "n" => return Ok(false),
                        _ => eprintln!("  answer yes or no"),
                    },
                }
            },
            Answers::None => Err("no --answers file, and no terminal to ask on".into()),
        }
    }
}

/// One drive to commission: its name, where it is reached, what the project knows.
struct Target {
    name: String,
    link: LinkSpec,
    setup: DriveSetup,
}

fn now_utc() -> String {
    crate::telemetry::utc_text(std::time::SystemTime::now())
}

/// The backups the procedure's steps write for `drive`, loaded (refused before anything
/// moves when one is missing or unreadable).
fn backups_for(
    procedure: &Procedure,
    drive: Option<&crate::project::Drive>,
    name: &str,
) -> Result<BTreeMap<usize, Backup>, Failure> {
    let mut loaded = BTreeMap::new();
    for (i, step) in procedure.steps.iter().enumerate() {
        let Kind::ApplyBackup { file } = &step.kind else {
            continue;
        };
        let backup = match file {
            Some(file) => {
                let stem = drive.map_or_else(|| name.to_owned(), |d| d.file_stem());
                let path = procedure.backup_path(file, &stem);
                Backup::load(&path).map_err(|e| {
                    usage(format!(
                        "{}, line {} (step {}): the backup for {name} cannot be used: {}: {e}",
                        procedure.path.display(),
                        step.line,
                        i + 1,
                        path.display()
                    ))
                })?
            }
            None => drive.and_then(|d| d.backup.clone()).ok_or_else(|| {
                usage(format!(
                    "{}, line {} (step {}): apply-backup without a file takes the project's backup, and {name} has none (save one with the window's Backup, or give file = \"…\")",
                    procedure.path.display(),
                    step.line,
                    i + 1
                ))
            })?,
        };
        loaded.insert(i, backup);
    }
    Ok(loaded)
}

/// The drives to commission, each with its setup.
fn targets(
    procedure: &Procedure,
    link: Option<&LinkSpec>,
    project: Option<&Project>,
    names: Option<Vec<String>>,
    rehearse: bool,
    on_abort: crate::worker::LinkLossAction,
) -> Result<Vec<Target>, Failure> {
    if let Some(project) = project {
        let chosen: Vec<&crate::project::Drive> = match names {
            Some(names) => names
                .iter()
                .map(|n| project.drive(n).map_err(|e| usage(e.to_string())))
                .collect::<Result<_, _>>()?,
            None => project.drives.iter().collect(),
        };
        return chosen
            .into_iter()
            .map(|d| {
                Ok(Target {
                    name: d.name.clone(),
                    link: d.link.clone(),
                    setup: DriveSetup {
                        name: d.name.clone(),
                        link: d.link.to_string(),
                        expected: d.identity.clone(),
                        baseline: d.backup.clone(),
                        backups: backups_for(procedure, Some(d), &d.name)?,
                        rehearsal: rehearse,
                        on_abort,
                    },
                })
            })
            .collect();
    }
    let link = link.cloned().unwrap_or(LinkSpec::Sim);
    let name = "drive".to_owned();
    Ok(vec![Target {
        setup: DriveSetup {
            name: name.clone(),
            link: link.to_string(),
            expected: None,
            baseline: None,
            backups: backups_for(procedure, None, &name)?,
            rehearsal: rehearse,
            on_abort,
        },
        name,
        link,
    }])
}

/// How one drive's run ended besides its record.
enum Ended {
    Done,
    Interrupted(Failure),
}

/// Run `target` to its record: the runner driven through a session of its own.
fn run_drive(
    procedure: &Arc<Procedure>,
    target: Target,
    answers: &mut Answers,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> (DriveRecord, Ended) {
    let mut run = DriveRun::new(procedure.clone(), target.setup);
    eprintln!("commissioning {} ({})", target.name, target.link);
    let mut session = match Session::open(&target.link, timeout, trace, context) {
        Ok(s) => s,
        Err(f) => {
            run.abort(&format!("could not connect: {}", f.message));
            return (finished(&mut run), Ended::Done);
        }
    };
    run.link_up();
    let start = Instant::now();
    let mut routes: BTreeMap<u64, u64> = BTreeMap::new();
    let mut shown_prompt: Option<Prompt> = None;
    let mut reported = 0;
    loop {
        run.tick(start.elapsed().as_secs_f64());
        for (tag, request) in run.take_requests() {
            match session.send_request(request) {
                Ok(id) => {
                    routes.insert(id, tag);
                }
                Err(f) => run.abort(&f.message),
            }
        }
        while reported < run.steps.len() {
            print_step(&run.steps[reported]);
            reported += 1;
        }
        if run.is_over() {
            break;
        }
        match run.prompt().cloned() {
            Some(Prompt::Question(q)) => {
                match answers.next(&q) {
                    Ok(yes) => {
                        eprintln!("? {q} {}", if yes { "yes" } else { "no" });
                        run.answer(yes);
                    }
                    Err(why) => run.no_answer(&why),
                }
                continue;
            }
            Some(Prompt::Action(text))
                if shown_prompt.as_ref() != Some(&Prompt::Action(text.clone())) =>
            {
                eprintln!("→ {text}");
                shown_prompt = Some(Prompt::Action(text));
            }
            _ => {}
        }
        match session.poll(Duration::from_millis(20)) {
            Ok(Some(event)) => {
                if let Some(id) = event.reply_id()
                    && let Some(&tag) = routes.get(&id)
                    && run.on_reply(tag, &event)
                {
                    routes.remove(&id);
                }
                let lost = matches!(event, crate::worker::Event::Disconnected { .. });
                run.on_event(&event);
                if lost && run.expects_restart() {
                    // The drive restarts: open the link again as the `reboot` command does.
                    drop(session);
                    routes.clear();
                    match reopen(&target.link, &mut run, start, timeout, trace, context) {
                        Some(s) => session = s,
                        None => return (finished(&mut run), Ended::Done),
                    }
                } else if lost && !run.is_over() {
                    run.abort("the link was lost");
                }
            }
            Ok(None) => {}
            Err(f) if f.signal.is_some() => {
                run.abort(&f.message);
                // The halt goes out before the session closes.
                for (_, request) in run.take_requests() {
                    let _ = session.send_request(request);
                }
                let until = Instant::now() + Duration::from_secs(2);
                while Instant::now() < until {
                    match session.poll(Duration::from_millis(50)) {
                        Ok(Some(crate::worker::Event::Progress { progress, .. }))
                            if progress.is_final() =>
                        {
                            break;
                        }
                        Err(_) => break,
                        _ => {}
                    }
                }
                while reported < run.steps.len() {
                    print_step(&run.steps[reported]);
                    reported += 1;
                }
                return (finished(&mut run), Ended::Interrupted(f));
            }
            Err(f) => {
                run.abort(&f.message);
                return (finished(&mut run), Ended::Done);
            }
        }
    }
    (finished(&mut run), Ended::Done)
}

/// Open the link again after a restart, until it answers or the runner's wait runs out.
fn reopen(
    link: &LinkSpec,
    run: &mut DriveRun,
    start: Instant,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> Option<Session> {
    std::thread::sleep(Duration::from_millis(500));
    loop {
        run.tick(start.elapsed().as_secs_f64());
        if !run.expects_restart() {
            // The wait ran out (the runner failed the step and went on without a link).
            return None;
        }
        match Session::open(link, timeout.min(Duration::from_secs(2)), trace, context) {
            Ok(session) => {
                run.link_up();
                return Some(session);
            }
            Err(_) => std::thread::sleep(Duration::from_millis(250)),
        }
    }
}

/// The runner's record, made if the run ended without one.
fn finished(run: &mut DriveRun) -> DriveRecord {
    if run.record().is_none() {
        run.abort("the run ended early");
    }
    run.record().cloned().unwrap_or_else(|| DriveRecord {
        name: run.name().to_owned(),
        link: String::new(),
        identity: vec![],
        steps: run.steps.clone(),
        differs_from_factory: vec![],
        differs_from_baseline: None,
        timeline: vec![],
        verdict: Verdict::Aborted,
    })
}

fn print_step(step: &StepRecord) {
    let figures: Vec<String> = step
        .figures
        .iter()
        .map(|f| match &f.limit {
            Some(l) => format!("{} {} (limit {l})", f.name, f.shown()),
            None => format!("{} {}", f.name, f.shown()),
        })
        .collect();
    eprintln!(
        "  {:>2}. [{}] {}: {}{}",
        step.number,
        step.verdict.word(),
        step.title,
        step.note,
        if figures.is_empty() {
            String::new()
        } else {
            format!(" — {}", figures.join("; "))
        }
    );
}

/// Simulated drives served on loopback Modbus TCP, one per target, standing in for them.
fn stand_ins(targets: &mut [Target]) -> Result<Vec<ServerThread>, Failure> {
    let mut servers = vec![];
    for target in targets.iter_mut() {
        let server = ServerThread::modbus_tcp(
            std::net::SocketAddr::from(([127, 0, 0, 1], 0)),
            crate::sim::server::modbus::ServerOptions::default(),
        )
        .map_err(|e| failed(format!("cannot serve a simulated drive: {e}")))?;
        let stand_in: LinkSpec = format!("modbus-tcp://{}", server.addr)
            .parse()
            .map_err(|e| failed(format!("the simulated drive's link: {e}")))?;
        target.setup.link = format!(
            "rehearsal: simulated drive on {stand_in}, standing in for {}",
            target.link
        );
        target.link = stand_in;
        servers.push(server);
    }
    Ok(servers)
}

#[allow(clippy::too_many_arguments)]
pub(super) fn run(
    args: &CommissionArgs,
    link: Option<&LinkSpec>,
    project: Option<(&Path, &Project)>,
    drive: Option<&str>,
    json: bool,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> ExitCode {
    let fail = |f: Failure| {
        report::print_error(&f.message, json);
        ExitCode::from(f.code)
    };
    let procedure = match Procedure::load(&args.procedure) {
        Ok(p) => Arc::new(p),
        Err(e) => return fail(usage(e.to_string())),
    };
    let mut answers = match Answers::load(args.answers.as_deref()) {
        Ok(a) => a,
        Err(f) => return fail(f),
    };
    let names = match (&args.drives, drive) {
        (Some(list), _) => Some(
            list.split(',')
                .map(|n| n.trim().to_owned())
                .filter(|n| !n.is_empty())
                .collect(),
        ),
        (None, Some(one)) => Some(vec![one.to_owned()]),
        (None, None) => None,
    };
    if project.is_none() && names.is_some() {
        return fail(usage(
            "--drives and --drive name a project's drives: give --project FILE",
        ));
    }
    let rehearse = args.rehearse;
    let on_abort = context.policy.on_exit;
    let mut targets = match targets(
        &procedure,
        link,
        project.map(|p| p.1),
        names,
        rehearse,
        on_abort,
    ) {
        Ok(t) => t,
        Err(f) => return fail(f),
    };
    // The in-process simulated drive would not outlive a restart: serve it instead. No
    // hand presses its switches: its inputs are forced, as in a rehearsal.
    for target in &mut targets {
        if target.link == LinkSpec::Sim {
            target.setup.rehearsal = true;
        }
    }
    let serve = rehearse || targets.iter().any(|t| t.link == LinkSpec::Sim);
    let _servers = if serve {
        match stand_ins(&mut targets) {
            Ok(s) => s,
            Err(f) => return fail(f),
        }
    } else {
        vec![]
    };
    // Any drive a simulated one stands in for makes the run a rehearsal in its record.
    let rehearsal = rehearse || targets.iter().any(|t| t.setup.rehearsal);
    let started = now_utc();
    let machine = match project {
        Some((path, _)) => format!("project {}", path.display()),
        None => format!("link {}", link.cloned().unwrap_or(LinkSpec::Sim)),
    };
    let mut drives = vec![];
    let mut interrupted = None;
    for target in targets {
        if interrupted.is_some() {
            break;
        }
        let (record, ended) = run_drive(&procedure, target, &mut answers, timeout, trace, context);
        if let Ended::Interrupted(f) = ended {
            interrupted = Some(f);
        }
        drives.push(record);
    }
    let record = Record::new(
        &procedure,
        RunInfo {
            machine,
            operator: args.operator.clone().unwrap_or_else(record::os_user),
            started,
            finished: now_utc(),
            rehearsal,
        },
        drives,
    );
    let verdict = record.verdict;
    let json_path = match record.write(&args.record) {
        Ok(p) => p,
        Err(e) => return fail(failed(e)),
    };
    if json {
        report::print_json(&record, "commissioning record");
    } else {
        println!(
            "{}: {} — record {} (and {})",
            record.procedure,
            record.verdict.word(),
            args.record.display(),
            json_path.display()
        );
    }
    match (interrupted, verdict) {
        (Some(f), _) => ExitCode::from(f.code),
        (None, Verdict::Passed | Verdict::Skipped) => ExitCode::SUCCESS,
        // Aborted by itself (a lost link, a stop from elsewhere): a failure, not Ctrl-C.
        (None, Verdict::Aborted | Verdict::Failed) => ExitCode::from(super::EXIT_FAILED),
    }
}
