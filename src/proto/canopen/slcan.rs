//! slcan, the Lawicel serial-line CAN protocol that CANable, USBtin, CANUSB and CAN232
//! adapters speak over a (virtual) serial port.
//!
//! Every message is one line of ASCII ending in `\r`:
//!
//! | line | meaning |
//! | --- | --- |
//! | `tIIILDD…` | data frame, 11-bit id (3 hex digits), length digit 0-8, data in hex |
//! | `TIIIIIIIILDD…` | data frame, 29-bit id (8 hex digits) |
//! | `rIIIL`, `RIIIIIIIIL` | remote frames (the length asked for, no data) |
//! | `C`, `Sn`, `O`, `L` | close the channel, set the bit rate (`S0` 10k … `S8` 1M), open it, open it listen-only |
//! | `\r` alone | the adapter's "OK" |
//! | BEL (07h), no `\r` | the adapter's "error" |
//!
//! An adapter sends each frame it receives from the bus as such a line; with `Z1` it
//! appends a 4-hex-digit millisecond timestamp (0000-EA5F). Lawicel adapters answer a
//! transmitted frame with `z\r`/`Z\r`, CANable firmware with `\r`.
//!
//! This module is the sans-IO codec: [`encode_frame`], [`decode_line`], [`bitrate_command`],
//! [`LineSplitter`] (bytes in, decoded lines out, whatever the wire brings) and
//! [`AdapterState`] (what an adapter answers to each line). The serial ends that run it,
//! the host's `SlcanBus` and the emulated adapter `SlcanDevice`, are in
//! `crate::link::canopen::slcan`.

use std::collections::VecDeque;
use std::fmt;
use std::time::{Duration, Instant};

use super::CanFrame;

/// The standard slcan bit rates and their commands (CiA 301 rates; 83.3k has no standard
/// code).
pub const BITRATES: [(u32, &str); 9] = [
    (10_000, "S0"),
    (20_000, "S1"),
    (50_000, "S2"),
    (100_000, "S3"),
    (125_000, "S4"),
    (250_000, "S5"),
    (500_000, "S6"),
    (800_000, "S7"),
    (1_000_000, "S8"),
];

/// The longest line the splitter keeps before it gives up on it. The longest legal line is
/// an extended frame with 8 data bytes and a timestamp: 1 + 8 + 1 + 16 + 4 = 30 characters.
pub const MAX_LINE: usize = 64;

/// How long the host waits for the adapter's answer to `C`, `Sn` and `O`.
pub const REPLY_TIMEOUT: Duration = Duration::from_secs(1);

/// The serial speed used to open an adapter. USB adapters (CANable, USBtin, CANUSB)
/// ignore it; a Lawicel CAN232 on a real RS-232 port must be set to it.
pub const SERIAL_BAUD: u32 = 115_200;

/// The adapter's "OK": a `\r` alone.
pub const OK: u8 = b'\r';
const BEL: u8 = 0x07;

/// What an slcan line can be, besides a frame.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SlcanLine {
    /// A CAN frame (from the bus, or one the host asks to transmit).
    Frame(CanFrame),
    /// An empty line: the adapter's "OK".
    Ack,
    /// BEL (07h): the adapter's "error".
    Error,
    /// Any other printable line: a command (`S8`, `O`), a version (`V1013`), a serial
    /// number, status flags, `z`/`Z` transmit acknowledgements.
    Other(String),
}

/// Bytes that are not slcan, and bit rates slcan has no command for.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum SlcanError {
    #[error(
        "{0} bit/s is not a standard slcan bit rate; choose one of 10000, 20000, 50000, 100000, 125000, 250000, 500000, 800000 or 1000000 (S0 to S8)"
    )]
    Bitrate(u32),
    #[error("malformed slcan frame `{line}`: {reason}")]
    Frame { line: String, reason: String },
    #[error("not an slcan line: `{0}`")]
    Garbage(String),
    #[error(
        "more than {MAX_LINE} characters without a line end (`{0}…`): not slcan, or the serial speed is wrong"
    )]
    TooLong(String),
}

