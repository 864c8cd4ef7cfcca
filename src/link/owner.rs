//! The thread that owns a shared medium — a CAN adapter, an RTU serial line — on behalf of
//! every link that uses it: one per medium, with a runtime of its own.

use tokio::sync::oneshot;

use super::Error;

/// The owner thread a medium had before, if any: a new owner waits for it to let go of the
/// port before opening it again.
pub(crate) type Thread = Option<std::thread::JoinHandle<()>>;

/// Start an owner thread called `name`. It waits for the `last` owner of the medium to end,
/// builds a current-thread runtime (a serial port or a socket belongs to the runtime that
/// opened it) and runs `open_and_serve` on it, which says on `opened` whether the medium
/// opened, then serves it. A runtime that cannot start is said on `opened` too. `key` names
/// the medium (`slcan:/dev/ttyACM0`, the port's path) and `what` what the thread owns ("the
/// CAN bus"), for messages.
pub(crate) fn spawn_owner<F, Fut>(
    name: String,
    key: String,
    what: &str,
    last: Thread,
    opened: oneshot::Sender<Result<(), Error>>,
    open_and_serve: F,
) -> Result<std::thread::JoinHandle<()>, Error>
where
    F: FnOnce(oneshot::Sender<Result<(), Error>>) -> Fut + Send + 'static,
    Fut: std::future::Future<Output = ()> + 'static,
{
    let context = format!("starting the thread that owns {what}");
    std::thread::Builder::new()
        .name(name)
        .spawn(move || {
            if let Some(last) = last {
                let _ = last.join();
            }
            let runtime = match tokio::runtime::Builder::new_current_thread()
                .enable_all()
                .build()
            {
                Ok(runtime) => runtime,
                Err(e) => {
                    let _ = opened.send(Err(Error::Io {
                        context: format!("starting the owner of {key}"),
                        source: e,
                    }));
                    return;
                }
            };
            runtime.block_on(open_and_serve(opened));
        })
        .map_err(|e| Error::Io { context, source: e })
}
