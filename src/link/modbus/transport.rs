//! One Modbus connection, TCP or RTU: send a request PDU, get the answer, with timeouts and
//! messages that say what failed and where. A Nanotec drive allows one TCP connection, so
//! everything (polling, commands, object access) goes through this one transport.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use tokio::io::AsyncWriteExt;
use tokio::net::TcpStream;
use tokio_serial::{SerialPort, SerialPortBuilderExt, SerialStream};

use crate::link::tries::{NO_ANSWER, TRIES, Trouble, gave_up, read_within, send_within, silence};
use crate::link::{Error, LinkSpec, Parity, TraceRecord, TraceRing};
use crate::proto::modbus::frame::{self, Direction};
use crate::proto::modbus::pdu::{Exception, Request, Response};

/// Transaction ids remembered, so that a late answer to an earlier request is told from
/// a reply for a transaction never asked for.
const SENT_KEPT: usize = 64;

enum Io {
    Tcp(TcpStream),
    Rtu(Box<SerialStream>),
    /// Released before reopening, so that a serial port is free to open again and a
    /// drive that allows one TCP connection sees the old one go first.
    Closed,
}

/// A live Modbus connection.
pub struct Transport {
    /// Where it goes: a Modbus TCP or RTU connection string.
    spec: LinkSpec,
    io: Io,
    timeout: Duration,
    transaction: u16,
    /// The transaction ids sent lately (TCP), oldest first.
    sent: VecDeque<u16>,
    buffer: Vec<u8>,
    last_answer: Option<Instant>,
    trace: TraceRing,
    /// Troubles got over by sending again, not yet reported.
    recovered: Vec<String>,
}

impl std::fmt::Debug for Transport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Transport")
            .field("spec", &self.spec)
            .field("timeout", &self.timeout)
            .finish_non_exhaustive()
    }
}

/// A frame for messages: at most 32 bytes of it.
fn hex(bytes: &[u8]) -> String {
    crate::number::hex_cut(bytes, 32)
}

/// The silence a Modbus RTU master keeps between frames: 3.5 characters (11 bits each)
/// above 19200 baud a fixed 1.75 ms, and at least the 3 ms Nanotec asks for after a
/// response when several slaves share the bus (protocol notes §1.7).
fn rtu_gap(baud: u32) -> Duration {
    let chars = if baud > 19_200 {
        Duration::from_micros(1750)
    } else {
        Duration::from_secs_f64(3.5 * 11.0 / f64::from(baud.max(1)))
    };
    chars.max(Duration::from_millis(3))
}

impl Transport {
    /// Open the connection `spec` names (Modbus TCP or RTU).
    pub async fn connect(spec: &LinkSpec, timeout: Duration) -> Result<Transport, Error> {
        let io = open(spec, timeout).await?;
        Ok(Transport {
            spec: spec.clone(),
            io,
            timeout,
            transaction: 0,
            sent: VecDeque::with_capacity(SENT_KEPT),
            buffer: Vec::with_capacity(512),
            last_answer: None,
            trace: TraceRing::new(),
            recovered: Vec::new(),
        })
    }

    /// Where, for messages: `192.168.2.100:502` or `/dev/ttyUSB0 slave 5`.
    pub fn describe(&self) -> String {
        match &self.spec {
            LinkSpec::ModbusTcp { host, port, .. } => format!("{host}:{port}"),
            LinkSpec::ModbusRtu { path, slave, .. } => format!("{path} slave {slave}"),
            other => other.to_string(),
        }
    }

    /// The frames sent and received since the last call, oldest first.
    pub fn take_trace(&mut self) -> Vec<TraceRecord> {
        self.trace.take()
    }

    /// Open the connection again after a failure.
    pub async fn reconnect(&mut self) -> Result<(), Error> {
        self.close().await;
        self.io = Io::Closed;
        self.io = open(&self.spec, self.timeout).await?;
        self.buffer.clear();
        Ok(())
    }