/// The command that sets `bitrate` (bit/s), e.g. `S8` for 1 Mbit/s.
pub fn bitrate_command(bitrate: u32) -> Result<&'static str, SlcanError> {
    BITRATES
        .iter()
        .find(|(rate, _)| *rate == bitrate)
        .map(|(_, command)| *command)
        .ok_or(SlcanError::Bitrate(bitrate))
}

/// The line that transmits `frame` (host to adapter) or reports it (adapter to host):
/// `t1232AABB\r`, `T0000012340\r`, `r1238\r`, `R000001232\r`. Hex is uppercase.
pub fn encode_frame(frame: &CanFrame) -> Vec<u8> {
    use std::fmt::Write;
    let kind = match (frame.is_extended(), frame.is_remote()) {
        (false, false) => 't',
        (true, false) => 'T',
        (false, true) => 'r',
        (true, true) => 'R',
    };
    let mut line = String::with_capacity(1 + 8 + 1 + 16 + 1);
    line.push(kind);
    // Writing to a String cannot fail.
    if frame.is_extended() {
        let _ = write!(line, "{:08X}", frame.id());
    } else {
        let _ = write!(line, "{:03X}", frame.id());
    }
    let _ = write!(line, "{}", frame.len());
    for byte in frame.data() {
        let _ = write!(line, "{byte:02X}");
    }
    line.push('\r');
    line.into_bytes()
}

/// Decode one line, with or without its `\r`. Tolerates a `\n` after the `\r` (adapters
/// set to CR/LF), lowercase hex and a 4-digit timestamp after a frame (`Z1`).
pub fn decode_line(line: &[u8]) -> Result<SlcanLine, SlcanError> {
    let mut line = line;
    while let [rest @ .., b'\r' | b'\n'] = line {
        line = rest;
    }
    while let [b'\n', rest @ ..] = line {
        line = rest;
    }
    match line {
        [] => Ok(SlcanLine::Ack),
        [BEL] => Ok(SlcanLine::Error),
        [b't' | b'T' | b'r' | b'R', ..] => decode_frame(line).map(SlcanLine::Frame),
        _ if line.len() <= MAX_LINE && line.iter().all(|b| (0x20..=0x7E).contains(b)) => {
            // All printable ASCII, so this is valid UTF-8.
            Ok(SlcanLine::Other(String::from_utf8_lossy(line).into_owned()))
        }
        _ => Err(SlcanError::Garbage(shown(line))),
    }
}

fn decode_frame(line: &[u8]) -> Result<CanFrame, SlcanError> {
    let bad = |reason: &str| SlcanError::Frame {
        line: shown(line),
        reason: reason.to_owned(),
    };
    let kind = line[0];
    let extended = kind.is_ascii_uppercase();
    let remote = matches!(kind, b'r' | b'R');
    let id_digits = if extended { 8 } else { 3 };
    let rest = &line[1..];
    if rest.len() < id_digits + 1 {
        return Err(bad("too short for an identifier and a length"));
    }
    let id = parse_hex(&rest[..id_digits]).ok_or_else(|| bad("the identifier is not hex"))?;
    let len = match rest[id_digits] {
        digit @ b'0'..=b'8' => usize::from(digit - b'0'),
        _ => return Err(bad("the length is not a digit from 0 to 8")),
    };
    let tail = &rest[id_digits + 1..];
    let data_digits = if remote { 0 } else { 2 * len };
    if tail.len() < data_digits {
        return Err(bad("fewer data bytes than the length says"));
    }
    let (hex, after) = tail.split_at(data_digits);
    match after.len() {
        0 => {}
        4 if parse_hex(after).is_some() => {} // a timestamp (Z1)
        _ => {
            return Err(bad(
                "unexpected characters after the data (a timestamp has exactly 4 hex digits)",
            ));
        }
    }
    let mut data = [0u8; 8];
    for (i, pair) in hex.chunks_exact(2).enumerate() {
        // At most 8 pairs: `len` is at most 8.
        data[i] = parse_hex(pair).ok_or_else(|| bad("a data byte is not hex"))? as u8;
    }
    // A remote frame carries its length but no data: `with` keeps the length of the
    // (zero) slice and `data()` hides it.
    CanFrame::with(id, extended, remote, &data[..len]).map_err(|e| bad(&e.to_string()))
}

