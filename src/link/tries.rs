//! Sending a request again: how often, what each try met, and the error when every try
//! went wrong. Shared by the links that own a byte stream (Modbus TCP/RTU, EtherNet/IP)
//! and by CANopen's SDO transfers.

use std::time::{Duration, Instant};

use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};

use super::Error;

/// How often one request goes out before a link gives up on it: a lost, late, corrupted
/// or mismatched reply is worth another try within the request's timeout.
pub const TRIES: u32 = 3;

/// How a try without an answer is described (and told apart when every try timed out).
pub(crate) const NO_ANSWER: &str = "no answer within";

/// How one try of a request ended when it brought no usable answer.
pub(crate) enum Trouble {
    /// A lost, late, corrupted or mismatched reply: worth sending again.
    Retry(String),
    /// The connection itself failed: sending again cannot help.
    Fatal(Error),
}

/// The error after every try of `what` went wrong: a timeout when nothing came back at
/// all (with `hint`, what to check), otherwise each try's trouble named.
pub(crate) fn gave_up(what: String, troubles: Vec<String>, waited: Duration, hint: &str) -> Error {
    if troubles.iter().all(|t| t.starts_with(NO_ANSWER)) {
        let hint = if hint.is_empty() {
            String::new()
        } else {
            format!("; {hint}")
        };
        return Error::Timeout {
            what: format!("{what} ({TRIES} tries{hint})"),
            after: waited,
        };
    }
    Error::NoValidReply {
        what,
        tries: TRIES,
        troubles,
    }
}

/// Write `bytes` before `deadline`: a write that cannot finish, or fails, ends the request
/// (sending again cannot help), the failure named by `io_error`.
pub(crate) async fn send_within<W: AsyncWrite + Unpin, D: std::fmt::Display + ?Sized>(
    writer: &mut W,
    bytes: &[u8],
    deadline: Instant,
    what: &D,
    timeout: Duration,
    io_error: impl FnOnce(&str, std::io::Error) -> Error,
) -> Result<(), Trouble> {
    match tokio::time::timeout_at(deadline.into(), writer.write_all(bytes)).await {
        Err(_) => Err(Trouble::Fatal(Error::Timeout {
            what: format!("{what}: sending"),
            after: timeout,
        })),
        Ok(Err(e)) => Err(Trouble::Fatal(io_error(&what.to_string(), e))),
        Ok(Ok(())) => Ok(()),
    }
}

/// Read what comes next (up to `CHUNK` bytes) onto `buffer` before `deadline`: `true`
/// when something came, `false` at the deadline. A read that fails, or a peer that
/// closes the stream (`closed` says what closed), ends the request.
pub(crate) async fn read_within<
    R: AsyncRead + Unpin,
    const CHUNK: usize,
    D: std::fmt::Display + ?Sized,
>(
    reader: &mut R,
    buffer: &mut Vec<u8>,
    deadline: Instant,
    what: &D,
    closed: &str,
    io_error: impl FnOnce(&str, std::io::Error) -> Error,
) -> Result<bool, Trouble> {
    let mut chunk = [0u8; CHUNK];
    match tokio::time::timeout_at(deadline.into(), reader.read(&mut chunk)).await {
        Err(_) => Ok(false),
        Ok(Err(e)) => Err(Trouble::Fatal(io_error(&what.to_string(), e))),
        Ok(Ok(0)) => Err(Trouble::Fatal(Error::Disconnected(format!(
            "{what}: {closed}"
        )))),
        Ok(Ok(n)) => {
            buffer.extend_from_slice(&chunk[..n]);
            Ok(true)
        }
    }
}

/// A try that heard nothing usable since `sent_at`; `partial`, where part of a `unit`
/// (frame, message) came, is said (the caller drops it and starts clean).
pub(crate) fn silence(sent_at: Instant, partial: Option<(&str, String)>) -> Trouble {
    let heard = match partial {
        None => String::new(),
        Some((unit, hex)) => format!(" (only part of a {unit} came: {hex})"),
    };
    Trouble::Retry(format!(
        "{NO_ANSWER} {} ms{heard}",
        sent_at.elapsed().as_millis()
    ))
}
