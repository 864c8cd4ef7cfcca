//! One RS-485 line shared by every Modbus RTU slave on it.
//!
//! Two drives on one line are two slaves behind one serial port. Each drive keeps its own
//! worker thread and its own [`ModbusLink`](super::client::ModbusLink), but the port is
//! opened once: the first link to name it ([`RtuLine::join`], keyed by the port's path)
//! starts the line's owner, a thread of its own that is the port's only user. A link's
//! transport hands it one try of a request at a time:
//!
//! * the owner runs the tries in the order they come, one on the wire at a time, so the
//!   drives' workers take turns: each slave is answered by its own address, a frame from
//!   another slave is skipped;
//! * the owner keeps the silence between frames on the line (3.5 characters, at least
//!   3 ms after an answer, whoever's it was);
//! * a try's time counts from when it goes on the wire, and a slave that does not answer
//!   holds the line for one try at a time (a third of its timeout): the others' requests
//!   go between its tries, so a silent slave delays them by at most one of its tries;
//! * the line closes when its last link goes; a port that fails ends the line for every
//!   link on it, and the next link to name the port opens it afresh.

use std::collections::BTreeMap;
use std::sync::Mutex;
use std::time::{Duration, Instant, SystemTime};

use tokio::sync::{mpsc, oneshot};
use tokio_serial::{SerialPort, SerialPortBuilderExt, SerialStream};

use super::transport::io_error;
use crate::link::tries::{NO_ANSWER, Trouble, read_within, send_within};
use crate::link::{Error, LinkSpec, Parity};
use crate::proto::modbus::frame::{self, Direction};

/// Tries waiting for the owner (each link has one at a time).
const QUEUE: usize = 64;

/// A frame as the owner saw it, for the link's trace: when, sent or received, its bytes.
pub type LineFrame = (SystemTime, bool, Vec<u8>);

/// How a try ended, and the frames seen on the way.
pub(super) type TryOutcome = (Result<Vec<u8>, Trouble>, Vec<LineFrame>);

/// One try of a request, for the owner.
struct Try {
    slave: u8,
    adu: Vec<u8>,
    /// How long the try may wait for its answer once on the wire.
    window: Duration,
    what: String,
    timeout: Duration,
    reply: oneshot::Sender<TryOutcome>,
}

/// The serial settings a second link must agree with, and the port's path.
#[derive(Clone, Debug, PartialEq, Eq)]
struct Settings {
    path: String,
    baud: u32,
    parity: Parity,
    stop_bits: u8,
}

impl std::fmt::Display for Settings {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let parity = match self.parity {
            Parity::None => 'N',
            Parity::Even => 'E',
            Parity::Odd => 'O',
        };
        write!(f, "{} baud 8{parity}{}", self.baud, self.stop_bits)
    }
}

/// Each line's owner (while a link holds it), its settings, and its thread: a line
/// opened again waits for the last owner to let go of the port.
type Registry = BTreeMap<String, (mpsc::WeakSender<Try>, Settings, Thread)>;

use crate::link::owner::Thread;

fn registry() -> std::sync::MutexGuard<'static, Registry> {
    static LINES: Mutex<Registry> = Mutex::new(BTreeMap::new());
    LINES.lock().unwrap_or_else(|p| p.into_inner())
}

/// The lines open now, by key (for tests and messages).
pub fn open_lines() -> Vec<String> {
    registry()
        .iter()
        .filter(|(_, (sender, _, _))| sender.upgrade().is_some_and(|s| !s.is_closed()))
        .map(|(key, _)| key.clone())
        .collect()
}

/// A link's hold on a shared serial line.
#[derive(Debug)]
pub struct RtuLine {
    owner: mpsc::Sender<Try>,
    settings: Settings,
}

impl RtuLine {
    /// Join the line of the port `spec` names, opening it on an owner thread when no link
    /// has it open. A second link with other serial settings is refused.
    pub async fn join(spec: &LinkSpec) -> Result<RtuLine, Error> {
        let LinkSpec::ModbusRtu {
            path,
            baud,
            parity,
            stop_bits,
            ..
        } = spec
        else {
            return Err(Error::Unsupported(format!(
                "{spec} is not a Modbus RTU connection string"
            )));
        };
        let settings = Settings {
            path: path.clone(),
            baud: *baud,
            parity: *parity,
            stop_bits: *stop_bits,
        };
        let key = format!("rtu:{}", crate::link::same_file(path));
        let (owner, opened) = {
            let mut lines = registry();
            let running = lines.get(&key).and_then(|(weak, open_with, _)| {
                Some((weak.upgrade().filter(|s| !s.is_closed())?, open_with))
            });
            match running {
                Some((owner, open_with)) => {
                    if *open_with != settings {
                        return Err(Error::Refused(format!(
                            "the serial port {path} is already open by another drive at {open_with}, not {settings}: every slave on one line runs at the line's settings"
                        )));
                    }
                    (owner, None)
                }
                None => {
                    let (owner, tries) = mpsc::channel(QUEUE);
                    let (opened_tx, opened_rx) = oneshot::channel();
                    let last = lines.remove(&key).and_then(|(_, _, thread)| thread);
                    let thread = spawn_owner(settings.clone(), tries, opened_tx, last)?;
                    lines.insert(key, (owner.downgrade(), settings.clone(), Some(thread)));
                    (owner, Some(opened_rx))
                }
            }
        };
        if let Some(opened) = opened {
            opened.await.map_err(|_| {
                Error::Disconnected(format!("the owner of {path} stopped while opening it"))
            })??;
        }
        Ok(RtuLine { owner, settings })
    }

