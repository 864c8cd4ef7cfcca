//! Modbus ADU framing around a PDU from [`super::pdu`]: the MBAP header of Modbus TCP
//! (protocol notes §1.6) and the slave address + CRC of Modbus RTU (§1.7). Sans-IO: the
//! caller reads bytes into a buffer, calls a decoder, and drops the bytes it says it
//! consumed.
//!
//! Decoders are total: any byte slice gives a frame, "need more bytes" (`Ok(None)`) or a
//! [`FrameError`], never a panic. An RTU error means the stream is out of step: the caller
//! drops its buffer and resynchronises on the next inter-frame gap (3.5 characters), which
//! only it can see because only it owns the clock.

use std::fmt;

use super::pdu::{self, CanopenHeader, MEI_CANOPEN, MEI_DEVICE_ID, fc};

/// Bytes of the MBAP header: transaction id, protocol id, length, unit id.
pub const MBAP_LEN: usize = 7;
/// Largest MBAP length field accepted: the unit id plus a PDU of at most 254 bytes, one more
/// than the spec's 253 so that a vendor PDU at the edge (FC 101, whose page allows up to
/// 252 bytes of frames after a 3-byte header) is not cut off.
pub const MAX_TCP_LENGTH: u16 = 255;
/// Largest Modbus RTU frame: address, PDU of at most 253 bytes, CRC (Modbus over Serial Line
/// V1.02 §2.5.1).
pub const MAX_RTU_FRAME: usize = 256;

/// A frame that cannot be right: the stream is out of step or corrupted.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    #[error("MBAP protocol id {0:04X}h is not 0000h (Modbus): the stream is out of step")]
    TcpProtocol(u16),

    #[error(
        "MBAP length {0} is outside 2 … 255 (unit id plus a PDU of 1 to 254 bytes): the stream is out of step"
    )]
    TcpLength(u16),

    #[error("RTU frame of {len} bytes: CRC {received:04X}h on the wire, {computed:04X}h computed")]
    BadCrc {
        len: usize,
        received: u16,
        computed: u16,
    },

    #[error(
        "RTU {direction}: function code {function} ({function:02X}h) is unknown, so the frame's length cannot be told"
    )]
    UnknownFunction { function: u8, direction: Direction },

    #[error(
        "RTU {direction}: FC 43 with MEI type {mei:02X}h is unknown, so the frame's length cannot be told"
    )]
    UnknownMei { mei: u8, direction: Direction },

    #[error("RTU frame of {len} bytes is longer than the serial line's {MAX_RTU_FRAME}")]
    TooLong { len: usize },
}

// ---------------------------------------------------------------------------------------------
// Modbus TCP.

/// One Modbus TCP ADU.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct TcpFrame {
    /// Echoed by the server (NT-MBAP).
    pub transaction: u16,
    /// Nanotec drives do not route: 0 (NT-MBAP, protocol notes §1.6).
    pub unit: u8,
    pub pdu: Vec<u8>,
}

/// The MBAP header and `pdu`: `tid tid 00 00 len len unit pdu…`, all big-endian.
pub fn encode_tcp(transaction: u16, unit: u8, pdu: &[u8]) -> Vec<u8> {
    let length = u16::try_from(pdu.len() + 1).unwrap_or(u16::MAX);
    let mut out = Vec::with_capacity(MBAP_LEN + pdu.len());
    out.extend_from_slice(&transaction.to_be_bytes());
    out.extend_from_slice(&[0, 0]);
    out.extend_from_slice(&length.to_be_bytes());
    out.push(unit);
    out.extend_from_slice(pdu);
    out
}

