//! One Modbus connection, TCP or RTU: send a request PDU, get the answer, with timeouts and
//! messages that say what failed and where. A Nanotec drive allows one TCP connection, so
//! everything (polling, commands, object access) goes through this one transport.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;
use tokio_serial::{SerialPort, SerialPortBuilderExt, SerialStream};

use super::frame::{self, Direction};
use super::pdu::{Exception, Request, Response};
use crate::link::{Error, LinkSpec, Parity, TraceRecord};

/// Frames kept for diagnostics (the log panel and error messages).
const TRACE_LIMIT: usize = 4096;

/// Where a Modbus connection goes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Endpoint {
    Tcp {
        host: String,
        port: u16,
        unit: u8,
    },
    Rtu {
        path: String,
        baud: u32,
        parity: Parity,
        stop_bits: u8,
        slave: u8,
    },
}

impl Endpoint {
    pub fn from_spec(spec: &LinkSpec) -> Option<Endpoint> {
        match spec.clone() {
            LinkSpec::ModbusTcp {
                host, port, unit, ..
            } => Some(Endpoint::Tcp { host, port, unit }),
            LinkSpec::ModbusRtu {
                path,
                baud,
                parity,
                stop_bits,
                slave,
                ..
            } => Some(Endpoint::Rtu {
                path,
                baud,
                parity,
                stop_bits,
                slave,
            }),
            _ => None,
        }
    }

    /// Where, for messages: `192.168.2.100:502` or `/dev/ttyUSB0 slave 5`.
    pub fn describe(&self) -> String {
        match self {
            Endpoint::Tcp { host, port, .. } => format!("{host}:{port}"),
            Endpoint::Rtu { path, slave, .. } => format!("{path} slave {slave}"),
        }
    }
}

enum Io {
    Tcp(TcpStream),
    Rtu(Box<SerialStream>),
    /// Released before reopening, so that a serial port is free to open again and a
    /// drive that allows one TCP connection sees the old one go first.
    Closed,
}

/// A live Modbus connection.
pub struct Transport {
    endpoint: Endpoint,
    io: Io,
    timeout: Duration,
    transaction: u16,
    buffer: Vec<u8>,
    last_answer: Option<Instant>,
    trace: VecDeque<TraceRecord>,
}

impl std::fmt::Debug for Transport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Transport")
            .field("endpoint", &self.endpoint)
            .field("timeout", &self.timeout)
            .finish_non_exhaustive()
    }
}

fn hex(bytes: &[u8]) -> String {
    let shown: Vec<String> = bytes.iter().take(32).map(|b| format!("{b:02X}")).collect();
    let more = if bytes.len() > 32 { " …" } else { "" };
    format!("{}{more}", shown.join(" "))
}

/// The silence a Modbus RTU master keeps between frames: 3.5 characters (11 bits each)
/// above 19200 baud a fixed 1.75 ms, and at least the 3 ms Nanotec asks for after a
/// response when several slaves share the bus (FACTS 1.7).
fn rtu_gap(baud: u32) -> Duration {
    let chars = if baud > 19_200 {
        Duration::from_micros(1750)
    } else {
        Duration::from_secs_f64(3.5 * 11.0 / f64::from(baud.max(1)))
    };
    chars.max(Duration::from_millis(3))
}

impl Transport {
    /// Open the connection.
    pub async fn connect(endpoint: &Endpoint, timeout: Duration) -> Result<Transport, Error> {
        let io = open(endpoint, timeout).await?;
        Ok(Transport {
            endpoint: endpoint.clone(),
            io,
            timeout,
            transaction: 0,
            buffer: Vec::with_capacity(512),
            last_answer: None,
            trace: VecDeque::new(),
        })
    }

    pub fn endpoint(&self) -> &Endpoint {
        &self.endpoint
    }

    /// The frames sent and received since the last call, oldest first.
    pub fn take_trace(&mut self) -> Vec<TraceRecord> {
        self.trace.drain(..).collect()
    }

    /// Open the connection again after a failure.
    pub async fn reconnect(&mut self) -> Result<(), Error> {
        self.close().await;
        self.io = Io::Closed;
        self.io = open(&self.endpoint, self.timeout).await?;
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
        if self.trace.len() >= TRACE_LIMIT {
            self.trace.pop_front();
        }
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
        self.trace.push_back(TraceRecord {
            at: std::time::SystemTime::now(),
            sent,
            raw: hex(bytes),
            text,
            can: None,
        });
    }

    /// Send a request and wait for its answer. A device's exception is data
    /// (`Ok(Err(_))`); a connection that fails, times out or talks nonsense is an error.
    pub async fn transact(
        &mut self,
        request: &Request,
    ) -> Result<Result<Response, Exception>, Error> {
        let pdu = request.encode();
        let what = format!("{} to {}", request.describe(), self.endpoint.describe());
        let deadline = Instant::now() + self.timeout;
        let answer = match self.io {
            Io::Tcp(_) => self.transact_tcp(&pdu, &what, deadline).await?,
            Io::Rtu(_) => self.transact_rtu(&pdu, &what, deadline).await?,
            Io::Closed => {
                return Err(Error::Disconnected(format!(
                    "{what}: the connection is closed (reopening failed)"
                )));
            }
        };
        Response::decode(request, &answer)
            .map_err(|e| Error::Protocol(format!("{what}: {e}; reply {}", hex(&answer))))
    }