    /// Close politely: a Nanotec drive allows one TCP connection, release it.
    pub async fn close(&mut self) {
        if let Io::Tcp(stream) = &mut self.io {
            let _ = stream.shutdown().await;
        }
    }

    fn record(&mut self, sent: bool, bytes: &[u8]) {
        let function = match self.io {
            Io::Tcp(_) => bytes.get(7),
            Io::Rtu(_) => bytes.get(1),
            Io::Closed => None,
        };
        let text = match function {
            Some(f) if f & 0x80 != 0 => format!("FC {} exception", f & 0x7F),
            Some(f) => format!("FC {f} {}", if sent { "request" } else { "response" }),
            None => "short frame".into(),
        };
        self.trace.record(sent, hex(bytes), text);
    }

    /// Send a request and wait for its answer. A device's exception is data
    /// (`Ok(Err(_))`); a connection that fails is an error at once. A lost, late,
    /// corrupted or mismatched reply is not: the request goes out again, up to [`TRIES`]
    /// times within the timeout, and only when every try went wrong is that an error
    /// naming what each try met.
    pub async fn transact(
        &mut self,
        request: &Request,
    ) -> Result<Result<Response, Exception>, Error> {
        let pdu = request.encode();
        let what = format!("{} to {}", request.describe(), self.describe());
        let started = Instant::now();
        let deadline = started + self.timeout;
        let per_try = self.timeout / TRIES;
        let mut troubles = Vec::new();
        let mut ids = Vec::new();
        for attempt in 1..=TRIES {
            let try_deadline = if attempt == TRIES {
                deadline
            } else {
                (Instant::now() + per_try).min(deadline)
            };
            let answer = match self.io {
                Io::Tcp(_) => self.try_tcp(&pdu, &what, try_deadline, &mut ids).await,
                Io::Rtu(_) => self.try_rtu(&pdu, &what, try_deadline).await,
                Io::Closed => {
                    return Err(Error::Disconnected(format!(
                        "{what}: the connection is closed (reopening failed)"
                    )));
                }
            };
            match answer {
                Ok(answer) => match Response::decode(request, &answer) {
                    Ok(result) => {
                        if !troubles.is_empty() {
                            self.recovered.push(format!(
                                "{what}: {} (answered on try {attempt})",
                                troubles.join("; ")
                            ));
                        }
                        return Ok(result);
                    }
                    Err(e) => troubles.push(format!("a corrupted reply ({e}): {}", hex(&answer))),
                },
                Err(Trouble::Retry(text)) => troubles.push(text),
                Err(Trouble::Fatal(error)) => return Err(error),
            }
        }
        let hint = match self.spec {
            LinkSpec::ModbusRtu { .. } => "check the slave address, baud rate and parity",
            _ => "",
        };
        Err(gave_up(what, troubles, self.timeout, hint))
    }

    /// What went wrong and was got over by sending again, since the last call (for the
    /// log: a link that recovers often is worth a look at the cabling).
    pub fn take_recovered(&mut self) -> Vec<String> {
        std::mem::take(&mut self.recovered)
    }

    /// One try over TCP: a fresh transaction id, then frames until the answer to this or
    /// an earlier try of the same request (`ids`). A late answer to an earlier request is
    /// skipped; a frame for a transaction never asked for, or bytes that are no frame,
    /// end the try so that the request goes out again.
    async fn try_tcp(
        &mut self,
        pdu: &[u8],
        what: &str,
        deadline: Instant,
        ids: &mut Vec<u16>,
    ) -> Result<Vec<u8>, Trouble> {
        let LinkSpec::ModbusTcp { unit, .. } = self.spec else {
            return Err(not_tcp());
        };
        self.transaction = self.transaction.wrapping_add(1);
        let transaction = self.transaction;
        ids.push(transaction);
        if self.sent.len() >= SENT_KEPT {
            self.sent.pop_front();
        }
        self.sent.push_back(transaction);
        let adu = frame::encode_tcp(transaction, unit, pdu);
        self.record(true, &adu);
        let stream = tcp(&mut self.io)?;
        send_within(stream, &adu, deadline, what, self.timeout, io_error).await?;
        let sent_at = Instant::now();
        loop {
            if let Some(answer) = self.buffered_tcp(transaction, ids) {
                return answer;
            }
            let stream = tcp(&mut self.io)?;
            let read = read_within::<_, 512>(
                stream,
                &mut self.buffer,
                deadline,
                what,
                TCP_CLOSED,
                io_error,
            );
            if !read.await? {
                // Half a frame: its rest may never come; start clean.
                let partial = (!self.buffer.is_empty()).then(|| {
                    let raw = std::mem::take(&mut self.buffer);
                    self.record(false, &raw);
                    ("frame", hex(&raw))
                });
                return Err(silence(sent_at, partial));
            }
        }
    }

