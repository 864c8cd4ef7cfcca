//! Files the way a desktop application handles them: the system's open and save dialogs,
//! asked on a thread of their own so the window never waits; names that say which device
//! and when; a confirmation before a file is replaced; and the folder of a saved file
//! opened in the file manager. Tests answer the dialogs through [`ScriptedPicker`].
//!
//! A model: no egui here (a dialog's answer wakes the window through a [`Wake`]).

use std::collections::VecDeque;
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

/// What a dialog is asked: open or save, its title, where it starts, the name it
/// proposes and the kinds of file it lists.
#[derive(Clone, Debug, PartialEq)]
pub struct Ask {
    pub save: bool,
    pub title: String,
    pub directory: Option<PathBuf>,
    /// The proposed file name (save dialogs).
    pub name: String,
    /// (description, extensions without the dot)
    pub filters: Vec<(String, Vec<String>)>,
}

/// What a dialog answered.
#[derive(Clone, Debug, PartialEq)]
pub enum Picked {
    File(PathBuf),
    Cancelled,
    /// No dialog could be shown (no desktop portal, no zenity): why, in words.
    NoDialog(String),
}

/// Where a dialog's answer goes.
pub type Answer = Arc<Mutex<Option<Picked>>>;

/// A native dialog that comes back empty sooner than this was never on screen: nobody
/// cancels a dialog in a fifth of a second.
const NO_DIALOG_WITHIN: std::time::Duration = std::time::Duration::from_millis(200);

/// Wakes the window when a thread left something for it (a dialog's answer).
pub type Wake = Arc<dyn Fn() + Send + Sync>;

/// Shows the open and save dialogs. `pick` must not block the window: the answer comes
/// later through `answer`, and `wake` is called when it is there.
pub trait FilePicker: Send + Sync + fmt::Debug {
    fn pick(&self, ask: Ask, answer: Answer, wake: Wake);
}

/// The system's dialogs (the XDG desktop portal on Linux, no GTK needed), each on a
/// thread of its own.
#[derive(Debug, Default)]
pub struct NativePicker;

impl FilePicker for NativePicker {
    fn pick(&self, ask: Ask, answer: Answer, wake: Wake) {
        let reply = answer.clone();
        let spawned = std::thread::Builder::new()
            .name("file dialog".into())
            .spawn(move || {
                let asked = std::time::Instant::now();
                let mut dialog = rfd::FileDialog::new().set_title(&ask.title);
                if let Some(dir) = &ask.directory {
                    dialog = dialog.set_directory(dir);
                }
                for (what, extensions) in &ask.filters {
                    dialog = dialog.add_filter(what, extensions);
                }
                let picked = if ask.save {
                    dialog.set_file_name(&ask.name).save_file()
                } else {
                    dialog.pick_file()
                };
                let picked = match picked {
                    Some(path) => Picked::File(path),
                    None if asked.elapsed() < NO_DIALOG_WITHIN => Picked::NoDialog(
                        "no file dialog could be shown: it needs the XDG desktop portal \
                         (xdg-desktop-portal with a GTK, GNOME or KDE back end) or zenity"
                            .into(),
                    ),
                    None => Picked::Cancelled,
                };
                put(&answer, picked);
                wake();
            });
        if let Err(e) = spawned {
            put(
                &reply,
                Picked::NoDialog(format!("no thread for the file dialog: {e}")),
            );
        }
    }
}

/// What a thread left in `slot` for the window, taken out (once).
pub fn take<T>(slot: &Mutex<Option<T>>) -> Option<T> {
    slot.lock().ok().and_then(|mut s| s.take())
}

fn put(answer: &Answer, picked: Picked) {
    if let Ok(mut slot) = answer.lock() {
        *slot = Some(picked);
    }
}

/// The environment variable that answers the window's file dialogs from a script: the
/// paths the dialogs pick, in order, separated as in `PATH` (headless runs, demos, and
/// under Xvfb where no desktop portal runs).
pub const ANSWERS_VARIABLE: &str = "DRIVEDECK_FILE_ANSWERS";