fn parse_hex(digits: &[u8]) -> Option<u32> {
    if digits.is_empty() || digits.len() > 8 {
        return None;
    }
    digits.iter().try_fold(0u32, |acc, &d| {
        let nibble = char::from(d).to_digit(16)?;
        Some(acc << 4 | nibble)
    })
}

/// A line for an error message: printable, control bytes escaped, cut at `MAX_LINE`.
fn shown(line: &[u8]) -> String {
    let cut = &line[..line.len().min(MAX_LINE)];
    cut.escape_ascii().to_string()
}

/// Splits the byte stream of a serial port into decoded lines, however the bytes arrive:
/// a line may come in pieces, several lines in one read, garbage in between.
///
/// `\r` ends a line; BEL is a line of its own (the adapter's error has no `\r`); a `\n`
/// at the start of a line is skipped (CR/LF adapters). A line that grows past
/// [`MAX_LINE`] is reported once as [`SlcanError::TooLong`] and the rest of it, up to the
/// next line end, is dropped, so the splitter never holds more than `MAX_LINE` bytes.
#[derive(Debug, Default)]
pub struct LineSplitter {
    partial: Vec<u8>,
    overlong: bool,
    lines: VecDeque<Result<SlcanLine, SlcanError>>,
}

impl LineSplitter {
    pub fn new() -> Self {
        Self::default()
    }

    /// Feed bytes as they arrive.
    pub fn push(&mut self, bytes: &[u8]) {
        for &byte in bytes {
            match byte {
                OK => {
                    if self.overlong {
                        self.overlong = false;
                    } else {
                        let line = std::mem::take(&mut self.partial);
                        self.lines.push_back(decode_line(&line));
                    }
                }
                BEL => {
                    if !self.partial.is_empty() {
                        // Whatever came before the BEL never got its `\r`.
                        let fragment = std::mem::take(&mut self.partial);
                        self.lines
                            .push_back(Err(SlcanError::Garbage(shown(&fragment))));
                    }
                    self.overlong = false;
                    self.lines.push_back(Ok(SlcanLine::Error));
                }
                b'\n' if self.partial.is_empty() => {}
                _ if self.overlong => {}
                _ if self.partial.len() >= MAX_LINE => {
                    let line = std::mem::take(&mut self.partial);
                    self.lines.push_back(Err(SlcanError::TooLong(shown(&line))));
                    self.overlong = true;
                }
                _ => self.partial.push(byte),
            }
        }
    }

    /// The next complete line, decoded.
    pub fn next_line(&mut self) -> Option<Result<SlcanLine, SlcanError>> {
        self.lines.pop_front()
    }

    /// The bytes of the line not yet ended.
    pub fn partial(&self) -> &[u8] {
        &self.partial
    }
}

/// "1 Mbit/s", "500 kbit/s", "83300 bit/s".
pub fn rate_text(bitrate: u32) -> String {
    if bitrate >= 1_000_000 && bitrate.is_multiple_of(1_000_000) {
        format!("{} Mbit/s", bitrate / 1_000_000)
    } else if bitrate >= 1000 && bitrate.is_multiple_of(1000) {
        format!("{} kbit/s", bitrate / 1000)
    } else {
        format!("{bitrate} bit/s")
    }
}

// ---------------------------------------------------------------------------------------
// The adapter's behaviour, sans IO.

