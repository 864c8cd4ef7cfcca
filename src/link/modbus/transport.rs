//! One Modbus connection, TCP or RTU: send a request PDU, get the answer, with timeouts and
//! messages that say what failed and where. A Nanotec drive allows one TCP connection, so
//! everything (polling, commands, object access) goes through this one transport.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use tokio::io::AsyncWriteExt;
use tokio::net::TcpStream;

use super::line::RtuLine;

use crate::link::tries::{TRIES, Trouble, gave_up, read_within, send_within, silence};
use crate::link::{Error, LinkSpec, RawFrames, TraceRecord};
use crate::proto::modbus::frame;
use crate::proto::modbus::pdu::{Exception, Request, Response};

/// Transaction ids remembered, so that a late answer to an earlier request is told from
/// a reply for a transaction never asked for.
const SENT_KEPT: usize = 64;

enum Io {
    Tcp(TcpStream),
    /// The slave's share of its serial line.
    Rtu(RtuLine),
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
    /// Where, for messages (`describe`), worked out once.
    place: std::sync::Arc<str>,
    /// The frames sent and received, as bytes: made into text only when taken.
    frames: RawFrames<()>,
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

/// Bytes of a frame kept for the frame log (its text shows at most 32 of them).
const TRACE_BYTES: usize = 64;

/// Where a link goes, for messages: `192.168.2.100:502` or `/dev/ttyUSB0 slave 5`.
fn describe(spec: &LinkSpec) -> String {
    match spec {
        LinkSpec::ModbusTcp { host, port, .. } => format!("{host}:{port}"),
        LinkSpec::ModbusRtu { path, slave, .. } => format!("{path} slave {slave}"),
        other => other.to_string(),
    }
}

/// What a transaction is, for its messages: "FC 23 (…) to 192.168.2.100:502", written out
/// only when a message needs it.
struct What<'a> {
    request: &'a Request,
    place: &'a str,
}

impl std::fmt::Display for What<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} to {}", self.request.describe(), self.place)
    }
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
            place: describe(spec).into(),
            frames: RawFrames::new(TRACE_BYTES),
            recovered: Vec::new(),
        })
    }

    /// Where, for messages: `192.168.2.100:502` or `/dev/ttyUSB0 slave 5`.
    pub fn describe(&self) -> String {
        self.place.to_string()
    }

    /// The frames sent and received since the last call, oldest first.
    pub fn take_trace(&mut self) -> Vec<TraceRecord> {
        let function_at = match self.spec {
            LinkSpec::ModbusRtu { .. } => 1,
            _ => 7,
        };
        self.frames.take(|sent, _, bytes| {
            let text = match bytes.get(function_at) {
                Some(f) if f & 0x80 != 0 => format!("FC {} exception", f & 0x7F),
                Some(f) => format!("FC {f} {}", if sent { "request" } else { "response" }),
                None => "short frame".into(),
            };
            (hex(bytes), text)
        })
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
        self.frames.record(sent, (), bytes);
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
        // Said only when something goes wrong: not formatted on every exchange.
        let place = self.place.clone();
        let what = What {
            request,
            place: &place,
        };
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
        Err(gave_up(what.to_string(), troubles, self.timeout, hint))
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
        what: &What<'_>,
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
            let read = read_within::<_, 512, _>(
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

    /// One try over RTU, run by the line's owner (the port is shared by every slave on it,
    /// see [`super::line`]). Its time counts from when it goes on the wire.
    async fn try_rtu(
        &mut self,
        pdu: &[u8],
        what: &What<'_>,
        deadline: Instant,
    ) -> Result<Vec<u8>, Trouble> {
        let LinkSpec::ModbusRtu { slave, .. } = self.spec else {
            return Err(not_rtu());
        };
        let Io::Rtu(line) = &self.io else {
            return Err(not_rtu());
        };
        let adu = frame::encode_rtu(slave, pdu);
        let window = deadline.saturating_duration_since(Instant::now());
        let (answer, frames) = line
            .transact(slave, adu, window, &what.to_string(), self.timeout)
            .await;
        for (at, sent, bytes) in frames {
            self.frames.record_at(at, sent, (), &bytes);
        }
        answer
    }
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

/// A failed read or write: a connection lost where the stream says so, an I/O error
/// otherwise.
pub(super) fn io_error(what: &str, e: std::io::Error) -> Error {
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
        LinkSpec::ModbusRtu { .. } => Ok(Io::Rtu(RtuLine::join(spec).await?)),
        other => Err(Error::Unsupported(format!(
            "{other} is not a Modbus connection string"
        ))),
    }
}
