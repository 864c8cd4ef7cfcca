//! The Procedure tab's model: a procedure file loaded and checked, run on the drive shown
//! by the same runner as `drivedeck commission` (`procedure::runner`), its steps' states
//! and figures as they come, the operator's questions, and the record written when it
//! ends. Esc (or Abort, or leaving the drive) aborts it: the drive halts and the record
//! says so.
//!
//! A model: no egui here.

use std::path::PathBuf;
use std::sync::Arc;

use crate::procedure::record::{self, Record, RunInfo};
use crate::procedure::runner::{DriveRun, DriveSetup, Prompt};
use crate::procedure::{Kind, Procedure};
use crate::ui::panel::PanelModel;
use crate::worker::{Event, Request};

/// The Procedure tab of one drive.
#[derive(Debug, Default)]
pub struct ProcedurePanel {
    /// The procedure file, as typed.
    pub path: String,
    /// Where the record goes (HTML; the JSON beside it).
    pub record_path: String,
    /// Who runs it (empty: the user logged in).
    pub operator: String,
    pub procedure: Option<Arc<Procedure>>,
    /// What loading, starting or the last run said.
    pub message: Option<Result<String, String>>,
    run: Option<DriveRun>,
    started: String,
    machine: String,
    rehearsal: bool,
    /// The last run's record.
    pub record: Option<Record>,
    /// Where the last run's record page was written.
    pub written: Option<PathBuf>,
    connected: bool,
    now: f64,
}

impl PanelModel for ProcedurePanel {
    fn on_event(&mut self, event: &Event) {
        match event {
            Event::Connected(_) => self.connected = true,
            Event::Disconnected { .. } => self.connected = false,
            _ => {}
        }
        if let Some(run) = self.run.as_mut() {
            run.on_event(event);
        }
    }

    fn on_reply(&mut self, tag: u64, event: &Event) -> bool {
        match self.run.as_mut() {
            Some(run) => run.on_reply(tag, event),
            None => true,
        }
    }

    fn take_requests(&mut self) -> Vec<(u64, Request)> {
        self.run
            .as_mut()
            .map(DriveRun::take_requests)
            .unwrap_or_default()
    }

    fn tick(&mut self, now: f64) {
        self.now = now;
        if let Some(run) = self.run.as_mut() {
            run.tick(now);
        }
        if self.run.as_ref().is_some_and(DriveRun::is_over) {
            self.finish();
        }
    }

    fn holding(&self) -> Vec<String> {
        if self.is_running() {
            vec!["A commissioning procedure is running: it is aborted (the drive halted)".into()]
        } else {
            vec![]
        }
    }

    fn let_go(&mut self) {
        self.abort("the drive is being disconnected");
    }
}

impl ProcedurePanel {
    pub fn is_running(&self) -> bool {
        self.run.as_ref().is_some_and(|r| !r.is_over())
    }

    pub fn is_connected(&self) -> bool {
        self.connected
    }

    /// The run under way (or the last, until the next starts).
    pub fn run(&self) -> Option<&DriveRun> {
        self.run.as_ref()
    }

    pub fn prompt(&self) -> Option<&Prompt> {
        self.run.as_ref().and_then(DriveRun::prompt)
    }

    /// Load and check the file at `path`.
    pub fn load(&mut self) {
        let path = PathBuf::from(self.path.trim());
        match Procedure::load(&path) {
            Ok(p) => {
                self.message = Some(Ok(format!(
                    "{}: {} step(s), checked",
                    p.name,
                    p.steps.len()
                )));
                if self.record_path.trim().is_empty() {
                    let stem = path
                        .file_stem()
                        .map_or("procedure".into(), |s| s.to_string_lossy().into_owned());
                    self.record_path = format!("{stem}-record.html");
                }
                self.procedure = Some(Arc::new(p));
            }
            Err(e) => {
                self.procedure = None;
                self.message = Some(Err(e.to_string()));
            }
        }
    }

    /// Start the procedure on the drive: `setup` says what the project knows of it,
    /// `machine` names it for the record. Refused (with why) while not connected, with no
    /// procedure loaded, a run under way, or a backup a step needs missing.
    pub fn start(&mut self, mut setup: DriveSetup, machine: String) {
        if self.is_running() {
            return;
        }
        let Some(procedure) = self.procedure.clone() else {
            self.message = Some(Err("load a procedure first".into()));
            return;
        };
        if !self.connected {
            self.message = Some(Err("not connected: nothing runs".into()));
            return;
        }
        for (i, step) in procedure.steps.iter().enumerate() {
            let Kind::ApplyBackup { file } = &step.kind else {
                continue;
            };
            let backup = match file {
                Some(file) => {
                    // `{drive}` is the name made a file name, as on the command line.
                    let stem = crate::project::file_stem(&setup.name);
                    let path = procedure.backup_path(file, &stem);
                    crate::od::backup::Backup::load(&path).map_err(|e| {
                        format!(
                            "step {} (line {}): {}: {e}",
                            i + 1,
                            step.line,
                            path.display()
                        )
                    })
                }
                None => setup.baseline.clone().ok_or_else(|| {
                    format!(
                        "step {} (line {}): the project holds no backup of {} to apply",
                        i + 1,
                        step.line,
                        setup.name
                    )
                }),
            };
            match backup {
                Ok(b) => {
                    setup.backups.insert(i, b);
                }
                Err(why) => {
                    self.message = Some(Err(format!("nothing ran: {why}")));
                    return;
                }
            }
        }
        self.rehearsal = setup.rehearsal;
        self.machine = machine;
        self.started = crate::telemetry::utc_text(std::time::SystemTime::now());
        self.record = None;
        self.message = Some(Ok(format!("{} started", procedure.name)));
        let mut run = DriveRun::new(procedure, setup);
        run.link_up();
        run.tick(self.now);
        self.run = Some(run);
    }

    pub fn answer(&mut self, yes: bool) {
        if let Some(run) = self.run.as_mut() {
            run.answer(yes);
        }
    }

    /// Abort the run under way (the drive halts; the record says why).
    pub fn abort(&mut self, why: &str) {
        if let Some(run) = self.run.as_mut()
            && !run.is_over()
        {
            run.abort(why);
            self.finish();
        }
    }

    /// The run ended: its record made and written.
    fn finish(&mut self) {
        let Some(run) = self.run.as_ref() else {
            return;
        };
        if self.record.is_some() {
            return;
        }
        let Some(drive) = run.record().cloned() else {
            return;
        };
        let operator = if self.operator.trim().is_empty() {
            record::os_user()
        } else {
            self.operator.trim().to_owned()
        };
        let record = Record::new(
            run.procedure(),
            RunInfo {
                machine: self.machine.clone(),
                operator,
                started: self.started.clone(),
                finished: crate::telemetry::utc_text(std::time::SystemTime::now()),
                rehearsal: self.rehearsal,
            },
            vec![drive],
        );
        let path = PathBuf::from(self.record_path.trim());
        self.written = None;
        self.message = Some(match record.write(&path) {
            Ok(json) => {
                // Whole, for the browser (a relative path is the window's working folder's).
                self.written = Some(std::path::absolute(&path).unwrap_or_else(|_| path.clone()));
                let line = format!(
                    "{}: {} — record {} (and {})",
                    record.procedure,
                    record.verdict.word(),
                    path.display(),
                    json.display()
                );
                if record.verdict == crate::procedure::Verdict::Passed {
                    Ok(line)
                } else {
                    Err(line)
                }
            }
            Err(e) => Err(format!("the run ended {}, but {e}", record.verdict.word())),
        });
        self.record = Some(record);
    }
}