/// The first frame in `buf` and the bytes it takes, `Ok(None)` while incomplete. Checks the
/// protocol id as soon as it has arrived and the length field before waiting for the body.
pub fn decode_tcp(buf: &[u8]) -> Result<Option<(TcpFrame, usize)>, FrameError> {
    if let Some(&[hi, lo]) = buf.get(2..4) {
        let protocol = u16::from_be_bytes([hi, lo]);
        if protocol != 0 {
            return Err(FrameError::TcpProtocol(protocol));
        }
    }
    let Some(&[hi, lo]) = buf.get(4..6) else {
        return Ok(None);
    };
    let length = u16::from_be_bytes([hi, lo]);
    if !(2..=MAX_TCP_LENGTH).contains(&length) {
        return Err(FrameError::TcpLength(length));
    }
    let total = 6 + usize::from(length);
    let Some(frame) = buf.get(..total) else {
        return Ok(None);
    };
    Ok(Some((
        TcpFrame {
            transaction: u16::from_be_bytes([frame[0], frame[1]]),
            unit: frame[6],
            pdu: frame[MBAP_LEN..].to_vec(),
        },
        total,
    )))
}

// ---------------------------------------------------------------------------------------------
// Modbus RTU.

/// Modbus CRC-16: polynomial A001h (8005h reflected), initial value FFFFh. On the wire the
/// low byte goes first.
pub fn crc16(bytes: &[u8]) -> u16 {
    let mut crc: u16 = 0xFFFF;
    for &byte in bytes {
        crc ^= u16::from(byte);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xA001
            } else {
                crc >> 1
            };
        }
    }
    crc
}

/// `slave pdu… crcLo crcHi`. Slave 0 is broadcast (no reply, protocol notes §1.7).
pub fn encode_rtu(slave: u8, pdu: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(pdu.len() + 3);
    out.push(slave);
    out.extend_from_slice(pdu);
    out.extend_from_slice(&crc16(&out).to_le_bytes());
    out
}

/// Which way a frame travels: RTU has no length field, and a request and its response of the
/// same function code have different layouts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Direction {
    /// Master to slave (what a server decodes).
    Request,
    /// Slave to master (what a client decodes).
    Response,
}

impl fmt::Display for Direction {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Direction::Request => "request",
            Direction::Response => "response",
        })
    }
}

/// One Modbus RTU ADU, CRC checked and stripped.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct RtuFrame {
    pub slave: u8,
    pub pdu: Vec<u8>,
}

/// The first frame in `buf` and the bytes it takes, `Ok(None)` while incomplete.
///
/// The length is predicted from the function code and its length fields: FC 1–6, 15, 16,
/// 22, 23; FC 43/0Dh from its protocol-control options and number-of-data field; FC 43/0Eh;
/// FC 101/102 from their length byte; a standard exception is 5 bytes with address and CRC,
/// Nanotec's extended exception `x FF 00 06 0D CE a b c d` 13 bytes. An unknown function code
/// or a bad CRC is an error, so the caller can resynchronise.
///
/// One ambiguity is resolved by the CRC: a response to an FC 43 **write** may or may not echo
/// the written data (see [`pdu::CanopenResponse`]). Both lengths are tried, the longer one
/// first once it has arrived; while only the shorter one has, it is taken if its CRC matches
/// (a false match needs a 1 in 65536 coincidence in the echoed data).
pub fn decode_rtu(buf: &[u8], dir: Direction) -> Result<Option<(RtuFrame, usize)>, FrameError> {
    let Some(pdu) = buf.get(1..).filter(|pdu| !pdu.is_empty()) else {
        return Ok(None);
    };
    match expected_pdu_len(pdu, dir)? {
        None => Ok(None),
        Some(Expected::Exact(len)) => take_frame(buf, len),
        Some(Expected::EitherOf { short, full }) => take_either(buf, short, full),
    }
}

/// How long the PDU will be, once enough of it has arrived to tell.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Expected {
    Exact(usize),
    EitherOf { short: usize, full: usize },
}

fn frame_len(pdu_len: usize) -> usize {
    1 + pdu_len + 2
}

fn take_frame(buf: &[u8], pdu_len: usize) -> Result<Option<(RtuFrame, usize)>, FrameError> {
    let total = frame_len(pdu_len);
    if total > MAX_RTU_FRAME {
        return Err(FrameError::TooLong { len: total });
    }
    let Some(frame) = buf.get(..total) else {
        return Ok(None);
    };
    check_crc(frame)?;
    Ok(Some((split(frame), total)))
}