    async fn transact_tcp(
        &mut self,
        pdu: &[u8],
        what: &str,
        deadline: Instant,
    ) -> Result<Vec<u8>, Error> {
        let Endpoint::Tcp { unit, .. } = self.endpoint else {
            return Err(Error::Protocol("TCP transaction on a serial link".into()));
        };
        self.transaction = self.transaction.wrapping_add(1);
        let transaction = self.transaction;
        let adu = frame::encode_tcp(transaction, unit, pdu);
        self.record(true, &adu);
        let Io::Tcp(stream) = &mut self.io else {
            return Err(Error::Protocol("TCP transaction on a serial link".into()));
        };
        let written = tokio::time::timeout_at(deadline.into(), stream.write_all(&adu)).await;
        match written {
            Err(_) => {
                return Err(Error::Timeout {
                    what: what.to_owned(),
                    after: self.timeout,
                });
            }
            Ok(Err(e)) => return Err(io_error(what, e)),
            Ok(Ok(())) => {}
        }
        loop {
            // A whole frame waiting already?
            match frame::decode_tcp(&self.buffer) {
                Ok(Some((frame, used))) => {
                    let raw = self.buffer[..used].to_vec();
                    self.buffer.drain(..used);
                    self.record(false, &raw);
                    if frame.transaction != transaction {
                        // A late answer to a request that timed out: skip it.
                        continue;
                    }
                    return Ok(frame.pdu);
                }
                Ok(None) => {}
                Err(e) => {
                    let raw = std::mem::take(&mut self.buffer);
                    self.record(false, &raw);
                    return Err(Error::Protocol(format!(
                        "{what}: garbage instead of a Modbus TCP frame ({e}): {}",
                        hex(&raw)
                    )));
                }
            }
            let Io::Tcp(stream) = &mut self.io else {
                return Err(Error::Protocol("TCP transaction on a serial link".into()));
            };
            let mut chunk = [0u8; 512];
            match tokio::time::timeout_at(deadline.into(), stream.read(&mut chunk)).await {
                Err(_) => {
                    return Err(Error::Timeout {
                        what: what.to_owned(),
                        after: self.timeout,
                    });
                }
                Ok(Err(e)) => return Err(io_error(what, e)),
                Ok(Ok(0)) => {
                    return Err(Error::Disconnected(format!(
                        "{what}: the drive closed the connection (a Nanotec drive allows one Modbus TCP connection; if another client such as Plug & Drive Studio or a PLC holds it, close that one)"
                    )));
                }
                Ok(Ok(n)) => self.buffer.extend_from_slice(&chunk[..n]),
            }
        }
    }

    async fn transact_rtu(
        &mut self,
        pdu: &[u8],
        what: &str,
        deadline: Instant,
    ) -> Result<Vec<u8>, Error> {
        let Endpoint::Rtu { slave, baud, .. } = self.endpoint else {
            return Err(Error::Protocol("RTU transaction on a TCP link".into()));
        };
        // Keep the bus silent long enough between frames.
        if let Some(last) = self.last_answer {
            let quiet_until = last + rtu_gap(baud);
            tokio::time::sleep_until(quiet_until.into()).await;
        }
        let adu = frame::encode_rtu(slave, pdu);
        self.record(true, &adu);
        let Io::Rtu(port) = &mut self.io else {
            return Err(Error::Protocol("RTU transaction on a TCP link".into()));
        };
        // Whatever is still in the buffer belongs to nothing we asked.
        let _ = port.clear(tokio_serial::ClearBuffer::Input);
        self.buffer.clear();
        match tokio::time::timeout_at(deadline.into(), port.write_all(&adu)).await {
            Err(_) => {
                return Err(Error::Timeout {
                    what: what.to_owned(),
                    after: self.timeout,
                });
            }
            Ok(Err(e)) => return Err(io_error(what, e)),
            Ok(Ok(())) => {}
        }
        loop {
            match frame::decode_rtu(&self.buffer, Direction::Response) {
                Ok(Some((frame, used))) => {
                    let raw = self.buffer[..used].to_vec();
                    self.buffer.drain(..used);
                    self.record(false, &raw);
                    self.last_answer = Some(Instant::now());
                    if frame.slave != slave {
                        return Err(Error::Protocol(format!(
                            "{what}: the answer came from slave {} (another device answers on this address?)",
                            frame.slave
                        )));
                    }
                    return Ok(frame.pdu);
                }
                Ok(None) => {}
                Err(e) => {
                    let raw = std::mem::take(&mut self.buffer);
                    self.record(false, &raw);
                    self.last_answer = Some(Instant::now());
                    return Err(Error::Protocol(format!(
                        "{what}: garbled RTU frame ({e}): {} — check baud rate, parity and wiring",
                        hex(&raw)
                    )));
                }
            }
            let Io::Rtu(port) = &mut self.io else {
                return Err(Error::Protocol("RTU transaction on a TCP link".into()));
            };
            let mut chunk = [0u8; 256];
            match tokio::time::timeout_at(deadline.into(), port.read(&mut chunk)).await {
                Err(_) => {
                    self.last_answer = Some(Instant::now());
                    let heard = if self.buffer.is_empty() {
                        "no answer".to_owned()
                    } else {
                        format!("an incomplete answer {}", hex(&self.buffer))
                    };
                    return Err(Error::Timeout {
                        what: format!(
                            "{what} ({heard}; check the slave address, baud rate and parity)"
                        ),
                        after: self.timeout,
                    });
                }
                Ok(Err(e)) => return Err(io_error(what, e)),
                Ok(Ok(0)) => {
                    return Err(Error::Disconnected(format!(
                        "{what}: the serial port closed"
                    )));
                }
                Ok(Ok(n)) => self.buffer.extend_from_slice(&chunk[..n]),
            }
        }
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

async fn open(endpoint: &Endpoint, timeout: Duration) -> Result<Io, Error> {
    match endpoint {
        Endpoint::Tcp { host, port, .. } => {
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
        Endpoint::Rtu {
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
    }
}
