//! An encapsulation session over TCP: RegisterSession, request and reply matched by
//! sender context, explicit Message Router requests in SendRRData, and a trace of every
//! message for the frame log.

use std::sync::Arc;
use std::time::{Duration, Instant};

use tokio::io::AsyncWriteExt;
use tokio::net::TcpStream;

use crate::link::tries::{TRIES, Trouble, gave_up, read_within, send_within, silence};
use crate::link::{Error, RawFrames, TraceRecord};
use crate::proto::enip::cip::{self, Reply, Request};
use crate::proto::enip::cpf::Item;
use crate::proto::enip::describe::describe;
use crate::proto::enip::encap::{self, Command, Framed, Packet, RrData, Status};
use crate::proto::enip::identity::Identity;
use crate::proto::enip::wire::hex;

/// A registered session with an adapter.
#[derive(Debug)]
pub struct Session {
    stream: TcpStream,
    handle: u32,
    buffer: Vec<u8>,
    /// The message being sent, kept from one exchange to the next.
    out: Vec<u8>,
    context: u64,
    timeout: Duration,
    /// `host:port`, for messages.
    peer: Arc<str>,
    /// The messages sent and received, as bytes: described only when taken.
    trace: RawFrames<Kept>,
    /// Troubles got over by sending again, not yet reported.
    recovered: Vec<String>,
}

/// What a kept frame was when it came or went.
#[derive(Debug, Clone, Copy)]
enum Kept {
    /// A whole encapsulation message: described from its bytes when taken.
    Message,
    /// Half a message, left when a try ended.
    Incomplete,
    /// Bytes that announced a message longer than any adapter sends.
    Garbage,
}

/// Bytes of a message kept for the frame log: more than any explicit message drivedeck
/// sends or expects (a CIP explicit message fits 504 bytes).
const TRACE_BYTES: usize = 4096;

/// What an exchange is, for its messages ("Get_Attribute_Single (0Eh) to 10.0.0.5:44818"),
/// written out only when a message needs it.
enum What<'a> {
    Command(Command, &'a str),
    Service(u8, &'a str),
}

impl std::fmt::Display for What<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            What::Command(command, peer) => write!(f, "{} to {peer}", command.name()),
            What::Service(service, peer) => write!(
                f,
                "{} ({service:02X}h) to {peer}",
                cip::service::name(*service)
            ),
        }
    }
}

/// Message for a failed TCP read or write.
fn io_error(what: &str, e: std::io::Error) -> Error {
    use std::io::ErrorKind::*;
    match e.kind() {
        ConnectionReset | ConnectionAborted | BrokenPipe | UnexpectedEof => {
            Error::Disconnected(format!("{what}: the adapter closed the connection ({e})"))
        }
        _ => Error::Io {
            context: what.to_owned(),
            source: e,
        },
    }
}

impl Session {
    /// Connect and register a session.
    pub async fn open(host: &str, port: u16, timeout: Duration) -> Result<Session, Error> {
        Self::open_traced(host, port, timeout)
            .await
            .map_err(|(error, _)| error)
    }

    /// [`Session::open`], keeping the frames of a registration that failed.
    pub async fn open_traced(
        host: &str,
        port: u16,
        timeout: Duration,
    ) -> crate::link::Traced<Session> {
        let peer = if host.contains(':') {
            format!("[{host}]:{port}")
        } else {
            format!("{host}:{port}")
        };
        let what = format!("EtherNet/IP adapter at {peer}");
        let stream = match tokio::time::timeout(timeout, TcpStream::connect((host, port))).await {
            Err(_) => {
                return Err((
                    Error::Timeout {
                        what: format!("connecting to the {what}"),
                        after: timeout,
                    },
                    vec![],
                ));
            }
            Ok(Err(e)) if e.kind() == std::io::ErrorKind::ConnectionRefused => {
                return Err((
                    Error::Refused(format!(
                        "the {what} refuses TCP connections: is it on, and is {port} its EtherNet/IP port (44818)?"
                    )),
                    vec![],
                ));
            }
            Ok(Err(e)) => {
                return Err((io_error(&format!("connecting to the {what}"), e), vec![]));
            }
            Ok(Ok(stream)) => stream,
        };
        let _ = stream.set_nodelay(true);
        let mut session = Session {
            stream,
            handle: 0,
            buffer: Vec::with_capacity(1024),
            out: Vec::with_capacity(256),
            context: 0,
            timeout,
            peer: peer.into(),
            trace: RawFrames::new(TRACE_BYTES),
            recovered: Vec::new(),
        };
        match session.register().await {
            Ok(()) => Ok(session),
            Err(error) => Err((error, session.take_trace())),
        }
    }