fn take_either(
    buf: &[u8],
    short: usize,
    full: usize,
) -> Result<Option<(RtuFrame, usize)>, FrameError> {
    let candidates = [frame_len(full), frame_len(short)];
    let mut last_error = None;
    for total in candidates.into_iter().filter(|&t| t <= MAX_RTU_FRAME) {
        if let Some(frame) = buf.get(..total) {
            match check_crc(frame) {
                Ok(()) => return Ok(Some((split(frame), total))),
                Err(error) => last_error = last_error.or(Some(error)),
            }
        }
    }
    let full_possible = candidates[0] <= MAX_RTU_FRAME;
    let waiting_for_full = full_possible && buf.len() < candidates[0];
    match last_error {
        Some(error) if !waiting_for_full => Err(error),
        _ if candidates[1] > MAX_RTU_FRAME => Err(FrameError::TooLong { len: candidates[1] }),
        _ => Ok(None),
    }
}

fn check_crc(frame: &[u8]) -> Result<(), FrameError> {
    let (body, tail) = frame.split_at(frame.len().saturating_sub(2));
    let received = match tail {
        &[lo, hi] => u16::from_le_bytes([lo, hi]),
        _ => 0,
    };
    let computed = crc16(body);
    if received == computed {
        Ok(())
    } else {
        Err(FrameError::BadCrc {
            len: frame.len(),
            received,
            computed,
        })
    }
}

/// Address and PDU of a frame whose CRC has been checked (at least 4 bytes).
fn split(frame: &[u8]) -> RtuFrame {
    RtuFrame {
        slave: frame.first().copied().unwrap_or_default(),
        pdu: frame
            .get(1..frame.len().saturating_sub(2))
            .unwrap_or_default()
            .to_vec(),
    }
}

/// `Ok(None)` while the bytes that tell the length have not all arrived.
fn expected_pdu_len(pdu: &[u8], dir: Direction) -> Result<Option<Expected>, FrameError> {
    let Some(&function) = pdu.first() else {
        return Ok(None);
    };
    let unknown = FrameError::UnknownFunction {
        function,
        direction: dir,
    };
    if function & 0x80 != 0 {
        return match dir {
            Direction::Response => Ok(exception_len(pdu)),
            Direction::Request => Err(unknown),
        };
    }
    let exact = |len: usize| Ok(Some(Expected::Exact(len)));
    // `base` bytes, plus the value of the length byte at `at`.
    let counted =
        |base: usize, at: usize| Ok(pdu.get(at).map(|&n| Expected::Exact(base + usize::from(n))));
    match (dir, function) {
        (Direction::Request, 0x01..=0x06) => exact(5),
        (Direction::Request, 0x0F | fc::WRITE_MULTIPLE) => counted(6, 5),
        (Direction::Request, 0x16) => exact(7),
        (Direction::Request, fc::READ_WRITE) => counted(10, 9),
        (Direction::Request, fc::READ_DICTIONARY) => counted(3, 2),
        (Direction::Request, fc::READ_ARRAY) => counted(5, 2),
        (Direction::Response, 0x01..=0x04 | fc::READ_WRITE) => counted(2, 1),
        (Direction::Response, 0x05 | 0x06 | 0x0F | fc::WRITE_MULTIPLE) => exact(5),
        (Direction::Response, 0x16) => exact(7),
        (Direction::Response, fc::READ_DICTIONARY | fc::READ_ARRAY) => counted(3, 2),
        (_, fc::ENCAPSULATED) => encapsulated_len(pdu, dir),
        _ => Err(unknown),
    }
}

/// Standard exception: `fc|80h code`. Extended (FC 43/101/102 with code FFh):
/// `fc|80h FF lenHi lenLo` and `len` more bytes (6 for Nanotec: `0D CE` and the abort code).
fn exception_len(pdu: &[u8]) -> Option<Expected> {
    let function = pdu.first()? & 0x7F;
    if !pdu::has_extended_exception(function) {
        return Some(Expected::Exact(2));
    }
    if *pdu.get(1)? != pdu::exception::EXTENDED {
        return Some(Expected::Exact(2));
    }
    match pdu.get(2..4)? {
        &[hi, lo] => Some(Expected::Exact(
            4 + usize::from(u16::from_be_bytes([hi, lo])),
        )),
        _ => None,
    }
}