    /// The answer to this try's `transaction` or an earlier try's (`ids`) among the bytes
    /// received, late answers to earlier requests skipped; `None` until a whole frame is
    /// there.
    fn buffered_tcp(&mut self, transaction: u16, ids: &[u16]) -> Option<Result<Vec<u8>, Trouble>> {
        loop {
            match frame::decode_tcp(&self.buffer) {
                Ok(Some((frame, used))) => {
                    let raw = self.buffer[..used].to_vec();
                    self.buffer.drain(..used);
                    self.record(false, &raw);
                    if ids.contains(&frame.transaction) {
                        return Some(Ok(frame.pdu));
                    }
                    if self.sent.contains(&frame.transaction) {
                        // A late answer to a request that timed out: skip it.
                        continue;
                    }
                    return Some(Err(Trouble::Retry(format!(
                        "a reply for another transaction ({:04X}h, ours {transaction:04X}h): discarded",
                        frame.transaction
                    ))));
                }
                Ok(None) => return None,
                Err(e) => {
                    let raw = std::mem::take(&mut self.buffer);
                    self.record(false, &raw);
                    return Some(Err(Trouble::Retry(format!(
                        "garbage instead of a Modbus TCP frame ({e}): {}",
                        hex(&raw)
                    ))));
                }
            }
        }
    }

    /// One try over RTU. Noise before the answer is skipped byte by byte until a frame
    /// with a good CRC starts (resynchronising); a frame from another slave is skipped;
    /// once something garbled came and the line has been quiet for a few character times,
    /// the try ends so that the request goes out again.
    async fn try_rtu(
        &mut self,
        pdu: &[u8],
        what: &str,
        deadline: Instant,
    ) -> Result<Vec<u8>, Trouble> {
        let LinkSpec::ModbusRtu { slave, baud, .. } = self.spec else {
            return Err(not_rtu());
        };
        // Keep the bus silent long enough between frames.
        if let Some(last) = self.last_answer {
            let quiet_until = last + rtu_gap(baud);
            tokio::time::sleep_until(quiet_until.into()).await;
        }
        let adu = frame::encode_rtu(slave, pdu);
        self.record(true, &adu);
        let port = rtu(&mut self.io)?;
        // Whatever is still in the buffer belongs to nothing we asked.
        let _ = port.clear(tokio_serial::ClearBuffer::Input);
        self.buffer.clear();
        send_within(port, &adu, deadline, what, self.timeout, io_error).await?;
        let sent_at = Instant::now();
        let mut skipped = Skipped::default();
        loop {
            if let Some(answer) = self.buffered_rtu(slave, &mut skipped) {
                return Ok(answer);
            }
            // After something garbled, a quiet line means nothing good is coming.
            let garbled = skipped.first_error.is_some() || skipped.other_slave.is_some();
            let wait_until = if garbled {
                (Instant::now() + rtu_gap(baud) * 4).min(deadline)
            } else {
                deadline
            };
            let port = rtu(&mut self.io)?;
            let closed = "the serial port closed";
            let read =
                read_within::<_, 256>(port, &mut self.buffer, wait_until, what, closed, io_error);
            if !read.await? {
                return Err(Trouble::Retry(self.rtu_silence(slave, sent_at, skipped)));
            }
        }
    }