    /// RegisterSession: the handle every later message carries.
    async fn register(&mut self) -> Result<(), Error> {
        let reply = self
            .exchange(Command::REGISTER_SESSION, encap::register_session_data())
            .await?;
        match reply.status {
            Status::SUCCESS if reply.session != 0 => {
                self.handle = reply.session;
                Ok(())
            }
            Status::SUCCESS => Err(Error::Protocol(format!(
                "the adapter at {} registered session handle 0",
                self.peer
            ))),
            Status::INSUFFICIENT_MEMORY => Err(Error::Refused(format!(
                "the adapter at {} has no room for another session ({}): close other tools talking to it",
                self.peer, reply.status
            ))),
            status => Err(Error::Refused(format!(
                "the adapter at {} refused RegisterSession: {status}",
                self.peer
            ))),
        }
    }

    pub fn peer(&self) -> &str {
        &self.peer
    }

    pub fn handle(&self) -> u32 {
        self.handle
    }

    /// The address the TCP connection came from (our side) and went to (the adapter).
    pub fn addresses(&self) -> (Option<std::net::SocketAddr>, Option<std::net::SocketAddr>) {
        (self.stream.local_addr().ok(), self.stream.peer_addr().ok())
    }

    pub fn take_trace(&mut self) -> Vec<TraceRecord> {
        self.trace.take(|_, kept, bytes| {
            let text = match kept {
                Kept::Message => match encap::split(bytes) {
                    Framed::Packet(packet, _) => describe(&packet),
                    _ => "message (cut for the frame log)".to_owned(),
                },
                Kept::Incomplete => "incomplete".to_owned(),
                Kept::Garbage => "garbage".to_owned(),
            };
            (hex(bytes), text)
        })
    }

    fn record(&mut self, sent: bool, bytes: &[u8], kept: Kept) {
        self.trace.record(sent, kept, bytes);
    }

    /// Send one encapsulation message and wait for its reply. A lost, late, corrupted or
    /// mismatched reply sends the message again (up to [`TRIES`] times within the
    /// timeout); a reply with another session handle or command code is rejected by name.
    pub async fn exchange(&mut self, command: Command, data: Vec<u8>) -> Result<Packet, Error> {
        let peer = self.peer.clone();
        let what = What::Command(command, &peer);
        self.with_tries(command, &data, &what, |reply| Ok(Ok(reply)))
            .await
    }

    /// Send `data` until `accept` takes a reply: `Ok(Ok(_))` the answer, `Ok(Err(_))` an
    /// answer that ends the request (a refusal), `Err(why)` a reply not worth keeping,
    /// so the message goes out again. Every try's trouble is named if all fail.
    async fn with_tries<T>(
        &mut self,
        command: Command,
        data: &[u8],
        what: &What<'_>,
        mut accept: impl FnMut(Packet) -> Result<Result<T, Error>, String>,
    ) -> Result<T, Error> {
        let deadline = Instant::now() + self.timeout;
        let mut troubles = Vec::new();
        let mut contexts = Contexts::default();
        for attempt in 1..=TRIES {
            let try_deadline = try_deadline(attempt, self.timeout, deadline);
            let reply = match self
                .exchange_once(command, data, what, try_deadline, &mut contexts)
                .await
            {
                Ok(reply) => reply,
                Err(Trouble::Retry(text)) => {
                    troubles.push(text);
                    continue;
                }
                Err(Trouble::Fatal(error)) => return Err(error),
            };
            match accept(reply) {
                Ok(answer) => {
                    if answer.is_ok() && !troubles.is_empty() {
                        self.recovered.push(format!(
                            "{what}: {} (answered on try {attempt})",
                            troubles.join("; ")
                        ));
                    }
                    return answer;
                }
                Err(text) => troubles.push(format!("a corrupted reply ({text})")),
            }
        }
        Err(gave_up(what.to_string(), troubles, self.timeout, ""))
    }