/// What an slcan adapter does with each line the host sends: the command interpreter of
/// [`SlcanDevice`], without the serial port. It answers like a CANable (`\r` for OK, also
/// after a transmitted frame; BEL for errors) and refuses what a Lawicel adapter refuses
/// (a bit rate while the channel is open, frames while it is closed).
#[derive(Clone, Debug)]
pub struct AdapterState {
    open: Option<Mode>,
    bitrate: Option<u32>,
    timestamps: bool,
    opened_at: Option<Instant>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mode {
    Normal,
    ListenOnly,
}

/// What the adapter does with one line from the host.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Handled {
    /// The bytes to send back (`\r`, BEL, `V1010\r`, …).
    pub reply: Vec<u8>,
    /// A frame the host transmits onto the bus.
    pub frame: Option<CanFrame>,
}

impl Handled {
    /// `\r`, with the frame to transmit if any.
    fn ok(frame: Option<CanFrame>) -> Self {
        Handled {
            reply: vec![OK],
            frame,
        }
    }

    /// BEL: the adapter refuses the line.
    fn refuse() -> Self {
        Handled {
            reply: vec![BEL],
            frame: None,
        }
    }

    /// A reply with text (`V1010\r`, …).
    fn answer(text: &[u8]) -> Self {
        Handled {
            reply: text.to_vec(),
            frame: None,
        }
    }
}

/// `V`: hardware 1.0, software 1.0 (python-can's `get_version` reads two decimal pairs).
const VERSION_REPLY: &[u8] = b"V1010\r";
/// `v`: firmware version (USBtin style).
const FIRMWARE_REPLY: &[u8] = b"v0100\r";
/// `N`: four characters of serial number.
const SERIAL_REPLY: &[u8] = b"NDDSM\r";

impl Default for AdapterState {
    fn default() -> Self {
        Self::new()
    }
}

impl AdapterState {
    /// Closed, bit rate not set (the adapter's default), no timestamps.
    pub fn new() -> Self {
        AdapterState {
            open: None,
            bitrate: None,
            timestamps: false,
            opened_at: None,
        }
    }

    pub fn is_open(&self) -> bool {
        self.open.is_some()
    }

    pub fn is_listen_only(&self) -> bool {
        self.open == Some(Mode::ListenOnly)
    }

    /// The bit rate set with `Sn`, `None` before any (or after a custom `s` timing).
    pub fn bitrate(&self) -> Option<u32> {
        self.bitrate
    }

    pub fn timestamps(&self) -> bool {
        self.timestamps
    }

    /// Act on one line from the host, at `now` (the timestamps count from the opening).
    pub fn handle(&mut self, line: Result<SlcanLine, SlcanError>, now: Instant) -> Handled {
        let line = match line {
            Ok(line) => line,
            Err(_) => return Handled::refuse(),
        };
        match line {
            // An empty command (python-can sends one after `S8`): nothing to do.
            SlcanLine::Ack => Handled::ok(None),
            // The host does not send errors; nothing to answer.
            SlcanLine::Error => Handled::default(),
            SlcanLine::Frame(frame) => match self.open {
                Some(Mode::Normal) => Handled::ok(Some(frame)),
                // Closed: nothing goes on the bus. Listen-only: the adapter may not send.
                _ => Handled::refuse(),
            },
            SlcanLine::Other(command) => self.command(command.as_bytes(), now),
        }
    }

