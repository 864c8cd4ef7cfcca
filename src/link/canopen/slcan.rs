//! The two serial ends of slcan (the Lawicel serial-line CAN protocol of CANable, USBtin,
//! CANUSB and CAN232 adapters), over the sans-IO codec in [`crate::proto::canopen::slcan`]:
//! - [`SlcanBus`], the host side a technician's laptop runs against a real adapter;
//! - [`SlcanDevice`], the adapter side, for the simulated node served on a pseudo-terminal
//!   (`drivedeck sim --slcan PATH`), so python-can's `slcan` interface or our own host
//!   side can talk to the simulator as if through a CANable.

use std::collections::VecDeque;
use std::io;
use std::time::{Duration, Instant};

use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};

use super::CanBus;
use crate::link::Error;
use crate::proto::canopen::CanFrame;
use crate::proto::canopen::slcan::{
    AdapterState, LineSplitter, OK, REPLY_TIMEOUT, SERIAL_BAUD, SlcanError, SlcanLine,
    bitrate_command, encode_frame, rate_text,
};

// ---------------------------------------------------------------------------------------
// The byte stream under both ends.

/// A serial stream with its line splitter and the bytes still to write. Reading and
/// writing go through `fill` and `flush`, which are cancel-safe: a `recv` cancelled by a
/// timeout loses neither half a line nor half a reply.
#[derive(Debug)]
struct Wire<S> {
    stream: S,
    splitter: LineSplitter,
    out: Vec<u8>,
}

impl<S: AsyncRead + AsyncWrite + Unpin> Wire<S> {
    fn new(stream: S) -> Self {
        Wire {
            stream,
            splitter: LineSplitter::new(),
            out: Vec::new(),
        }
    }

    /// Write out everything queued.
    async fn flush(&mut self) -> io::Result<()> {
        while !self.out.is_empty() {
            let n = self.stream.write(&self.out).await?;
            if n == 0 {
                return Err(io::ErrorKind::WriteZero.into());
            }
            self.out.drain(..n);
        }
        self.stream.flush().await
    }

    /// Read what is there (waits for at least one byte); 0 at the end of the stream.
    async fn fill(&mut self) -> io::Result<usize> {
        let mut chunk = [0u8; 256];
        let n = self.stream.read(&mut chunk).await?;
        self.splitter.push(&chunk[..n]);
        Ok(n)
    }

    /// The next of `frames`, else more of the stream read (`None`: split the lines
    /// again). `closed` is the error when the other end closed the stream, `failed` words
    /// a read that failed.
    async fn next_or_fill(
        &mut self,
        frames: &mut VecDeque<CanFrame>,
        closed: impl FnOnce() -> Error,
        failed: impl FnOnce(io::Error) -> Error,
    ) -> Result<Option<CanFrame>, Error> {
        if let Some(frame) = frames.pop_front() {
            return Ok(Some(frame));
        }
        match self.fill().await {
            Ok(0) => Err(closed()),
            Ok(_) => Ok(None),
            Err(e) => Err(failed(e)),
        }
    }
}

/// The other end went away: EOF, a broken pipe, or EIO (a pseudo-terminal whose other
/// side closed, a USB adapter unplugged).
fn is_gone(e: &io::Error) -> bool {
    use io::ErrorKind::*;
    matches!(
        e.kind(),
        BrokenPipe | UnexpectedEof | ConnectionReset | ConnectionAborted | WriteZero
    ) || e.raw_os_error() == Some(5)
}

/// A failed read or write: the other end went away (`gone` says so), or an I/O error in
/// `context`.
fn io_error(e: io::Error, context: String, gone: impl FnOnce(&io::Error) -> String) -> Error {
    if is_gone(&e) {
        Error::Disconnected(gone(&e))
    } else {
        Error::Io { context, source: e }
    }
}

fn serial_open_error(path: &str, e: tokio_serial::Error) -> Error {
    crate::link::serial::open_error(path, e)
}

// ---------------------------------------------------------------------------------------
// Host side.

