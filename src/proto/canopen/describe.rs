//! One line of text per CAN frame for the frame log, and the candump log format for exports.
//!
//! [`describe`] reads a frame by the predefined connection set (protocol notes §2.2 to
//! §2.4): "NMT start node 1", "heartbeat node 1: operational", "SDO request node 1: upload
//! 1018h:01h", "SDO abort node 1 1018h:09h: 06090011h (Sub-index does not exist)", …
//!
//! [`candump_line`] writes the format of `candump -l` / `candump -L` (can-utils `candump.c`
//! and `lib.c`, also python-can's `CanutilsLogWriter`):
//!
//! ```text
//! (1700000000.123456) can0 601#4018100100000000
//! (0000000012.000500) can0 12345678#0102          29-bit identifier: 8 hex digits
//! (0000000012.000500) can0 181#R8                 remote frame with DLC (R alone for DLC 0)
//! ```
//!
//! and [`parse_candump_line`] reads it back (also lower-case hex, `.` between data bytes and
//! interface names padded by candump when it logs several interfaces).

use std::fmt::Write as _;

use super::CanFrame;
use super::emcy::Emcy;
use super::nmt::{Cob, NmtState, classify, decode_command, decode_heartbeat};
use super::sdo::{Initiate, Request, Response, Segment};
use crate::cia::ErrorCode;
use crate::number::hex;

/// "4 bytes 6C 02 00 00", "1 byte 05", "0 bytes".
fn bytes_text(data: &[u8]) -> String {
    let mut out = match data.len() {
        1 => "1 byte".to_owned(),
        n => format!("{n} bytes"),
    };
    for b in data {
        let _ = write!(out, " {b:02X}");
    }
    out
}

fn object(index: u16, sub: u8) -> String {
    format!("{index:04X}h:{sub:02X}h")
}

fn segment_text(segment: &Segment) -> String {
    let mut out = format!(
        "toggle {}, {}",
        u8::from(segment.toggle),
        bytes_text(segment.data())
    );
    if segment.last {
        out.push_str(", last");
    }
    out
}

/// A line for the frame log.
pub fn describe(frame: &CanFrame) -> String {
    let Some(cob_id) = frame.cob_id() else {
        return format!("CAN {:08X}h (29-bit): {}", frame.id(), payload_text(frame));
    };
    match classify(cob_id) {
        Cob::Nmt => match decode_command(frame) {
            Ok((command, 0)) => format!("NMT {command} all nodes"),
            Ok((command, node)) => format!("NMT {command} node {node}"),
            Err(e) => format!("NMT: {e}; {}", payload_text(frame)),
        },
        Cob::Sync => match frame.data() {
            [counter] => format!("SYNC counter {counter}"),
            _ if frame.is_remote() || frame.is_empty() => "SYNC".to_owned(),
            _ => format!("SYNC: {}", payload_text(frame)),
        },
        Cob::Emcy { node } => match Emcy::decode(frame) {
            Ok((_, emcy)) => {
                let mut out = format!(
                    "EMCY node {node}: {} register {:02X}h",
                    ErrorCode(emcy.error_code),
                    emcy.error_register
                );
                if emcy.manufacturer != [0; 5] {
                    let _ = write!(out, ", manufacturer {}", hex(&emcy.manufacturer));
                }
                out
            }
            Err(e) => format!("EMCY node {node}: {e}"),
        },
        Cob::Heartbeat { node } => {
            if frame.is_remote() {
                return format!("node guarding request node {node}");
            }
            match decode_heartbeat(frame) {
                Ok((_, NmtState::BootUp)) => format!("boot-up node {node}"),
                Ok((_, state)) => {
                    let toggle = frame.data().first().is_some_and(|b| b & 0x80 != 0);
                    let toggle = if toggle { " (toggle 1)" } else { "" };
                    format!("heartbeat node {node}: {state}{toggle}")
                }
                Err(e) => format!("heartbeat node {node}: {e}"),
            }
        }
        Cob::Tpdo { n, node } => format!("TPDO{n} node {node}: {}", payload_text(frame)),
        Cob::Rpdo { n, node } => format!("RPDO{n} node {node}: {}", payload_text(frame)),
        Cob::SdoRequest { node } => describe_request(node, frame),
        Cob::SdoResponse { node } => describe_response(node, frame),
        Cob::Other => format!("CAN {cob_id:03X}h: {}", payload_text(frame)),
    }
}