/// The dialogs the window uses: the system's, or those answered by
/// [`ANSWERS_VARIABLE`] when it is set.
pub fn picker() -> Arc<dyn FilePicker> {
    match std::env::var_os(ANSWERS_VARIABLE) {
        Some(paths) => {
            let scripted = ScriptedPicker::new();
            for path in std::env::split_paths(&paths) {
                scripted.answer(Some(path));
            }
            scripted
        }
        None => Arc::new(NativePicker),
    }
}

/// Dialogs answered from a script (for tests, and for scripts driving the window): each
/// `pick` takes the next answer queued (none left: cancelled) and remembers what it was
/// asked.
#[derive(Debug, Default)]
pub struct ScriptedPicker {
    answers: Mutex<VecDeque<Picked>>,
    asked: Mutex<Vec<Ask>>,
}

impl ScriptedPicker {
    pub fn new() -> Arc<ScriptedPicker> {
        Arc::default()
    }

    /// The next dialog picks `path` (`None`: the user cancels it).
    pub fn answer(&self, path: Option<PathBuf>) {
        if let Ok(mut answers) = self.answers.lock() {
            answers.push_back(path.map_or(Picked::Cancelled, Picked::File));
        }
    }

    /// The next dialog cannot be shown (no desktop portal), for `why`.
    pub fn answer_no_dialog(&self, why: &str) {
        if let Ok(mut answers) = self.answers.lock() {
            answers.push_back(Picked::NoDialog(why.to_owned()));
        }
    }

    /// Every dialog asked so far, oldest first.
    pub fn asked(&self) -> Vec<Ask> {
        self.asked.lock().map(|a| a.clone()).unwrap_or_default()
    }
}

impl FilePicker for ScriptedPicker {
    fn pick(&self, ask: Ask, answer: Answer, wake: Wake) {
        let next = self
            .answers
            .lock()
            .ok()
            .and_then(|mut answers| answers.pop_front())
            .unwrap_or(Picked::Cancelled);
        if let Ok(mut asked) = self.asked.lock() {
            asked.push(ask);
        }
        put(&answer, next);
        wake();
    }
}

/// A dialog that could not be shown, asked in the window instead: what it was asked, why
/// the system's could not show, the path as typed, and where the answer goes.
pub struct Prompt {
    pub ask: Ask,
    pub why: String,
    pub text: String,
    answer: Answer,
    wake: Wake,
}

impl fmt::Debug for Prompt {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Prompt")
            .field("ask", &self.ask)
            .field("why", &self.why)
            .field("text", &self.text)
            .finish_non_exhaustive()
    }
}

impl Prompt {
    /// The path typed: the dialog's answer.
    pub fn pick(self) -> Option<PathBuf> {
        let text = self.text.trim();
        if text.is_empty() {
            return None;
        }
        let path = PathBuf::from(text);
        put(&self.answer, Picked::File(path.clone()));
        (self.wake)();
        Some(path)
    }

    /// Nothing: the dialog's answer is "cancelled".
    pub fn cancel(self) {
        put(&self.answer, Picked::Cancelled);
        (self.wake)();
    }
}

/// The prompts waiting to be shown, oldest first.
pub type Prompts = Arc<Mutex<VecDeque<Prompt>>>;

/// The system's dialogs, with the window's own path field where none can be shown (no
/// desktop portal, no zenity): the question goes to [`Prompts`] and the answer comes from
/// there, so every open and save works the same without a portal.
#[derive(Debug)]
pub struct PromptingPicker {
    inner: Arc<dyn FilePicker>,
    prompts: Prompts,
}

impl PromptingPicker {
    pub fn new(inner: Arc<dyn FilePicker>, prompts: Prompts) -> Arc<PromptingPicker> {
        Arc::new(PromptingPicker { inner, prompts })
    }
}