/// A CAN bus through an slcan adapter: what a technician's laptop runs against a CANable,
/// USBtin or CANUSB.
///
/// Opening closes the adapter's channel (`C`), sets the bit rate (`Sn`) and opens it
/// (`O`), checking each answer. Received frames come from `recv`; the adapter's OK and
/// `z`/`Z` acknowledgements are skipped there; its refusals (BEL) and the garbled lines
/// skipped are counted and handed to the user's log by [`CanBus::take_troubles`].
/// [`SlcanBus::close`] closes the channel again; dropping the bus leaves it open (the
/// next open closes it first).
#[derive(Debug)]
pub struct SlcanBus<S> {
    wire: Wire<S>,
    name: String,
    bitrate: u32,
    reply_timeout: Duration,
    frames: VecDeque<CanFrame>,
    refusals: u64,
    garbled_in_a_row: u32,
    /// Good lines read since the adapter was opened: garbage after them is noise on the
    /// line, not a wrong serial speed (which garbles every line from the start).
    good_lines: u64,
    /// Not yet reported: garbled lines skipped (with the last one's fault) and refusals.
    unreported: Unreported,
}

/// What [`SlcanBus::recv`] got over since the last [`CanBus::take_troubles`].
/// Why [`GARBLED_LIMIT`] garbled lines in a row came from the adapter at `name`, after
/// `good` good lines: noise on a line that worked, or a line that never did.
fn garbage_from(name: &str, good: u64, last: &SlcanError) -> String {
    if good > 0 {
        format!(
            "the line from the adapter at {name} is noisy: {GARBLED_LIMIT} garbled lines in a \
             row after {good} good ones (the last: {last}); check the USB cable (short, \
             shielded, not beside motor or power cables), the adapter's ground and the CAN \
             wiring and its termination (a wrong serial speed would garble every line from \
             the start)"
        )
    } else {
        format!(
            "the adapter at {name} sends garbage ({GARBLED_LIMIT} lines in a row, nothing \
             readable since it was opened, the last: {last}): a wrong serial speed, or not an \
             slcan adapter"
        )
    }
}

#[derive(Debug, Default)]
struct Unreported {
    garbled: u32,
    last_garbled: Option<SlcanError>,
    refusals: u32,
}

/// So many garbled lines with nothing sensible in between make `recv` fail instead of
/// skipping them: the serial speed is wrong or the device is not an slcan adapter.
const GARBLED_LIMIT: u32 = 16;

impl SlcanBus<tokio_serial::SerialStream> {
    /// Open the adapter at `path` (`/dev/ttyACM0`, `COM5`) and its CAN channel at
    /// `bitrate` bit/s.
    pub async fn open(path: &str, bitrate: u32) -> Result<Self, Error> {
        use tokio_serial::{SerialPort, SerialPortBuilderExt};
        // A wrong bit rate is found before the port is touched.
        bitrate_command(bitrate).map_err(|e| Error::Unsupported(e.to_string()))?;
        let port = tokio_serial::new(path, SERIAL_BAUD)
            .open_native_async()
            .map_err(|e| serial_open_error(path, e))?;
        // Frames and answers from an earlier session belong to nothing we ask.
        let _ = port.clear(tokio_serial::ClearBuffer::Input);
        Self::with_options(port, bitrate, path, REPLY_TIMEOUT).await
    }
}

impl<S: AsyncRead + AsyncWrite + Unpin> SlcanBus<S> {
    /// Set up the adapter on an open stream.
    pub async fn new(stream: S, bitrate: u32) -> Result<Self, Error> {
        Self::with_options(stream, bitrate, "serial stream", REPLY_TIMEOUT).await
    }