    /// One try: a fresh sender context, then frames until the reply to this or an earlier
    /// try (`contexts`).
    async fn exchange_once(
        &mut self,
        command: Command,
        data: &[u8],
        what: &What<'_>,
        deadline: Instant,
        contexts: &mut Contexts,
    ) -> Result<Packet, Trouble> {
        self.context = self.context.wrapping_add(1);
        let context = self.context.to_le_bytes();
        contexts.push(context);
        Packet::encode_request_into(&mut self.out, command, self.handle, context, data);
        self.trace.record(true, Kept::Message, &self.out);
        send_within(
            &mut self.stream,
            &self.out,
            deadline,
            what,
            self.timeout,
            io_error,
        )
        .await?;
        let sent_at = Instant::now();
        loop {
            if let Some(reply) = self.buffered_reply(command, contexts) {
                return reply;
            }
            let closed = "the adapter closed the connection";
            let read = read_within::<_, 2048, _>(
                &mut self.stream,
                &mut self.buffer,
                deadline,
                what,
                closed,
                io_error,
            );
            if !read.await? {
                // Half a message: its rest may never come; start clean.
                let partial = (!self.buffer.is_empty()).then(|| {
                    let raw = std::mem::take(&mut self.buffer);
                    self.record(false, &raw, Kept::Incomplete);
                    ("message", hex(&raw))
                });
                return Err(silence(sent_at, partial));
            }
        }
    }

    /// The reply to this try or an earlier one (`contexts`) among the bytes received,
    /// stale replies skipped; `None` until a whole message is there.
    fn buffered_reply(
        &mut self,
        command: Command,
        contexts: &Contexts,
    ) -> Option<Result<Packet, Trouble>> {
        loop {
            match encap::split(&self.buffer) {
                Framed::Packet(reply, used) => {
                    self.trace
                        .record(false, Kept::Message, &self.buffer[..used]);
                    self.buffer.drain(..used);
                    if contexts.contains(&reply.context) {
                        return Some(self.check_reply(command, reply));
                    }
                    // A stale reply to an earlier, timed-out request: skip it.
                }
                Framed::TooLong(header) => {
                    let raw = std::mem::take(&mut self.buffer);
                    self.record(false, &raw, Kept::Garbage);
                    return Some(Err(Trouble::Retry(format!(
                        "a reply that announces {} bytes, more than any adapter sends (corrupted): {}",
                        header.length,
                        hex(&raw)
                    ))));
                }
                Framed::Incomplete => return None,
            }
        }
    }

    /// A reply to `command` must answer it, in our session.
    fn check_reply(&self, command: Command, reply: Packet) -> Result<Packet, Trouble> {
        if reply.command != command {
            return Err(Trouble::Retry(format!(
                "a reply with command {} to our {}: rejected",
                reply.command, command
            )));
        }
        // RegisterSession is answered with the new handle; everything after carries ours.
        if command != Command::REGISTER_SESSION && reply.session != self.handle {
            return Err(Trouble::Retry(format!(
                "a reply with session handle {:08X}h, ours is {:08X}h: rejected",
                reply.session, self.handle
            )));
        }
        Ok(reply)
    }

    /// Troubles got over by sending again, since the last call.
    pub fn take_recovered(&mut self) -> Vec<String> {
        std::mem::take(&mut self.recovered)
    }