fn payload_text(frame: &CanFrame) -> String {
    if frame.is_remote() {
        format!("remote request, DLC {}", frame.len())
    } else {
        bytes_text(frame.data())
    }
}

/// Command bytes this codec does not handle: block transfer (ccs/scs 5 and 6) and 7.
fn unsupported(byte0: u8, index: u16, sub: u8, request: bool) -> String {
    let what = match (byte0 >> 5, request) {
        (5, true) | (6, false) => "block upload",
        (6, true) | (5, false) => "block download",
        _ => return format!("invalid command byte {byte0:02X}h"),
    };
    format!(
        "{what} {} (command byte {byte0:02X}h, not supported)",
        object(index, sub)
    )
}

fn describe_request(node: u8, frame: &CanFrame) -> String {
    if frame.is_remote() {
        return format!("SDO request node {node}: {}", payload_text(frame));
    }
    let text = match Request::decode(frame.data()) {
        Err(e) => e.to_string(),
        Ok(Request::InitiateUpload { index, sub }) => format!("upload {}", object(index, sub)),
        Ok(Request::UploadSegment { toggle }) => {
            format!("upload segment, toggle {}", u8::from(toggle))
        }
        Ok(Request::InitiateDownload {
            index,
            sub,
            initiate,
        }) => format!(
            "download {}, {}",
            object(index, sub),
            initiate_text(&initiate)
        ),
        Ok(Request::DownloadSegment(segment)) => {
            format!("download segment, {}", segment_text(&segment))
        }
        Ok(Request::Abort { index, sub, code }) => {
            return format!("SDO abort to node {node} {}: {code}", object(index, sub));
        }
        Ok(Request::Unknown { byte0, index, sub }) => unsupported(byte0, index, sub, true),
    };
    format!("SDO request node {node}: {text}")
}

fn initiate_text(initiate: &Initiate) -> String {
    match initiate {
        Initiate::Expedited { .. } => bytes_text(initiate.expedited_data().unwrap_or_default()),
        Initiate::Segmented { size: Some(size) } => format!("segmented, {size} bytes"),
        Initiate::Segmented { size: None } => "segmented, size not indicated".to_owned(),
    }
}

fn describe_response(node: u8, frame: &CanFrame) -> String {
    if frame.is_remote() {
        return format!("SDO response node {node}: {}", payload_text(frame));
    }
    let text = match Response::decode(frame.data()) {
        Err(e) => e.to_string(),
        Ok(Response::UploadInitiated {
            index,
            sub,
            initiate: initiate @ Initiate::Segmented { .. },
        }) => format!(
            "upload {}, {}",
            object(index, sub),
            initiate_text(&initiate)
        ),
        Ok(Response::UploadInitiated { initiate, .. }) => initiate_text(&initiate),
        Ok(Response::UploadSegment(segment)) => format!("segment, {}", segment_text(&segment)),
        Ok(Response::DownloadInitiated { index, sub }) => {
            format!("download {} acknowledged", object(index, sub))
        }
        Ok(Response::DownloadSegment { toggle }) => {
            format!("segment acknowledged, toggle {}", u8::from(toggle))
        }
        Ok(Response::Abort { index, sub, code }) => {
            return format!("SDO abort node {node} {}: {code}", object(index, sub));
        }
        Ok(Response::Unknown { byte0, index, sub }) => unsupported(byte0, index, sub, false),
    };
    format!("SDO response node {node}: {text}")
}