    /// Set up the adapter on an open stream; `name` (its path) goes into messages, and each
    /// command gets `reply_timeout` for its answer.
    pub async fn with_options(
        stream: S,
        bitrate: u32,
        name: impl Into<String>,
        reply_timeout: Duration,
    ) -> Result<Self, Error> {
        let rate_command =
            bitrate_command(bitrate).map_err(|e| Error::Unsupported(e.to_string()))?;
        let mut bus = SlcanBus {
            wire: Wire::new(stream),
            name: name.into(),
            bitrate,
            reply_timeout,
            frames: VecDeque::new(),
            refusals: 0,
            garbled_in_a_row: 0,
            good_lines: 0,
            unreported: Unreported::default(),
        };
        // Any answer to `C` will do: a Lawicel adapter refuses to close a closed channel,
        // and a half command left in the adapter by an earlier session turns `C` into
        // garbage it refuses. If the channel is still open after that, the bit rate is
        // refused and the second round closes it for sure.
        bus.command("C", false).await?;
        if !bus.command(rate_command, true).await? {
            bus.command("C", true).await?;
            if !bus.command(rate_command, true).await? {
                return Err(Error::Refused(format!(
                    "the adapter at {} refused the bit rate {} (`{rate_command}`): its firmware may not support it",
                    bus.name,
                    rate_text(bitrate)
                )));
            }
        }
        // Frames before the channel opened are an earlier session's.
        bus.frames.clear();
        if !bus.command("O", true).await? {
            return Err(Error::Refused(format!(
                "the adapter at {} refused to open its CAN channel (`O`)",
                bus.name
            )));
        }
        Ok(bus)
    }

    /// Close the adapter's channel (`C`) and give back the stream.
    pub async fn close(mut self) -> Result<S, Error> {
        self.command("C", true).await?;
        Ok(self.wire.stream)
    }

    /// The bit rate the channel was opened at.
    pub fn bitrate(&self) -> u32 {
        self.bitrate
    }

    /// How many lines the adapter refused (BEL) since it was opened: frames it could not
    /// transmit, mostly.
    pub fn refusals(&self) -> u64 {
        self.refusals
    }

    /// Send `command`, wait for the adapter's OK (true) or error (false). Frames arriving
    /// meanwhile are kept. `heard` says whether the adapter has answered before, for the
    /// message when it does not answer now.
    async fn command(&mut self, command: &str, heard: bool) -> Result<bool, Error> {
        let deadline = tokio::time::Instant::now() + self.reply_timeout;
        self.wire.out.extend_from_slice(command.as_bytes());
        self.wire.out.push(OK);
        let what = format!("sending `{command}`");
        match tokio::time::timeout_at(deadline, self.wire.flush()).await {
            Ok(Ok(())) => {}
            Ok(Err(e)) => return Err(adapter_io_error(&self.name, &what, e)),
            Err(_) => return Err(self.silent(command, heard, false)),
        }
        let mut garbage = false;
        loop {
            while let Some(line) = self.wire.splitter.next_line() {
                match line {
                    Ok(SlcanLine::Ack) => return Ok(true),
                    Ok(SlcanLine::Error) => return Ok(false),
                    Ok(SlcanLine::Frame(frame)) => self.frames.push_back(frame),
                    Ok(SlcanLine::Other(text)) => {
                        tracing::debug!(
                            "slcan {}: `{text}` while waiting for `{command}`",
                            self.name
                        );
                    }
                    Err(e) => {
                        tracing::debug!("slcan {}: {e}", self.name);
                        garbage = true;
                    }
                }
            }
            match tokio::time::timeout_at(deadline, self.wire.fill()).await {
                Ok(Ok(0)) => {
                    return Err(Error::Disconnected(format!(
                        "the adapter at {} closed the port while {what}",
                        self.name
                    )));
                }
                Ok(Ok(_)) => {}
                Ok(Err(e)) => {
                    return Err(adapter_io_error(
                        &self.name,
                        &format!("waiting for `{command}`"),
                        e,
                    ));
                }
                Err(_) => return Err(self.silent(command, heard, garbage)),
            }
        }
    }

    /// The error for an adapter that did not answer `command` in time.
    fn silent(&self, command: &str, heard: bool, garbage: bool) -> Error {
        let what = if garbage {
            format!(
                "the device at {} did not answer `{command}` with slcan, only with garbage (a wrong serial speed, or not an slcan adapter)",
                self.name
            )
        } else if heard {
            format!(
                "the adapter at {} stopped answering (`{command}`)",
                self.name
            )
        } else {
            format!(
                "the adapter at {} did not answer `{command}`: is it an slcan adapter? (a CANable, USBtin or CANUSB with slcan firmware; a candleLight adapter is a SocketCAN interface, use canopen+socketcan://can0)",
                self.name
            )
        };
        Error::Timeout {
            what,
            after: self.reply_timeout,
        }
    }