    /// Run one try on the line: `adu` to `slave`, its answer awaited for `window` once on
    /// the wire. The frames seen on the way come back for the link's trace.
    pub(super) async fn transact(
        &self,
        slave: u8,
        adu: Vec<u8>,
        window: Duration,
        what: &str,
        timeout: Duration,
    ) -> TryOutcome {
        let (reply, answer) = oneshot::channel();
        let gone = || {
            Trouble::Fatal(Error::Disconnected(format!(
                "{what}: the serial port {} is closed (it failed for a drive on it)",
                self.settings.path
            )))
        };
        let request = Try {
            slave,
            adu,
            window,
            what: what.to_owned(),
            timeout,
            reply,
        };
        if self.owner.send(request).await.is_err() {
            return (Err(gone()), Vec::new());
        }
        answer.await.unwrap_or_else(|_| (Err(gone()), Vec::new()))
    }

    /// Whether the line still runs (a failed port ends it).
    pub fn is_open(&self) -> bool {
        !self.owner.is_closed()
    }
}

/// The silence a Modbus RTU master keeps between frames: 3.5 characters (11 bits each)
/// above 19200 baud a fixed 1.75 ms, and at least the 3 ms Nanotec asks for after a
/// response when several slaves share the bus (protocol notes §1.7).
pub(super) fn rtu_gap(baud: u32) -> Duration {
    let chars = if baud > 19_200 {
        Duration::from_micros(1750)
    } else {
        Duration::from_secs_f64(3.5 * 11.0 / f64::from(baud.max(1)))
    };
    chars.max(Duration::from_millis(3))
}

/// Start the owner thread of a line: it waits for the `last` owner of the port to close it,
/// opens the port (it belongs to the runtime that opened it), says how that went on
/// `opened`, then serves.
fn spawn_owner(
    settings: Settings,
    tries: mpsc::Receiver<Try>,
    opened: oneshot::Sender<Result<(), Error>>,
    last: Thread,
) -> Result<std::thread::JoinHandle<()>, Error> {
    let key = settings.path.clone();
    crate::link::owner::spawn_owner(
        format!("drivedeck-rtu {key}"),
        key,
        "the serial line",
        last,
        opened,
        move |opened| async move {
            match open(&settings) {
                Ok(port) => {
                    let _ = opened.send(Ok(()));
                    Owner {
                        port,
                        baud: settings.baud,
                        buffer: Vec::with_capacity(512),
                        last_answer: None,
                        frames: Vec::new(),
                    }
                    .serve(tries)
                    .await;
                }
                Err(error) => {
                    let _ = opened.send(Err(error));
                }
            }
        },
    )
}

fn open(settings: &Settings) -> Result<SerialStream, Error> {
    let path = settings.path.as_str();
    tokio_serial::new(path, settings.baud)
        .data_bits(tokio_serial::DataBits::Eight)
        .parity(match settings.parity {
            Parity::None => tokio_serial::Parity::None,
            Parity::Even => tokio_serial::Parity::Even,
            Parity::Odd => tokio_serial::Parity::Odd,
        })
        .stop_bits(if settings.stop_bits == 2 {
            tokio_serial::StopBits::Two
        } else {
            tokio_serial::StopBits::One
        })
        .open_native_async()
        .map_err(|e| crate::link::serial::open_error(path, e))
}

/// The port and what the line remembers between tries.
struct Owner {
    port: SerialStream,
    baud: u32,
    buffer: Vec<u8>,
    /// When the line last carried an answer: the next request keeps the gap after it.
    last_answer: Option<Instant>,
    /// The frames of the try under way.
    frames: Vec<LineFrame>,
}

impl Owner {
    async fn serve(mut self, mut tries: mpsc::Receiver<Try>) {
        while let Some(request) = tries.recv().await {
            let deadline = Instant::now() + request.window;
            let answer = self.run(&request, deadline).await;
            let broken = matches!(answer, Err(Trouble::Fatal(_)));
            let frames = std::mem::take(&mut self.frames);
            let _ = request.reply.send((answer, frames));
            if broken {
                // The port failed: the line ends for every link on it.
                break;
            }
        }
    }