    /// An explicit request in SendRRData, with `items` after the data item (e.g. a T→O
    /// sockaddr for Forward_Open). Returns the Message Router reply and the other items.
    /// A reply whose CIP part is corrupted, or answers another service, is asked again.
    pub async fn request(
        &mut self,
        request: &Request,
        items: Vec<Item>,
    ) -> Result<(Reply, Vec<Item>), Error> {
        let mut all = vec![Item::Null, Item::UnconnectedData(request.encode())];
        all.extend(items);
        let body = RrData::new(10, all).encode();
        let peer = self.peer.clone();
        let what = What::Service(request.service, &peer);
        self.with_tries(Command::SEND_RR_DATA, &body, &what, |reply| {
            if reply.status == Status::INVALID_SESSION {
                return Ok(Err(Error::Disconnected(format!(
                    "{what}: the adapter no longer knows our session ({})",
                    reply.status
                ))));
            }
            if reply.status != Status::SUCCESS {
                return Ok(Err(Error::Answer(format!(
                    "{what}: the adapter answered {}",
                    reply.status
                ))));
            }
            decode_router(request, &reply.data).map(Ok)
        })
        .await
    }

    /// ListIdentity over this TCP connection.
    pub async fn list_identity(&mut self) -> Result<Identity, Error> {
        let reply = self.exchange(Command::LIST_IDENTITY, vec![]).await?;
        let items = crate::proto::enip::cpf::decode(&reply.data)
            .map_err(|e| Error::Protocol(format!("ListIdentity from {}: {e}", self.peer)))?;
        items
            .into_iter()
            .find_map(|i| match i {
                Item::Identity(identity) => Some(*identity),
                _ => None,
            })
            .ok_or_else(|| {
                Error::Protocol(format!(
                    "ListIdentity from {}: no identity item in the reply",
                    self.peer
                ))
            })
    }

    /// UnRegisterSession and close.
    pub async fn close(&mut self) {
        let packet = Packet::new(Command::UNREGISTER_SESSION, self.handle, [0; 8], vec![]);
        let bytes = packet.encode();
        self.record(true, &bytes, Kept::Message);
        let _ = tokio::time::timeout(self.timeout, self.stream.write_all(&bytes)).await;
        let _ = self.stream.shutdown().await;
    }
}

/// The sender contexts of the tries of one request (at most [`TRIES`]): a reply to any of
/// them answers it.
#[derive(Default)]
struct Contexts {
    sent: [[u8; 8]; TRIES as usize],
    len: usize,
}

impl Contexts {
    fn push(&mut self, context: [u8; 8]) {
        if let Some(slot) = self.sent.get_mut(self.len) {
            *slot = context;
            self.len += 1;
        }
    }

    fn contains(&self, context: &[u8; 8]) -> bool {
        self.sent[..self.len].contains(context)
    }
}

/// The deadline of one try: its share of the timeout, the last one all that is left.
fn try_deadline(attempt: u32, timeout: Duration, deadline: Instant) -> Instant {
    if attempt == TRIES {
        deadline
    } else {
        (Instant::now() + timeout / TRIES).min(deadline)
    }
}

/// The Message Router reply in a SendRRData reply, and the items besides it; `Err` names
/// what is wrong with it.
fn decode_router(request: &Request, data: &[u8]) -> Result<(Reply, Vec<Item>), String> {
    let data = RrData::decode(data).map_err(|e| format!("{e}; reply {}", hex(data)))?;
    let router = data
        .unconnected()
        .ok_or_else(|| "the reply has no unconnected data item".to_owned())?;
    let decoded = Reply::decode(router)
        .and_then(|r| r.expect(request.service))
        .map_err(|e| format!("{e}; reply {}", hex(router)))?;
    let others = data
        .items
        .into_iter()
        .filter(|i| !matches!(i, Item::Null | Item::UnconnectedData(_)))
        .collect();
    Ok((decoded, others))
}