    /// A command other than a frame: open, close, bit rate, version, settings.
    fn command(&mut self, command: &[u8], now: Instant) -> Handled {
        let closed = self.open.is_none();
        match command {
            b"O" => self.open_channel(Mode::Normal, now),
            b"L" => self.open_channel(Mode::ListenOnly, now),
            b"C" => {
                self.open = None;
                self.opened_at = None;
                Handled::ok(None)
            }
            [b'S', digit @ b'0'..=b'8'] if closed => {
                self.bitrate = Some(BITRATES[usize::from(digit - b'0')].0);
                Handled::ok(None)
            }
            // BTR0/BTR1 (SJA1000) or a CANable 2 timing: accepted, rate unknown.
            [b's', timing @ ..]
                if closed
                    && matches!(timing.len(), 4 | 8)
                    && timing.iter().all(u8::is_ascii_hexdigit) =>
            {
                self.bitrate = None;
                Handled::ok(None)
            }
            b"V" => Handled::answer(VERSION_REPLY),
            b"v" => Handled::answer(FIRMWARE_REPLY),
            b"N" => Handled::answer(SERIAL_REPLY),
            // Status flags: nothing to report (Lawicel: only while open).
            b"F" if !closed => Handled::answer(b"F00\r"),
            [b'Z', flag @ (b'0' | b'1')] => {
                self.timestamps = *flag == b'1';
                Handled::ok(None)
            }
            // Auto poll, auto start, UART speed, filter mode, automatic
            // retransmission, CANable mode: accepted, nothing changes here.
            [b'X', b'0' | b'1']
            | [b'Q', b'0'..=b'2']
            | [b'U', b'0'..=b'6']
            | [b'W', b'0'..=b'2']
            | [b'A' | b'a', b'0' | b'1']
            | [b'M' | b'm', b'0' | b'1'] => Handled::ok(None),
            // Acceptance code and mask: everything passes.
            [b'M' | b'm', code @ ..]
                if closed && code.len() == 8 && code.iter().all(u8::is_ascii_hexdigit) =>
            {
                Handled::ok(None)
            }
            _ => Handled::refuse(),
        }
    }

    /// `O` or `L`. Opening an open channel is fine (a CANable does not mind, and
    /// python-can sends `O` twice).
    fn open_channel(&mut self, mode: Mode, now: Instant) -> Handled {
        if self.open != Some(mode) {
            self.open = Some(mode);
            self.opened_at = Some(now);
        }
        Handled::ok(None)
    }

    /// The line that reports `frame` from the bus to the host, `None` while the channel is
    /// closed (an adapter drops what it cannot deliver).
    pub fn frame_line(&self, frame: &CanFrame, now: Instant) -> Option<Vec<u8>> {
        self.open?;
        let mut line = encode_frame(frame);
        if self.timestamps {
            let since = self
                .opened_at
                .map_or(0, |at| now.saturating_duration_since(at).as_millis());
            let stamp = format!("{:04X}", since % 60_000);
            line.pop();
            line.extend_from_slice(stamp.as_bytes());
            line.push(OK);
        }
        Some(line)
    }
}

impl fmt::Display for SlcanLine {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SlcanLine::Frame(frame) => write!(f, "{frame}"),
            SlcanLine::Ack => f.write_str("OK"),
            SlcanLine::Error => f.write_str("BEL"),
            SlcanLine::Other(text) => f.write_str(text),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(line: &str) -> CanFrame {
        match decode_line(line.as_bytes()) {
            Ok(SlcanLine::Frame(frame)) => frame,
            other => panic!("{line:?} gave {other:?}"),
        }
    }

    #[test]
    fn lines_match_the_lawicel_examples() {
        // CAN232 manual: t1002AA33 is id 100h with AA 33.
        let f = CanFrame::new(0x100, &[0xAA, 0x33]).unwrap();
        assert_eq!(encode_frame(&f), b"t1002AA33\r");
        assert_eq!(frame("t1002AA33\r"), f);
        let f = CanFrame::new(0x345, &[0x01, 0x23, 0x45, 0x67, 0x89, 0xAB, 0xCD, 0xEF]).unwrap();
        assert_eq!(encode_frame(&f), b"t34580123456789ABCDEF\r");
        assert_eq!(
            encode_frame(&CanFrame::new(0x456, &[]).unwrap()),
            b"t4560\r"
        );
        // r0023: remote request for 3 bytes from 002h.
        let r = CanFrame::remote(0x002, 3).unwrap();
        assert_eq!(encode_frame(&r), b"r0023\r");
        assert_eq!(frame("r0023"), r);
        let x = CanFrame::with(0x1234_5678, true, false, &[0xDE, 0xAD]).unwrap();
        assert_eq!(encode_frame(&x), b"T123456782DEAD\r");
        let xr = CanFrame::with(0x1F, true, true, &[0; 8]).unwrap();
        assert_eq!(encode_frame(&xr), b"R0000001F8\r");
        assert_eq!(frame("R0000001F8\r"), xr);
    }