impl FilePicker for PromptingPicker {
    fn pick(&self, ask: Ask, answer: Answer, wake: Wake) {
        let between = Answer::default();
        let prompts = self.prompts.clone();
        let asked = ask.clone();
        let slot = between.clone();
        let forward: Wake = Arc::new(move || {
            let Some(picked) = take(&slot) else {
                return;
            };
            match picked {
                Picked::NoDialog(why) => {
                    let text = match &asked.directory {
                        Some(dir) if asked.save => {
                            dir.join(&asked.name).to_string_lossy().into_owned()
                        }
                        Some(dir) => format!("{}/", dir.to_string_lossy().trim_end_matches('/')),
                        None if asked.save => asked.name.clone(),
                        None => String::new(),
                    };
                    if let Ok(mut waiting) = prompts.lock() {
                        waiting.push_back(Prompt {
                            ask: asked.clone(),
                            why,
                            text,
                            answer: answer.clone(),
                            wake: wake.clone(),
                        });
                    }
                }
                other => put(&answer, other),
            }
            wake();
        });
        self.inner.pick(ask, between, forward);
    }
}

/// The proposed name of a file: the device, the date and the minute (UTC), and what it
/// holds — `PD4-E601L42_2026-12-02_1432_capture.csv`. Characters a file system may refuse
/// become `-`.
pub fn default_name(
    device: Option<&str>,
    at: std::time::SystemTime,
    what: &str,
    ext: &str,
) -> String {
    let device: String = device
        .map(str::trim)
        .filter(|d| !d.is_empty())
        .unwrap_or("drivedeck")
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.') {
                c
            } else {
                '-'
            }
        })
        .collect();
    // 2026-12-02T14:32:05Z
    let utc = crate::telemetry::utc_text(at);
    let date = utc.get(..10).unwrap_or("");
    let minute: String = utc.get(11..16).unwrap_or("").replace(':', "");
    format!("{device}_{date}_{minute}_{what}.{ext}")
}

/// Open the folder holding `path` in the file manager, without waiting for it.
pub fn open_folder(path: &Path) -> Result<(), String> {
    open_with_system(path.parent().unwrap_or(Path::new(".")))
}

/// Open `target` (a folder, a page) with what the desktop opens it with (xdg-open,
/// open, explorer), or the program `DRIVEDECK_OPENER` names; without waiting for it.
pub fn open_with_system(target: &Path) -> Result<(), String> {
    let default = if cfg!(target_os = "windows") {
        "explorer"
    } else if cfg!(target_os = "macos") {
        "open"
    } else {
        "xdg-open"
    };
    let program = std::env::var("DRIVEDECK_OPENER")
        .ok()
        .filter(|p| !p.trim().is_empty())
        .unwrap_or_else(|| default.to_owned());
    let mut child = std::process::Command::new(&program)
        .arg(target)
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .map_err(|e| format!("cannot open {} with {program}: {e}", target.display()))?;
    // Reaped on a thread of its own: the window does not wait for the program.
    std::thread::spawn(move || child.wait());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_default_name_says_the_device_the_minute_and_what_it_holds() {
        let at = std::time::SystemTime::UNIX_EPOCH + std::time::Duration::from_secs(1_796_221_925);
        assert_eq!(
            default_name(Some("PD4-E601L42"), at, "capture", "csv"),
            "PD4-E601L42_2026-12-02_1432_capture.csv"
        );
        assert_eq!(
            default_name(Some(" C5-E/2 x "), at, "plots", "png"),
            "C5-E-2-x_2026-12-02_1432_plots.png"
        );
        assert_eq!(
            default_name(None, at, "visible", "json"),
            "drivedeck_2026-12-02_1432_visible.json"
        );
    }

    #[test]
    fn a_scripted_picker_answers_in_order_then_cancels() {
        let picker = ScriptedPicker::new();
        picker.answer(Some(PathBuf::from("/tmp/a.csv")));
        let wake: Wake = Arc::new(|| {});
        let ask = Ask {
            save: true,
            title: "Save".into(),
            directory: None,
            name: "a.csv".into(),
            filters: Vec::new(),
        };
        let first: Answer = Arc::default();
        picker.pick(ask.clone(), first.clone(), wake.clone());
        assert_eq!(
            take(&first),
            Some(Picked::File(PathBuf::from("/tmp/a.csv")))
        );
        let second: Answer = Arc::default();
        picker.pick(ask.clone(), second.clone(), wake);
        assert_eq!(take(&second), Some(Picked::Cancelled));
        assert_eq!(picker.asked(), [ask.clone(), ask]);
    }
}