    /// A line from the adapter: a frame is queued, a refusal counted; a garbled line is
    /// counted too, and after [`GARBLED_LIMIT`] in a row is an error.
    fn take_line(&mut self, line: Result<SlcanLine, SlcanError>) -> Result<(), Error> {
        match line {
            Ok(line) => {
                self.garbled_in_a_row = 0;
                self.good_lines += 1;
                match line {
                    SlcanLine::Frame(frame) => self.frames.push_back(frame),
                    SlcanLine::Ack => {}
                    SlcanLine::Error => {
                        self.refusals += 1;
                        self.unreported.refusals += 1;
                        tracing::debug!(
                            "slcan {}: the adapter refused a line (BEL): a frame it could not transmit?",
                            self.name
                        );
                    }
                    SlcanLine::Other(text) => {
                        tracing::debug!("slcan {}: `{text}`", self.name);
                    }
                }
            }
            Err(e) => {
                self.garbled_in_a_row += 1;
                tracing::debug!("slcan {}: {e}", self.name);
                if self.garbled_in_a_row >= GARBLED_LIMIT {
                    // Reported once per so many lines, by this error alone; good
                    // lines still get through.
                    self.garbled_in_a_row = 0;
                    self.unreported.garbled = 0;
                    self.unreported.last_garbled = None;
                    return Err(Error::Protocol(garbage_from(
                        &self.name,
                        self.good_lines,
                        &e,
                    )));
                }
                self.unreported.garbled += 1;
                self.unreported.last_garbled = Some(e);
            }
        }
        Ok(())
    }
}

/// A failed read or write on the host side, the adapter at `name`.
fn adapter_io_error(name: &str, what: &str, e: io::Error) -> Error {
    io_error(e, format!("slcan adapter at {name}: {what}"), |e| {
        format!("the adapter at {name} went away while {what} ({e}): was it unplugged?")
    })
}

impl<S: AsyncRead + AsyncWrite + Unpin> CanBus for SlcanBus<S> {
    async fn send(&mut self, frame: &CanFrame) -> Result<(), Error> {
        self.wire.out.extend_from_slice(&encode_frame(frame));
        self.wire
            .flush()
            .await
            .map_err(|e| adapter_io_error(&self.name, &format!("sending {frame}"), e))
    }

    async fn recv(&mut self) -> Result<CanFrame, Error> {
        loop {
            while let Some(line) = self.wire.splitter.next_line() {
                self.take_line(line)?;
            }
            let name = &self.name;
            let closed = || {
                Error::Disconnected(format!(
                    "the adapter at {name} closed the port: was it unplugged?"
                ))
            };
            let failed = |e| adapter_io_error(name, "receiving", e);
            let next = self.wire.next_or_fill(&mut self.frames, closed, failed);
            if let Some(frame) = next.await? {
                return Ok(frame);
            }
        }
    }

    fn describe(&self) -> String {
        format!("slcan {} at {}", self.name, rate_text(self.bitrate))
    }

    /// At most one line per kind and call, with the count: a noisy line shows as "7 garbled
    /// lines skipped" per cycle, not as seven lines.
    fn take_troubles(&mut self) -> Vec<String> {
        let Unreported {
            garbled,
            last_garbled,
            refusals,
        } = std::mem::take(&mut self.unreported);
        let mut troubles = Vec::new();
        if garbled > 0 {
            let last = last_garbled.map(|e| e.to_string()).unwrap_or_default();
            troubles.push(if garbled == 1 {
                format!("slcan {}: 1 garbled line skipped: {last}", self.name)
            } else {
                format!(
                    "slcan {}: {garbled} garbled lines skipped, the last: {last}",
                    self.name
                )
            });
        }
        if refusals > 0 {
            troubles.push(format!(
                "slcan {}: the adapter refused {refusals} line(s) (BEL): frames it could not transmit?",
                self.name
            ));
        }
        troubles
    }
}

// ---------------------------------------------------------------------------------------
// Adapter side.