    #[test]
    fn decoding_tolerates_timestamps_lowercase_and_crlf() {
        let f = CanFrame::new(0x181, &[0x0A, 0xFF]).unwrap();
        assert_eq!(frame("t18120AFF1A2B\r"), f);
        assert_eq!(frame("t18120aff\r\n"), f);
        assert_eq!(frame("\nt18120AFF"), f);
        assert_eq!(frame("r1812EA5F"), CanFrame::remote(0x181, 2).unwrap());
        assert_eq!(decode_line(b"\r"), Ok(SlcanLine::Ack));
        assert_eq!(decode_line(b""), Ok(SlcanLine::Ack));
        assert_eq!(decode_line(b"\x07"), Ok(SlcanLine::Error));
        assert_eq!(
            decode_line(b"V1013\r"),
            Ok(SlcanLine::Other("V1013".into()))
        );
        assert_eq!(decode_line(b"z\r"), Ok(SlcanLine::Other("z".into())));
    }

    #[test]
    fn malformed_frames_say_what_is_wrong() {
        for bad in [
            "t12",        // no length
            "t1239",      // length 9
            "t12320A",    // one byte of two
            "t1230AB",    // two stray digits
            "t1230ABCDE", // five
            "tX230",      // id not hex
            "t8000",      // 800h does not fit 11 bits
            "T200000000", // 29 bits
            "t1231ZZ",    // data not hex
            "T1234",      // short extended
        ] {
            match decode_line(bad.as_bytes()) {
                Err(SlcanError::Frame { line, .. }) => assert_eq!(line, bad),
                other => panic!("{bad:?} gave {other:?}"),
            }
        }
        assert!(matches!(
            decode_line(b"\x00\xff\x01"),
            Err(SlcanError::Garbage(_))
        ));
        let e = decode_line(b"t8000").unwrap_err().to_string();
        assert!(e.contains("t8000") && e.contains("11 bits"), "{e}");
    }

    #[test]
    fn bit_rates_have_their_commands() {
        assert_eq!(bitrate_command(1_000_000), Ok("S8"));
        assert_eq!(bitrate_command(125_000), Ok("S4"));
        assert_eq!(bitrate_command(800_000), Ok("S7"));
        assert_eq!(bitrate_command(10_000), Ok("S0"));
        let e = bitrate_command(83_300).unwrap_err();
        assert_eq!(e, SlcanError::Bitrate(83_300));
        assert!(
            e.to_string()
                .contains("125000, 250000, 500000, 800000 or 1000000")
        );
        assert_eq!(rate_text(1_000_000), "1 Mbit/s");
        assert_eq!(rate_text(500_000), "500 kbit/s");
        assert_eq!(rate_text(83_300), "83300 bit/s");
    }

    #[test]
    fn the_splitter_reassembles_pieces_and_survives_garbage() {
        let mut s = LineSplitter::new();
        s.push(b"t12");
        assert!(s.next_line().is_none());
        assert_eq!(s.partial(), b"t12");
        s.push(b"31AA\r\x07\r\nV1013\rgarb\x07");
        assert_eq!(
            s.next_line(),
            Some(Ok(SlcanLine::Frame(CanFrame::new(0x123, &[0xAA]).unwrap())))
        );
        assert_eq!(s.next_line(), Some(Ok(SlcanLine::Error)));
        assert_eq!(s.next_line(), Some(Ok(SlcanLine::Ack)));
        assert_eq!(s.next_line(), Some(Ok(SlcanLine::Other("V1013".into()))));
        assert!(matches!(s.next_line(), Some(Err(SlcanError::Garbage(_)))));
        assert_eq!(s.next_line(), Some(Ok(SlcanLine::Error)));
        assert!(s.next_line().is_none());
        // An endless line is reported once and dropped up to its end.
        s.push(&[b'x'; 500]);
        assert!(s.partial().len() <= MAX_LINE);
        s.push(b"\rt1230\r");
        assert!(matches!(s.next_line(), Some(Err(SlcanError::TooLong(_)))));
        assert_eq!(
            s.next_line(),
            Some(Ok(SlcanLine::Frame(CanFrame::new(0x123, &[]).unwrap())))
        );
        assert!(s.next_line().is_none());
    }