/// One line of a candump log (`candump -l`), without the line break:
/// `(1700000000.123456) can0 601#4018100100000000`. The time is in seconds (since the Unix
/// epoch for a real log); negative or non-finite times are written as 0.
pub fn candump_line(seconds: f64, interface: &str, frame: &CanFrame) -> String {
    let micros = if seconds.is_finite() && seconds > 0.0 {
        // Saturates for absurdly large times; never panics.
        (seconds * 1e6).round() as u64
    } else {
        0
    };
    let mut out = format!(
        "({:010}.{:06}) {interface} ",
        micros / 1_000_000,
        micros % 1_000_000
    );
    if frame.is_extended() {
        let _ = write!(out, "{:08X}#", frame.id());
    } else {
        let _ = write!(out, "{:03X}#", frame.id());
    }
    if frame.is_remote() {
        out.push('R');
        if !frame.is_empty() {
            let _ = write!(out, "{}", frame.len());
        }
    } else {
        for b in frame.data() {
            let _ = write!(out, "{b:02X}");
        }
    }
    out
}

/// One parsed candump log line.
#[derive(Clone, Debug, PartialEq)]
pub struct CandumpLine {
    /// The time stamp in seconds.
    pub seconds: f64,
    pub interface: String,
    pub frame: CanFrame,
}

/// A line that is not a classic CAN frame in candump's log format.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum CandumpError {
    #[error("'{0}': a candump log line reads '(seconds.micros) interface id#data'")]
    Shape(String),
    #[error("'{0}' is not a time stamp (seconds.micros)")]
    Time(String),
    #[error("'{0}': the identifier has 3 (11-bit) or 8 (29-bit) hex digits before '#'")]
    Identifier(String),
    #[error("'{0}': the data is up to 8 bytes in hex pairs")]
    Data(String),
    #[error("'{0}' is a CAN FD frame; drivedeck handles classic CAN only")]
    CanFd(String),
    #[error("'{0}' is an error frame, not a data frame")]
    ErrorFrame(String),
}

/// Read a candump log line back (see the module documentation). A trailing direction flag
/// (`R`/`T`, written by newer candump versions with `-x`) is accepted and ignored.
pub fn parse_candump_line(line: &str) -> Result<CandumpLine, CandumpError> {
    let shape = || CandumpError::Shape(line.trim().to_owned());
    let rest = line.trim().strip_prefix('(').ok_or_else(shape)?;
    let (time, rest) = rest.split_once(')').ok_or_else(shape)?;
    let seconds = parse_time(time).ok_or_else(|| CandumpError::Time(time.to_owned()))?;
    let mut fields = rest.split_whitespace();
    let interface = fields.next().ok_or_else(shape)?;
    let text = fields.next().ok_or_else(shape)?;
    match (fields.next(), fields.next()) {
        (None, _) | (Some("R" | "T"), None) => {}
        _ => return Err(shape()),
    }
    Ok(CandumpLine {
        seconds,
        interface: interface.to_owned(),
        frame: parse_frame(text)?,
    })
}

fn parse_time(text: &str) -> Option<f64> {
    let (whole, fraction) = text.split_once('.')?;
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    if !digits(whole) || !digits(fraction) {
        return None;
    }
    text.parse().ok()
}