/// The adapter end of an slcan serial line, for a simulated node: it answers the host's
/// commands the way a CANable does (see [`AdapterState`]), hands the frames the host
/// transmits to `recv`, and reports the frames the node `send`s as lines. While the channel
/// is closed, sent frames are dropped, as an adapter drops what it receives while closed.
///
/// The host's commands are answered while the node waits in `recv` (and whenever it
/// sends), so a node on this bus keeps a `recv` going, as every CANopen node does.
#[derive(Debug)]
pub struct SlcanDevice<S> {
    wire: Wire<S>,
    name: String,
    state: AdapterState,
    frames: VecDeque<CanFrame>,
}

impl SlcanDevice<tokio_serial::SerialStream> {
    /// Serve on the serial port or pseudo-terminal at `path`.
    pub fn open(path: &str) -> Result<Self, Error> {
        use tokio_serial::SerialPortBuilderExt;
        let port = tokio_serial::new(path, SERIAL_BAUD)
            .open_native_async()
            .map_err(|e| serial_open_error(path, e))?;
        Ok(Self::with_name(port, path))
    }
}

impl<S: AsyncRead + AsyncWrite + Unpin> SlcanDevice<S> {
    pub fn new(stream: S) -> Self {
        Self::with_name(stream, "serial stream")
    }

    /// `name` (the path) goes into messages.
    pub fn with_name(stream: S, name: impl Into<String>) -> Self {
        SlcanDevice {
            wire: Wire::new(stream),
            name: name.into(),
            state: AdapterState::new(),
            frames: VecDeque::new(),
        }
    }

    /// The adapter as the host has set it up.
    pub fn state(&self) -> &AdapterState {
        &self.state
    }

    pub fn into_inner(self) -> S {
        self.wire.stream
    }
}

/// A failed read or write on the adapter side, serving on `name`.
fn device_io_error(name: &str, what: &str, e: io::Error) -> Error {
    io_error(e, format!("slcan device on {name}: {what}"), |e| {
        format!("the host left {name} while {what} ({e})")
    })
}

impl<S: AsyncRead + AsyncWrite + Unpin> CanBus for SlcanDevice<S> {
    async fn send(&mut self, frame: &CanFrame) -> Result<(), Error> {
        match self.state.frame_line(frame, Instant::now()) {
            Some(line) => self.wire.out.extend_from_slice(&line),
            None => tracing::trace!(
                "slcan device {}: channel closed, {frame} dropped",
                self.name
            ),
        }
        self.wire
            .flush()
            .await
            .map_err(|e| device_io_error(&self.name, &format!("sending {frame}"), e))
    }

    async fn recv(&mut self) -> Result<CanFrame, Error> {
        loop {
            while let Some(line) = self.wire.splitter.next_line() {
                let handled = self.state.handle(line, Instant::now());
                self.wire.out.extend_from_slice(&handled.reply);
                self.frames.extend(handled.frame);
            }
            // Answers first, so the host hears the OK for a frame before the node's reply.
            self.wire
                .flush()
                .await
                .map_err(|e| device_io_error(&self.name, "answering", e))?;
            let name = &self.name;
            let closed = || Error::Disconnected(format!("the host closed {name}"));
            let failed = |e| device_io_error(name, "receiving", e);
            let next = self.wire.next_or_fill(&mut self.frames, closed, failed);
            if let Some(frame) = next.await? {
                return Ok(frame);
            }
        }
    }

    fn describe(&self) -> String {
        format!("simulated slcan adapter on {}", self.name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn garbage_after_good_lines_is_noise_and_from_the_start_a_wrong_speed() {
        let last = SlcanError::Garbage("t6\\x01".into());
        let noise = garbage_from("/dev/ttyACM0", 1200, &last);
        assert!(
            noise.starts_with("the line from the adapter at /dev/ttyACM0 is noisy")
                && noise.contains("after 1200 good ones")
                && noise.contains("check the USB cable"),
            "{noise}"
        );
        let speed = garbage_from("/dev/ttyACM0", 0, &last);
        assert!(speed.contains("a wrong serial speed"), "{speed}");
        assert!(!speed.contains("noisy"), "{speed}");
    }
}