    fn feed(state: &mut AdapterState, line: &str) -> Handled {
        state.handle(decode_line(line.as_bytes()), Instant::now())
    }

    #[test]
    fn the_adapter_answers_python_can_opening() {
        // python-can 4.6 `slcanBus(bitrate=1000000)`: C, S8, an empty line (no data bit
        // rate), O, and O again from the constructor.
        let mut a = AdapterState::new();
        for line in ["C", "S8", "", "O", "O"] {
            assert_eq!(feed(&mut a, line).reply, b"\r", "{line:?}");
        }
        assert!(a.is_open());
        assert_eq!(a.bitrate(), Some(1_000_000));
        let f = CanFrame::new(0x601, &[0x40, 0x00, 0x10, 0x00]).unwrap();
        let h = feed(&mut a, "t601440001000");
        assert_eq!(h.reply, b"\r");
        assert_eq!(h.frame, Some(f));
        assert_eq!(feed(&mut a, "V").reply, b"V1010\r");
        assert_eq!(feed(&mut a, "N").reply, b"NDDSM\r");
        assert_eq!(feed(&mut a, "F").reply, b"F00\r");
        // No bit rate change while open.
        assert_eq!(feed(&mut a, "S6").reply, b"\x07");
        assert_eq!(feed(&mut a, "C").reply, b"\r");
        // Closed: frames are refused both ways.
        assert_eq!(feed(&mut a, "t1230").reply, b"\x07");
        assert_eq!(a.frame_line(&f, Instant::now()), None);
        assert_eq!(feed(&mut a, "S9").reply, b"\x07");
        assert_eq!(feed(&mut a, "what").reply, b"\x07");
        assert_eq!(feed(&mut a, "t12").reply, b"\x07");
        assert_eq!(feed(&mut a, "s031C").reply, b"\r");
        assert_eq!(a.bitrate(), None);
        // Listen-only: frames from the host are refused, frames to it delivered.
        assert_eq!(feed(&mut a, "L").reply, b"\r");
        assert!(a.is_listen_only());
        assert_eq!(feed(&mut a, "t1230").reply, b"\x07");
        assert_eq!(
            a.frame_line(&f, Instant::now()),
            Some(b"t601440001000\r".to_vec())
        );
    }

    #[test]
    fn the_adapter_stamps_frames_after_z1() {
        let mut a = AdapterState::new();
        let start = Instant::now();
        assert_eq!(
            a.handle(Ok(SlcanLine::Other("Z1".into())), start).reply,
            b"\r"
        );
        assert_eq!(
            a.handle(Ok(SlcanLine::Other("O".into())), start).reply,
            b"\r"
        );
        let f = CanFrame::new(0x701, &[0x05]).unwrap();
        let line = a
            .frame_line(&f, start + Duration::from_millis(0x1A2))
            .unwrap();
        assert_eq!(line, b"t70110501A2\r");
        assert_eq!(decode_line(&line), Ok(SlcanLine::Frame(f)));
        // The stamp wraps at 60 s, like a Lawicel adapter's.
        let line = a
            .frame_line(&f, start + Duration::from_millis(60_001))
            .unwrap();
        assert_eq!(line, b"t7011050001\r");
    }
}