    fn record(&mut self, sent: bool, bytes: &[u8]) {
        self.frames.push((SystemTime::now(), sent, bytes.to_vec()));
    }

    /// One try: noise before the answer is skipped byte by byte until a frame with a good
    /// CRC starts (resynchronising); a frame from another slave is skipped; once something
    /// garbled came and the line has been quiet for a few character times, the try ends
    /// so that the request goes out again.
    async fn run(&mut self, request: &Try, deadline: Instant) -> Result<Vec<u8>, Trouble> {
        let (slave, what) = (request.slave, request.what.as_str());
        // Keep the line silent long enough between frames.
        if let Some(last) = self.last_answer {
            tokio::time::sleep_until((last + rtu_gap(self.baud)).into()).await;
        }
        self.record(true, &request.adu);
        // Whatever is still in the buffer belongs to nothing asked.
        let _ = self.port.clear(tokio_serial::ClearBuffer::Input);
        self.buffer.clear();
        send_within(
            &mut self.port,
            &request.adu,
            deadline,
            what,
            request.timeout,
            io_error,
        )
        .await?;
        let sent_at = Instant::now();
        let mut skipped = Skipped::default();
        loop {
            if let Some(answer) = self.buffered(slave, &mut skipped) {
                return Ok(answer);
            }
            // After something garbled, a quiet line means nothing good is coming.
            let garbled = skipped.first_error.is_some() || skipped.other_slave.is_some();
            let wait_until = if garbled {
                (Instant::now() + rtu_gap(self.baud) * 4).min(deadline)
            } else {
                deadline
            };
            let closed = "the serial port closed";
            let read = read_within::<_, 256, _>(
                &mut self.port,
                &mut self.buffer,
                wait_until,
                what,
                closed,
                io_error,
            );
            if !read.await? {
                return Err(Trouble::Retry(self.silence(slave, sent_at, skipped)));
            }
        }
    }

    /// The answer from `slave` among the bytes received: noise before it skipped byte by
    /// byte, frames from other slaves skipped, both noted in `skipped`; `None` until a
    /// whole frame from `slave` is there.
    fn buffered(&mut self, slave: u8, skipped: &mut Skipped) -> Option<Vec<u8>> {
        loop {
            match frame::decode_rtu(&self.buffer, Direction::Response) {
                Ok(Some((frame, used))) => {
                    let raw = self.buffer[..used].to_vec();
                    self.buffer.drain(..used);
                    if !skipped.noise.is_empty() {
                        let noise = std::mem::take(&mut skipped.noise);
                        self.record(false, &noise);
                    }
                    self.record(false, &raw);
                    self.last_answer = Some(Instant::now());
                    if frame.slave != slave {
                        skipped.other_slave = Some(frame.slave);
                        continue;
                    }
                    return Some(frame.pdu);
                }
                Ok(None) => return None,
                Err(e) => {
                    // Not a frame from here: drop one byte and look again.
                    skipped.first_error.get_or_insert_with(|| e.to_string());
                    skipped.noise.push(self.buffer.remove(0));
                }
            }
        }
    }

    /// The line went quiet without an answer from `slave`: what was heard instead, in words.
    fn silence(&mut self, slave: u8, sent_at: Instant, skipped: Skipped) -> String {
        self.last_answer = Some(Instant::now());
        let Skipped {
            noise: mut heard,
            first_error,
            other_slave,
        } = skipped;
        heard.append(&mut self.buffer);
        if !heard.is_empty() {
            self.record(false, &heard);
        }
        let hex = |bytes: &[u8]| crate::number::hex_cut(bytes, 32);
        match (first_error, other_slave) {
            (Some(e), _) => format!(
                "a garbled answer ({e}; noise on the line, or a wrong baud rate or parity): {}",
                hex(&heard)
            ),
            (None, Some(other)) => format!(
                "an answer from slave {other} instead of {slave} (another device answers on this address?)"
            ),
            (None, None) if heard.is_empty() => format!(
                "{NO_ANSWER} {} ms (check the slave address, baud rate and parity)",
                sent_at.elapsed().as_millis()
            ),
            (None, None) => format!(
                "{NO_ANSWER} {} ms but an incomplete one: {} (check baud rate and parity)",
                sent_at.elapsed().as_millis(),
                hex(&heard)
            ),
        }
    }
}

/// What an RTU try heard besides its answer, for the message when none comes: the bytes
/// skipped as noise and the first reason, and the last other slave that answered.
#[derive(Default)]
struct Skipped {
    noise: Vec<u8>,
    first_error: Option<String>,
    other_slave: Option<u8>,
}