fn parse_frame(text: &str) -> Result<CanFrame, CandumpError> {
    let (id, data) = text
        .split_once('#')
        .ok_or_else(|| CandumpError::Identifier(text.to_owned()))?;
    if data.starts_with('#') {
        return Err(CandumpError::CanFd(text.to_owned()));
    }
    let bad_id = || CandumpError::Identifier(text.to_owned());
    if !id.bytes().all(|b| b.is_ascii_hexdigit()) {
        return Err(bad_id());
    }
    let raw = u32::from_str_radix(id, 16).map_err(|_| bad_id())?;
    let extended = match id.len() {
        3 => false,
        8 if raw & (1 << 29) != 0 => return Err(CandumpError::ErrorFrame(text.to_owned())),
        8 => true,
        _ => return Err(bad_id()),
    };
    let bad_data = || CandumpError::Data(text.to_owned());
    if let Some(dlc) = data.strip_prefix(['R', 'r']) {
        let len = match dlc {
            "" => 0,
            d if d.len() == 1 => d
                .parse::<u8>()
                .ok()
                .filter(|l| *l <= 8)
                .ok_or_else(bad_data)?,
            _ => return Err(bad_data()),
        };
        if extended {
            // `CanFrame` keeps no DLC for an extended remote frame; such lines are rare.
            return CanFrame::with(raw, true, true, &[]).map_err(|_| bad_id());
        }
        let id = u16::try_from(raw).map_err(|_| bad_id())?;
        return CanFrame::remote(id, len).map_err(|_| bad_id());
    }
    let digits: Vec<u8> = data.bytes().filter(|b| *b != b'.').collect();
    if !digits.len().is_multiple_of(2) || digits.len() > 16 {
        return Err(bad_data());
    }
    let mut bytes = Vec::with_capacity(digits.len() / 2);
    for pair in digits.chunks(2) {
        let pair = std::str::from_utf8(pair).map_err(|_| bad_data())?;
        if !pair.bytes().all(|b| b.is_ascii_hexdigit()) {
            return Err(bad_data());
        }
        bytes.push(u8::from_str_radix(pair, 16).map_err(|_| bad_data())?);
    }
    CanFrame::with(raw, extended, false, &bytes).map_err(|_| bad_id())
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;
    use crate::cia::AbortCode;
    use crate::proto::canopen::emcy::Emcy;
    use crate::proto::canopen::nmt::{NmtCommand, command_frame, heartbeat_frame};
    use crate::proto::canopen::sdo::abort_frame;

    fn frame(id: u16, data: &[u8]) -> CanFrame {
        CanFrame::new(id, data).unwrap()
    }

    #[test]
    fn the_examples_of_the_frame_log() {
        assert_eq!(
            describe(&command_frame(NmtCommand::Start, 1)),
            "NMT start node 1"
        );
        assert_eq!(
            describe(&command_frame(NmtCommand::ResetCommunication, 0)),
            "NMT reset communication all nodes"
        );
        assert_eq!(
            describe(&heartbeat_frame(1, NmtState::Operational)),
            "heartbeat node 1: operational"
        );
        assert_eq!(describe(&frame(0x701, &[0x00])), "boot-up node 1");
        assert_eq!(
            describe(&frame(0x701, &[0xFF])),
            "heartbeat node 1: pre-operational (toggle 1)"
        );
        assert_eq!(
            describe(&CanFrame::remote(0x701, 1).unwrap()),
            "node guarding request node 1"
        );
        assert_eq!(
            describe(&Emcy::new(0x2300, 0x03).frame(1)),
            "EMCY node 1: 2300h (output current too large) register 03h"
        );
        assert_eq!(
            describe(&frame(0x081, &[0x00, 0x23, 0x03, 0x05, 0, 0, 0, 0])),
            "EMCY node 1: 2300h (output current too large) register 03h, manufacturer 05 00 00 00 00"
        );
        assert_eq!(
            describe(&frame(0x601, &[0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0])),
            "SDO request node 1: upload 1018h:01h"
        );
        assert_eq!(
            describe(&frame(0x581, &[0x43, 0x18, 0x10, 0x01, 0x6C, 0x02, 0, 0])),
            "SDO response node 1: 4 bytes 6C 02 00 00"
        );
        assert_eq!(
            describe(&frame(
                0x581,
                &[0x80, 0x18, 0x10, 0x09, 0x11, 0x00, 0x09, 0x06]
            )),
            "SDO abort node 1 1018h:09h: 06090011h (Sub-index does not exist)"
        );
        assert_eq!(
            describe(&abort_frame(1, 0x1018, 1, AbortCode::SDO_TIMEOUT)),
            "SDO abort to node 1 1018h:01h: 05040000h (SDO protocol timed out)"
        );
        assert_eq!(
            describe(&frame(0x181, &[1, 0, 0, 0, 0x40, 0x06, 0, 0])),
            "TPDO1 node 1: 8 bytes 01 00 00 00 40 06 00 00"
        );
        assert_eq!(
            describe(&frame(0x201, &[0xD0, 0x07, 0, 0, 0xC8, 0, 0, 0x14])),
            "RPDO1 node 1: 8 bytes D0 07 00 00 C8 00 00 14"
        );
        assert_eq!(describe(&frame(0x080, &[])), "SYNC");
        assert_eq!(describe(&frame(0x080, &[7])), "SYNC counter 7");
    }

    #[test]
    fn every_sdo_step_is_named() {
        let cases: [(u16, [u8; 8], &str); 12] = [
            (
                0x601,
                [0xE0, 0, 0, 0, 0, 0, 0, 0],
                "SDO request node 1: invalid command byte E0h",
            ),
            (
                0x581,
                [0xC0, 0x08, 0x10, 0, 0, 0, 0, 0],
                "SDO response node 1: block upload 1008h:00h (command byte C0h, not supported)",
            ),
            (
                0x601,
                [0x2B, 0x40, 0x60, 0, 0x0F, 0, 0, 0],
                "SDO request node 1: download 6040h:00h, 2 bytes 0F 00",
            ),
            (
                0x601,
                [0x21, 0x08, 0x10, 0, 10, 0, 0, 0],
                "SDO request node 1: download 1008h:00h, segmented, 10 bytes",
            ),
            (
                0x601,
                [0x70, 0, 0, 0, 0, 0, 0, 0],
                "SDO request node 1: upload segment, toggle 1",
            ),
            (
                0x601,
                [0x19, b'7', b'8', b'9', 0, 0, 0, 0],
                "SDO request node 1: download segment, toggle 1, 3 bytes 37 38 39, last",
            ),
            (
                0x601,
                [0xA0, 0x08, 0x10, 0, 0, 0, 0, 0],
                "SDO request node 1: block upload 1008h:00h (command byte A0h, not supported)",
            ),
            (
                0x581,
                [0x41, 0x08, 0x10, 0, 25, 0, 0, 0],
                "SDO response node 1: upload 1008h:00h, segmented, 25 bytes",
            ),
            (
                0x581,
                [0x00, b'P', b'D', b'4', b'-', b'C', b'5', b'9'],
                "SDO response node 1: segment, toggle 0, 7 bytes 50 44 34 2D 43 35 39",
            ),
            (
                0x581,
                [0x60, 0x40, 0x60, 0, 0, 0, 0, 0],
                "SDO response node 1: download 6040h:00h acknowledged",
            ),
            (
                0x581,
                [0x30, 0, 0, 0, 0, 0, 0, 0],
                "SDO response node 1: segment acknowledged, toggle 1",
            ),
            (
                0x581,
                [0x4F, 0x00, 0x20, 1, 7, 0, 0, 0],
                "SDO response node 1: 1 byte 07",
            ),
        ];
        for (id, data, want) in cases {
            assert_eq!(describe(&frame(id, &data)), want);
        }
        assert_eq!(
            describe(&frame(0x581, &[])),
            "SDO response node 1: an SDO frame carries 8 bytes; this one is empty"
        );
    }

    #[test]
    fn other_frames() {
        assert_eq!(describe(&frame(0x100, &[1, 2])), "CAN 100h: 2 bytes 01 02");
        assert_eq!(describe(&frame(0x7E5, &[])), "CAN 7E5h: 0 bytes");
        assert_eq!(
            describe(&CanFrame::with(0x1234_5678, true, false, &[1]).unwrap()),
            "CAN 12345678h (29-bit): 1 byte 01"
        );
        assert_eq!(
            describe(&CanFrame::remote(0x181, 8).unwrap()),
            "TPDO1 node 1: remote request, DLC 8"
        );
        assert!(describe(&frame(0x000, &[9, 1])).starts_with("NMT: 09h is not"));
        assert_eq!(
            describe(&frame(0x081, &[])),
            "EMCY node 1: an EMCY message carries data; this one is empty"
        );
    }

    #[test]
    fn candump_format() {
        let sdo = frame(0x601, &[0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0]);
        assert_eq!(
            candump_line(1_700_000_000.123456, "can0", &sdo),
            "(1700000000.123456) can0 601#4018100100000000"
        );
        assert_eq!(
            candump_line(12.0005, "vcan0", &frame(0x080, &[])),
            "(0000000012.000500) vcan0 080#"
        );
        assert_eq!(
            candump_line(0.0, "can0", &CanFrame::remote(0x181, 8).unwrap()),
            "(0000000000.000000) can0 181#R8"
        );
        assert_eq!(
            candump_line(0.0, "can0", &CanFrame::remote(0x181, 0).unwrap()),
            "(0000000000.000000) can0 181#R"
        );
        assert_eq!(
            candump_line(
                -1.0,
                "can0",
                &CanFrame::with(0x1ABC, true, false, &[0xFF]).unwrap()
            ),
            "(0000000000.000000) can0 00001ABC#FF"
        );
        assert_eq!(
            candump_line(f64::NAN, "can0", &sdo),
            "(0000000000.000000) can0 601#4018100100000000"
        );
    }

    #[test]
    fn candump_lines_parse() {
        let line = parse_candump_line("(1700000000.123456) can0 601#4018100100000000").unwrap();
        assert_eq!(line.interface, "can0");
        assert_eq!(line.seconds, 1_700_000_000.123456);
        assert_eq!(
            line.frame,
            frame(0x601, &[0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0])
        );
        // python-can's writer ('%f'), padded names, separators, lower case, a direction flag.
        let line = parse_candump_line("(0.500000)  vcan0 181#de.ad.be.ef R\n").unwrap();
        assert_eq!(line.seconds, 0.5);
        assert_eq!(line.frame, frame(0x181, &[0xDE, 0xAD, 0xBE, 0xEF]));
        let line = parse_candump_line("(1.0) can1 12345678#").unwrap();
        assert_eq!(
            line.frame,
            CanFrame::with(0x1234_5678, true, false, &[]).unwrap()
        );
        assert_eq!(
            parse_candump_line("(1.0) can0 181#R").unwrap().frame,
            CanFrame::remote(0x181, 0).unwrap()
        );
        assert_eq!(
            parse_candump_line("(1.0) can0 181#r4").unwrap().frame,
            CanFrame::remote(0x181, 4).unwrap()
        );

        for bad in [
            "",
            "601#40",
            "(1.0 can0 601#40",
            "(1.0) can0",
            "(x.0) can0 601#40",
            "(nan) can0 601#40",
            "(1) can0 601#40",
            "(1.0) can0 601#4",
            "(1.0) can0 601#4G",
            "(1.0) can0 601#001122334455667788",
            "(1.0) can0 6010#40",
            "(1.0) can0 801#40",
            "(1.0) can0 601",
            "(1.0) can0 601##1001122",
            "(1.0) can0 20000080#0000000000000000",
            "(1.0) can0 181#R9",
            "(1.0) can0 601#40 extra words",
        ] {
            assert!(parse_candump_line(bad).is_err(), "{bad}");
        }
        assert!(matches!(
            parse_candump_line("(1.0) can0 123##0112233"),
            Err(CandumpError::CanFd(_))
        ));
    }

    fn any_frame() -> impl Strategy<Value = CanFrame> {
        prop_oneof![
            (0u32..0x800, proptest::collection::vec(any::<u8>(), 0..=8))
                .prop_map(|(id, data)| CanFrame::with(id, false, false, &data).unwrap()),
            (
                0u32..0x2000_0000,
                proptest::collection::vec(any::<u8>(), 0..=8)
            )
                .prop_map(|(id, data)| CanFrame::with(id, true, false, &data).unwrap()),
            (0u16..0x800, 0u8..=8).prop_map(|(id, len)| CanFrame::remote(id, len).unwrap()),
        ]
    }

    proptest! {
        #[test]
        fn candump_round_trip(frame in any_frame(), micros in 0u64..4_000_000_000_000_000) {
            let seconds = micros as f64 / 1e6;
            let line = candump_line(seconds, "can0", &frame);
            let parsed = parse_candump_line(&line).unwrap();
            prop_assert_eq!(parsed.frame, frame);
            prop_assert_eq!(&parsed.interface, "can0");
            // Microseconds survive the f64 (exact to well below 1 µs up to year 2096).
            prop_assert_eq!(candump_line(parsed.seconds, "can0", &frame), line);
        }

        #[test]
        fn describe_never_panics(frame in any_frame()) {
            prop_assert!(!describe(&frame).is_empty());
        }

        #[test]
        fn parsing_never_panics(line in "\\PC{0,60}") {
            let _ = parse_candump_line(&line);
        }

        #[test]
        fn parsing_never_panics_on_near_misses(line in "\\([0-9.]{0,12}\\) [a-z0-9]{1,5} [0-9A-Fa-f#.Rr]{0,24}") {
            let _ = parse_candump_line(&line);
        }
    }
}