    /// The answer from `slave` among the bytes received: noise before it skipped byte by
    /// byte, frames from other slaves skipped, both noted in `skipped`; `None` until a
    /// whole frame from `slave` is there.
    fn buffered_rtu(&mut self, slave: u8, skipped: &mut Skipped) -> Option<Vec<u8>> {
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
    fn rtu_silence(&mut self, slave: u8, sent_at: Instant, skipped: Skipped) -> String {
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

/// What the drive closing the TCP connection means.
const TCP_CLOSED: &str = "the drive closed the connection (a Nanotec drive allows one Modbus TCP connection; if another client such as Plug & Drive Studio or a PLC holds it, close that one)";

fn not_tcp() -> Trouble {
    Trouble::Fatal(Error::Protocol("TCP transaction on a serial link".into()))
}

fn not_rtu() -> Trouble {
    Trouble::Fatal(Error::Protocol("RTU transaction on a TCP link".into()))
}

/// The TCP stream of a TCP connection.
fn tcp(io: &mut Io) -> Result<&mut TcpStream, Trouble> {
    match io {
        Io::Tcp(stream) => Ok(stream),
        _ => Err(not_tcp()),
    }
}

/// The serial port of an RTU connection.
fn rtu(io: &mut Io) -> Result<&mut SerialStream, Trouble> {
    match io {
        Io::Rtu(port) => Ok(port.as_mut()),
        _ => Err(not_rtu()),
    }
}

fn io_error(what: &str, e: std::io::Error) -> Error {
    use std::io::ErrorKind::*;
    match e.kind() {
        ConnectionReset | ConnectionAborted | BrokenPipe | UnexpectedEof => {
            Error::Disconnected(format!(
                "{what}: {e} (a Nanotec drive allows one Modbus TCP connection; another client may hold it)"
            ))
        }
        _ => Error::Io {
            context: what.to_owned(),
            source: e,
        },
    }
}

async fn open(spec: &LinkSpec, timeout: Duration) -> Result<Io, Error> {
    match spec {
        LinkSpec::ModbusTcp { host, port, .. } => {
            let target = format!("{host}:{port}");
            let connect = TcpStream::connect((host.as_str(), *port));
            match tokio::time::timeout(timeout, connect).await {
                Err(_) => Err(Error::Timeout {
                    what: format!(
                        "connecting to {target} (is the drive on this network and switched on?)"
                    ),
                    after: timeout,
                }),
                Ok(Err(e)) if e.kind() == std::io::ErrorKind::ConnectionRefused => {
                    Err(Error::Refused(format!(
                        "{target} refused the connection: nothing listens there, or the drive's one Modbus TCP connection is taken by another client (Plug & Drive Studio, a PLC)"
                    )))
                }
                Ok(Err(e)) => Err(Error::Io {
                    context: format!("connecting to {target}"),
                    source: e,
                }),
                Ok(Ok(stream)) => {
                    let _ = stream.set_nodelay(true);
                    Ok(Io::Tcp(stream))
                }
            }
        }
        LinkSpec::ModbusRtu {
            path,
            baud,
            parity,
            stop_bits,
            ..
        } => {
            let builder = tokio_serial::new(path.as_str(), *baud)
                .data_bits(tokio_serial::DataBits::Eight)
                .parity(match parity {
                    Parity::None => tokio_serial::Parity::None,
                    Parity::Even => tokio_serial::Parity::Even,
                    Parity::Odd => tokio_serial::Parity::Odd,
                })
                .stop_bits(if *stop_bits == 2 {
                    tokio_serial::StopBits::Two
                } else {
                    tokio_serial::StopBits::One
                })
                .timeout(timeout);
            builder
                .open_native_async()
                .map(|port| Io::Rtu(Box::new(port)))
                .map_err(|e| Error::Io {
                    context: format!("opening serial port {path}"),
                    source: std::io::Error::other(e.to_string()),
                })
        }
        other => Err(Error::Unsupported(format!(
            "{other} is not a Modbus connection string"
        ))),
    }
}