fn encapsulated_len(pdu: &[u8], dir: Direction) -> Result<Option<Expected>, FrameError> {
    let Some(&mei) = pdu.get(1) else {
        return Ok(None);
    };
    match (mei, dir) {
        (MEI_CANOPEN, _) => Ok(canopen_len(pdu, dir)),
        // 2B 0E code object-id
        (MEI_DEVICE_ID, Direction::Request) => Ok(Some(Expected::Exact(4))),
        (MEI_DEVICE_ID, Direction::Response) => Ok(device_id_len(pdu)),
        _ => Err(FrameError::UnknownMei {
            mei,
            direction: dir,
        }),
    }
}

/// FC 43/0Dh: header length from the protocol-control options, then the number-of-data field
/// (NT-FC43, protocol notes §1.4). A read request carries no data; a write response may or may not.
fn canopen_len(pdu: &[u8], dir: Direction) -> Option<Expected> {
    let control = *pdu.get(2)?;
    let header = CanopenHeader::pdu_len(control);
    let count = match pdu.get(header - 2..header)? {
        &[hi, lo] => usize::from(u16::from_be_bytes([hi, lo])),
        _ => return None,
    };
    let write = control & pdu::control::WRITE != 0;
    Some(match (dir, write) {
        (Direction::Request, false) => Expected::Exact(header),
        (Direction::Response, true) if count > 0 => Expected::EitherOf {
            short: header,
            full: header + count,
        },
        _ => Expected::Exact(header + count),
    })
}

