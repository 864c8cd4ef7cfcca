//! Ctrl-C (SIGINT), SIGTERM and SIGHUP for the one-shot commands that move the motor or
//! record: caught, so that the command can stop the drive by its `--on-exit` policy, say
//! whether the stop reached it, keep what was recorded, and exit 130. A second signal
//! while that is under way ends the process at once (the user insists).
//!
//! The handlers live on a thread of their own with a small tokio runtime (tokio's signal
//! support is already the worker's): nothing here runs inside a signal handler.

use std::sync::OnceLock;
use std::sync::atomic::{AtomicU8, AtomicU32, Ordering};

use super::EXIT_INTERRUPTED;

/// A signal of the operating system that asks the command to end.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OsSignal {
    Interrupt,
    Terminate,
    Hangup,
}

impl OsSignal {
    fn code(self) -> u8 {
        match self {
            OsSignal::Interrupt => 1,
            OsSignal::Terminate => 2,
            OsSignal::Hangup => 3,
        }
    }

    fn from_code(code: u8) -> Option<OsSignal> {
        match code {
            1 => Some(OsSignal::Interrupt),
            2 => Some(OsSignal::Terminate),
            3 => Some(OsSignal::Hangup),
            _ => None,
        }
    }
}

impl std::fmt::Display for OsSignal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            OsSignal::Interrupt => "SIGINT (Ctrl-C)",
            OsSignal::Terminate => "SIGTERM",
            OsSignal::Hangup => "SIGHUP (the terminal closed)",
        })
    }
}

/// The signal not yet taken by the command.
static PENDING: AtomicU8 = AtomicU8::new(0);
/// Signals caught since the handlers were installed.
static CAUGHT: AtomicU32 = AtomicU32::new(0);
static INSTALLED: OnceLock<Result<(), String>> = OnceLock::new();

/// Catch the signals from now on (once per process). `Err` names why they cannot be: the
/// command then runs with the default handling (the process ends at once).
pub fn install() -> Result<(), String> {
    INSTALLED
        .get_or_init(|| {
            let (ready_tx, ready_rx) = std::sync::mpsc::channel();
            std::thread::Builder::new()
                .name("drivedeck-signals".into())
                .spawn(move || {
                    let runtime = match tokio::runtime::Builder::new_current_thread()
                        .enable_io()
                        .build()
                    {
                        Ok(runtime) => runtime,
                        Err(e) => {
                            let _ = ready_tx.send(Err(format!("no runtime for signals: {e}")));
                            return;
                        }
                    };
                    runtime.block_on(listen(ready_tx));
                })
                .map_err(|e| format!("no thread for signals: {e}"))?;
            ready_rx
                .recv()
                .map_err(|_| "the signal thread ended".to_owned())?
        })
        .clone()
}

/// The signal caught since the last call, once.
pub fn take() -> Option<OsSignal> {
    OsSignal::from_code(PENDING.swap(0, Ordering::SeqCst))
}

fn caught(signal: OsSignal) {
    if CAUGHT.fetch_add(1, Ordering::SeqCst) >= 1 {
        eprintln!("drivedeck: {signal} again: exiting now, without waiting for the drive");
        std::process::exit(i32::from(EXIT_INTERRUPTED));
    }
    PENDING.store(signal.code(), Ordering::SeqCst);
}

#[cfg(unix)]
async fn listen(ready: std::sync::mpsc::Sender<Result<(), String>>) {
    use tokio::signal::unix::{SignalKind, signal};
    let streams = (
        signal(SignalKind::interrupt()),
        signal(SignalKind::terminate()),
        signal(SignalKind::hangup()),
    );
    let (mut int, mut term, mut hup) = match streams {
        (Ok(a), Ok(b), Ok(c)) => (a, b, c),
        (Err(e), _, _) | (_, Err(e), _) | (_, _, Err(e)) => {
            let _ = ready.send(Err(format!("cannot catch signals: {e}")));
            return;
        }
    };
    let _ = ready.send(Ok(()));
    loop {
        let signal = tokio::select! {
            _ = int.recv() => OsSignal::Interrupt,
            _ = term.recv() => OsSignal::Terminate,
            _ = hup.recv() => OsSignal::Hangup,
        };
        caught(signal);
    }
}

#[cfg(not(unix))]
async fn listen(ready: std::sync::mpsc::Sender<Result<(), String>>) {
    let _ = ready.send(Ok(()));
    loop {
        if tokio::signal::ctrl_c().await.is_err() {
            return;
        }
        caught(OsSignal::Interrupt);
    }
}