/// FC 43/0Eh response (Modbus spec §6.21): `2B 0E code conformity more next n` and `n`
/// objects `id len value…`.
fn device_id_len(pdu: &[u8]) -> Option<Expected> {
    let objects = *pdu.get(6)?;
    let mut len = 7;
    for _ in 0..objects {
        len += 2 + usize::from(*pdu.get(len + 1)?);
        if len > pdu::MAX_PDU + 3 {
            break; // longer than any frame: let the length check reject it
        }
    }
    Some(Expected::Exact(len))
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::super::pdu::tests::{any_exception, any_exchange, any_request};
    use super::super::pdu::{CanopenRequest, CanopenResponse, Request, Response};
    use super::*;

    fn bytes(hex: &str) -> Vec<u8> {
        hex.split_whitespace()
            .map(|b| u8::from_str_radix(b, 16).expect("test vector is hex"))
            .collect()
    }

    fn decoded(buf: &[u8], dir: Direction) -> (RtuFrame, usize) {
        match decode_rtu(buf, dir) {
            Ok(Some(found)) => found,
            other => panic!("{buf:02X?} as {dir}: {other:?}"),
        }
    }

    // --- CRC ----------------------------------------------------------------------------

    #[test]
    fn crc16_matches_known_vectors() {
        // CRC-16/MODBUS catalogue check value.
        assert_eq!(crc16(b"123456789"), 0x4B37);
        assert_eq!(
            encode_rtu(0x01, &bytes("03 00 00 00 01")),
            bytes("01 03 00 00 00 01 84 0A")
        );
        // Modbus over Serial Line V1.02, and a common read of 10 registers.
        assert_eq!(
            encode_rtu(0x11, &bytes("03 00 6B 00 03")),
            bytes("11 03 00 6B 00 03 76 87")
        );
        assert_eq!(
            encode_rtu(0x01, &bytes("03 00 00 00 0A")),
            bytes("01 03 00 00 00 0A C5 CD")
        );
    }

    // --- TCP ----------------------------------------------------------------------------

    #[test]
    fn tcp_frames_the_documented_fc23_exchange() {
        let pdu = bytes("17 13 84 00 04 17 6C 00 04 08 00 00 00 00 33 20 01 0E");
        let wire = encode_tcp(0x0102, 0, &pdu);
        assert_eq!(wire[..MBAP_LEN], bytes("01 02 00 00 00 13 00")[..]);
        assert_eq!(wire[MBAP_LEN..], pdu[..]);
        let frame = TcpFrame {
            transaction: 0x0102,
            unit: 0,
            pdu,
        };
        assert_eq!(decode_tcp(&wire), Ok(Some((frame, wire.len()))));
    }

    #[test]
    fn tcp_needs_the_whole_frame_and_consumes_only_it() {
        let first = encode_tcp(1, 0, &bytes("03 13 84 00 04"));
        let second = encode_tcp(2, 0, &bytes("04 13 84 00 01"));
        let stream = [first.clone(), second.clone()].concat();
        for cut in 0..first.len() {
            assert_eq!(decode_tcp(&stream[..cut]), Ok(None), "cut at {cut}");
        }
        let (frame, used) = decode_tcp(&stream).expect("valid").expect("complete");
        assert_eq!((frame.transaction, used), (1, first.len()));
        let (frame, used) = decode_tcp(&stream[used..])
            .expect("valid")
            .expect("complete");
        assert_eq!((frame.transaction, used), (2, second.len()));
    }

    #[test]
    fn tcp_rejects_what_cannot_be_modbus() {
        assert_eq!(
            decode_tcp(&bytes("00 01 00 02")),
            Err(FrameError::TcpProtocol(2))
        );
        assert_eq!(
            decode_tcp(&bytes("00 01 00 00 00 00 00")),
            Err(FrameError::TcpLength(0))
        );
        assert_eq!(
            decode_tcp(&bytes("00 01 00 00 01 00")),
            Err(FrameError::TcpLength(256))
        );
        assert_eq!(
            FrameError::TcpProtocol(0x4854).to_string(),
            "MBAP protocol id 4854h is not 0000h (Modbus): the stream is out of step"
        );
        assert_eq!(
            FrameError::TcpLength(256).to_string(),
            "MBAP length 256 is outside 2 … 255 (unit id plus a PDU of 1 to 254 bytes): the stream is out of step"
        );
    }

    // --- RTU ----------------------------------------------------------------------------

    #[test]
    fn rtu_request_and_response_of_one_function_differ_in_length() {
        let request = encode_rtu(5, &bytes("03 13 84 00 02"));
        let response = encode_rtu(5, &bytes("03 04 00 01 00 00"));
        assert_eq!(decoded(&request, Direction::Request).1, 8);
        assert_eq!(decoded(&response, Direction::Response).1, 9);
        assert_eq!(decode_rtu(&request[..6], Direction::Response), Ok(None));
    }

    #[test]
    fn rtu_exceptions_standard_and_extended() {
        let standard = encode_rtu(5, &bytes("83 02"));
        assert_eq!(standard.len(), 5);
        assert_eq!(decoded(&standard, Direction::Response).1, 5);
        let standard43 = encode_rtu(5, &bytes("AB 01"));
        assert_eq!(decoded(&standard43, Direction::Response).1, 5);
        for first in ["AB", "E5", "E6"] {
            let extended = encode_rtu(5, &bytes(&format!("{first} FF 00 06 0D CE 24 00 00 08")));
            assert_eq!(extended.len(), 13);
            let (frame, used) = decoded(&extended, Direction::Response);
            assert_eq!(used, 13);
            assert_eq!(frame.pdu.len(), 10);
            for cut in 0..extended.len() {
                assert_eq!(decode_rtu(&extended[..cut], Direction::Response), Ok(None));
            }
        }
        assert_eq!(
            decode_rtu(&encode_rtu(5, &bytes("83 02")), Direction::Request),
            Err(FrameError::UnknownFunction {
                function: 0x83,
                direction: Direction::Request
            })
        );
    }

    #[test]
    fn rtu_fc43_lengths_follow_the_option_flags() {
        let read = Request::Canopen(CanopenRequest::read(1, 0x6041, 0, 2)).encode();
        assert_eq!(decoded(&encode_rtu(5, &read), Direction::Request).1, 15);
        // Counter and network-id options add a byte each; a write adds its data.
        let mut write = CanopenRequest::write(1, 0x6040, 0, vec![0x0F, 0x00]);
        write.header.counter = Some(3);
        write.header.network_id = Some(0);
        let wire = encode_rtu(5, &Request::Canopen(write).encode());
        assert_eq!(wire.len(), 1 + 12 + 2 + 2 + 2);
        assert_eq!(decoded(&wire, Direction::Request).1, wire.len());
        let answer = bytes("2B 0D 00 00 01 60 41 00 00 00 00 02 37 06");
        assert_eq!(decoded(&encode_rtu(5, &answer), Direction::Response).1, 17);
    }

    #[test]
    fn rtu_fc43_write_response_with_and_without_echo() {
        let asked = CanopenRequest::write(1, 0x6040, 0, vec![0x0F, 0x00]);
        let echoed = encode_rtu(
            5,
            &Response::Canopen(CanopenResponse::answering(&asked, Vec::new())).encode(),
        );
        let bare = encode_rtu(5, &bytes("2B 0D 01 00 01 60 40 00 00 00 00 02"));
        assert_eq!(decoded(&echoed, Direction::Response).1, 17);
        assert_eq!(decoded(&bare, Direction::Response).1, 15);
        // The bare response followed by the next frame: still cut at 15.
        let next = encode_rtu(5, &bytes("83 02"));
        let stream = [bare.clone(), next].concat();
        assert_eq!(decoded(&stream, Direction::Response).1, 15);
        // The echoed one, split anywhere, waits for all of it.
        for cut in 0..echoed.len() {
            assert_eq!(
                decode_rtu(&echoed[..cut], Direction::Response),
                Ok(None),
                "cut {cut}"
            );
        }
        // Neither length has a good CRC once both have arrived: an error.
        let mut broken = echoed.clone();
        broken[16] ^= 0xFF;
        assert!(matches!(
            decode_rtu(&broken, Direction::Response),
            Err(FrameError::BadCrc { len: 17, .. })
        ));
    }

    #[test]
    fn rtu_fc101_and_fc102_use_their_length_byte() {
        let request = encode_rtu(5, &bytes("65 55 00"));
        assert_eq!(decoded(&request, Direction::Request).1, 6);
        let array = encode_rtu(5, &bytes("66 55 00 00 24"));
        assert_eq!(decoded(&array, Direction::Request).1, 8);
        let response = encode_rtu(5, &bytes("65 55 06 41 60 00 02 37 06"));
        assert_eq!(decoded(&response, Direction::Response).1, 12);
        let array_response = encode_rtu(5, &bytes("66 AA 05 00 24 01 01 07"));
        assert_eq!(decoded(&array_response, Direction::Response).1, 11);
    }

    #[test]
    fn rtu_device_identification_is_framed_so_a_server_can_refuse_it() {
        let request = encode_rtu(5, &bytes("2B 0E 01 00"));
        assert_eq!(decoded(&request, Direction::Request).1, 7);
        let response = encode_rtu(5, &bytes("2B 0E 01 01 00 00 02 00 03 41 42 43 01 01 58"));
        assert_eq!(decoded(&response, Direction::Response).1, response.len());
    }

    #[test]
    fn rtu_errors_let_the_caller_resynchronise() {
        let mut frame = encode_rtu(5, &bytes("03 13 84 00 04"));
        assert_eq!(frame[6..], [0x01, 0x20]);
        frame[7] ^= 0x01;
        assert_eq!(
            decode_rtu(&frame, Direction::Request)
                .unwrap_err()
                .to_string(),
            "RTU frame of 8 bytes: CRC 2101h on the wire, 2001h computed"
        );
        assert_eq!(
            decode_rtu(&bytes("05 07"), Direction::Request)
                .unwrap_err()
                .to_string(),
            "RTU request: function code 7 (07h) is unknown, so the frame's length cannot be told"
        );
        assert_eq!(
            decode_rtu(&bytes("05 2B 0C"), Direction::Response)
                .unwrap_err()
                .to_string(),
            "RTU response: FC 43 with MEI type 0Ch is unknown, so the frame's length cannot be told"
        );
        assert_eq!(
            decode_rtu(&bytes("05 10 00 00 00 7F FE"), Direction::Request),
            Err(FrameError::TooLong { len: 263 })
        );
        assert_eq!(decode_rtu(&[], Direction::Request), Ok(None));
        assert_eq!(decode_rtu(&[5], Direction::Response), Ok(None));
    }

    // --- Properties ---------------------------------------------------------------------

    /// Every prefix of `frame` is incomplete; the whole of it, followed by anything, is one
    /// frame of exactly its length.
    fn assert_splits(frame: &[u8], dir: Direction, tail: &[u8]) -> Result<(), TestCaseError> {
        for cut in 0..frame.len() {
            prop_assert_eq!(decode_rtu(&frame[..cut], dir), Ok(None), "cut at {}", cut);
        }
        let stream = [frame, tail].concat();
        let (decoded, used) = decode_rtu(&stream, dir)
            .map_err(|e| TestCaseError::fail(e.to_string()))?
            .ok_or_else(|| TestCaseError::fail("incomplete"))?;
        prop_assert_eq!(used, frame.len());
        prop_assert_eq!(&decoded.pdu[..], &frame[1..frame.len() - 2]);
        Ok(())
    }

    /// A write response echoing data has a header-only prefix whose CRC could match by
    /// chance (1 in 65536); such a frame is legitimately ambiguous, so skip it.
    fn short_crc_coincides(frame: &[u8]) -> bool {
        let Some(&control) = frame.get(3) else {
            return false;
        };
        if frame.get(1) != Some(&fc::ENCAPSULATED) || control & pdu::control::WRITE == 0 {
            return false;
        }
        let short = 1 + CanopenHeader::pdu_len(control) + 2;
        short < frame.len() && check_crc(&frame[..short]).is_ok()
    }

    proptest! {
        #[test]
        fn decoders_are_total(buf in proptest::collection::vec(any::<u8>(), 0..600)) {
            let _ = decode_tcp(&buf);
            let _ = decode_rtu(&buf, Direction::Request);
            let _ = decode_rtu(&buf, Direction::Response);
        }

        #[test]
        fn decoders_are_total_on_plausible_headers(
            slave in any::<u8>(),
            function in prop::sample::select(vec![
                0x01u8, 0x03, 0x04, 0x06, 0x0F, 0x10, 0x16, 0x17, 0x2B, 0x65, 0x66,
                0x83, 0xAB, 0xE5, 0xE6,
            ]),
            mei in prop::sample::select(vec![0x0Du8, 0x0E, 0x00]),
            rest in proptest::collection::vec(any::<u8>(), 0..300),
        ) {
            let buf = [&[slave, function, mei][..], &rest].concat();
            let _ = decode_rtu(&buf, Direction::Request);
            let _ = decode_rtu(&buf, Direction::Response);
        }

        #[test]
        fn rtu_requests_split_anywhere(
            slave in any::<u8>(),
            request in any_request().prop_filter("framable", |r| !matches!(r, Request::Other { .. })),
            tail in proptest::collection::vec(any::<u8>(), 0..8),
        ) {
            assert_splits(&encode_rtu(slave, &request.encode()), Direction::Request, &tail)?;
        }

        #[test]
        fn rtu_responses_split_anywhere(
            slave in any::<u8>(),
            (_request, response) in any_exchange(),
            tail in proptest::collection::vec(any::<u8>(), 0..8),
        ) {
            let frame = encode_rtu(slave, &response.encode());
            prop_assume!(!short_crc_coincides(&frame));
            assert_splits(&frame, Direction::Response, &tail)?;
        }

        #[test]
        fn rtu_exceptions_split_anywhere(slave in any::<u8>(), refusal in any_exception()) {
            assert_splits(&encode_rtu(slave, &refusal.encode()), Direction::Response, &[])?;
        }

        #[test]
        fn tcp_round_trips_and_splits(
            transaction in any::<u16>(),
            unit in any::<u8>(),
            request in any_request(),
        ) {
            let pdu = request.encode();
            let wire = encode_tcp(transaction, unit, &pdu);
            for cut in 0..wire.len() {
                prop_assert_eq!(decode_tcp(&wire[..cut]), Ok(None));
            }
            let frame = TcpFrame { transaction, unit, pdu };
            prop_assert_eq!(decode_tcp(&wire), Ok(Some((frame, wire.len()))));
        }
    }
}
