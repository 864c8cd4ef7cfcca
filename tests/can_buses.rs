//! The CAN back ends end to end, with the bytes really crossing the kernel:
//!
//! - slcan: our host side (`SlcanBus`) and adapter side (`SlcanDevice`) over a
//!   pseudo-terminal pair, frames both ways, the open/close handshake, and what the host
//!   says about devices that are not slcan adapters;
//! - garbage and partial lines on the serial line: errors, never panics, and the next good
//!   line still gets through;
//! - SocketCAN over a Unix socket pair: this kernel has no CAN at all, but a datagram pair
//!   carries `struct can_frame`s like a CAN_RAW socket does, so the socketcan crate's own
//!   frame code runs both ways (and the layout is pinned byte by byte);
//! - SocketCAN on a real `vcan0` where there is one;
//! - properties of the slcan codec.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::future::Future;
use std::time::Duration;

use drivedeck::link::Error;
use drivedeck::link::canopen::CanBus;
use drivedeck::link::canopen::slcan::{SlcanBus, SlcanDevice};
use drivedeck::proto::canopen::CanFrame;
use drivedeck::proto::canopen::slcan::{
    LineSplitter, MAX_LINE, SlcanError, SlcanLine, decode_line, encode_frame,
};
use proptest::prelude::*;
use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};
use tokio_serial::SerialStream;

const PATIENCE: Duration = Duration::from_secs(5);

async fn within<T>(what: &str, work: impl Future<Output = T>) -> T {
    match tokio::time::timeout(PATIENCE, work).await {
        Ok(out) => out,
        Err(_) => panic!("{what}: nothing within {PATIENCE:?}"),
    }
}

/// Run `work` while the adapter answers the host's commands (it does so inside `recv`).
async fn serving<S, T>(device: &mut SlcanDevice<S>, work: impl Future<Output = T>) -> T
where
    S: AsyncRead + AsyncWrite + Unpin,
{
    within("serving the host", async {
        tokio::select! {
            biased;
            out = work => out,
            got = device.recv() => panic!("the adapter got {got:?} while only commands were expected"),
        }
    })
    .await
}

/// Every kind of frame: standard 0 to 8 bytes, extended, remote, the extreme identifiers.
fn assorted_frames() -> Vec<CanFrame> {
    let mut frames: Vec<CanFrame> = (0..=8u8)
        .map(|n| {
            let data: Vec<u8> = (0..n).map(|i| 0x11 * i + 0x0F).collect();
            CanFrame::new(0x580 + u16::from(n), &data).unwrap()
        })
        .collect();
    frames.extend([
        CanFrame::new(0x000, &[0x01, 0x05]).unwrap(),
        CanFrame::new(0x7FF, &[0xFF; 8]).unwrap(),
        CanFrame::with(0x1FFF_FFFF, true, false, &[0xDE, 0xAD, 0xBE, 0xEF]).unwrap(),
        CanFrame::with(0x0000_0001, true, false, &[]).unwrap(),
        CanFrame::with(0x0ABC_DEF0, true, false, &[0; 8]).unwrap(),
        CanFrame::remote(0x181, 8).unwrap(),
        CanFrame::remote(0x701, 0).unwrap(),
        CanFrame::with(0x1234_5678, true, true, &[0; 4]).unwrap(),
    ]);
    frames
}

/// A pseudo-terminal pair: (host end, adapter end).
fn pty_pair() -> (SerialStream, SerialStream) {
    SerialStream::pair().expect("a pseudo-terminal pair")
}

/// Read from a raw stream until `want` bytes came or nothing more comes for a while.
async fn read_some(stream: &mut (impl AsyncRead + Unpin), want: usize) -> Vec<u8> {
    let mut got = Vec::new();
    let mut chunk = [0u8; 256];
    while got.len() < want {
        match tokio::time::timeout(Duration::from_millis(300), stream.read(&mut chunk)).await {
            Ok(Ok(n)) if n > 0 => got.extend_from_slice(&chunk[..n]),
            _ => break,
        }
    }
    got
}

// ---------------------------------------------------------------------------------------
// (a) slcan host and adapter over a pseudo-terminal pair

#[tokio::test(flavor = "current_thread")]
async fn slcan_host_and_adapter_exchange_every_kind_of_frame() {
    let (host_end, adapter_end) = pty_pair();
    let mut device = SlcanDevice::with_name(adapter_end, "pty");
    assert!(!device.state().is_open());

    let mut host = serving(
        &mut device,
        SlcanBus::with_options(host_end, 500_000, "pty", Duration::from_secs(2)),
    )
    .await
    .expect("the handshake");
    assert!(device.state().is_open());
    assert_eq!(device.state().bitrate(), Some(500_000));
    assert_eq!(host.describe(), "slcan pty at 500 kbit/s");
    assert_eq!(device.describe(), "simulated slcan adapter on pty");

    // Host to bus, one at a time and then all at once.
    for frame in assorted_frames() {
        host.send(&frame).await.unwrap();
        assert_eq!(
            within("a frame at the adapter", device.recv())
                .await
                .unwrap(),
            frame
        );
    }
    for frame in assorted_frames() {
        host.send(&frame).await.unwrap();
    }
    for frame in assorted_frames() {
        assert_eq!(
            within("a burst at the adapter", device.recv())
                .await
                .unwrap(),
            frame
        );
    }

    // Bus to host, the same.
    for frame in assorted_frames() {
        device.send(&frame).await.unwrap();
        assert_eq!(
            within("a frame at the host", host.recv()).await.unwrap(),
            frame
        );
    }
    for frame in assorted_frames() {
        device.send(&frame).await.unwrap();
    }
    for frame in assorted_frames() {
        assert_eq!(
            within("a burst at the host", host.recv()).await.unwrap(),
            frame
        );
    }

    // An SDO-like exchange: request, the adapter's OK, the answer.
    let request = CanFrame::new(0x601, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]).unwrap();
    let answer = CanFrame::new(0x581, &[0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00]).unwrap();
    host.send(&request).await.unwrap();
    assert_eq!(device.recv().await.unwrap(), request);
    device.send(&answer).await.unwrap();
    assert_eq!(within("the answer", host.recv()).await.unwrap(), answer);
    assert_eq!(host.refusals(), 0);

    // Closing: the adapter's channel closes, and the stream comes back.
    let mut raw = serving(&mut device, host.close()).await.expect("closing");
    assert!(!device.state().is_open());

    // A closed adapter drops what the bus brings and refuses what the host sends.
    device.send(&answer).await.unwrap();
    raw.write_all(b"t1230\rV\r").await.unwrap();
    let replies = serving(&mut device, read_some(&mut raw, 7)).await;
    assert_eq!(replies, b"\x07V1010\r", "{}", replies.escape_ascii());

    // Opened again at another rate, over the same stream.
    let mut host = serving(&mut device, SlcanBus::new(raw, 1_000_000))
        .await
        .expect("the second handshake");
    assert_eq!(device.state().bitrate(), Some(1_000_000));
    assert_eq!(host.bitrate(), 1_000_000);
    device.send(&answer).await.unwrap();
    assert_eq!(
        within("after reopening", host.recv()).await.unwrap(),
        answer
    );
}

#[tokio::test(flavor = "current_thread")]
async fn the_adapter_answers_what_python_can_sends() {
    let (mut raw, adapter_end) = pty_pair();
    let mut device = SlcanDevice::new(adapter_end);
    // python-can 4.6 `can.Bus(interface="slcan", bitrate=1000000)`: C, S8, an empty
    // line (the data bit rate command for classic CAN is empty), O, and O again.
    raw.write_all(b"C\rS8\r\rO\rO\r").await.unwrap();
    let replies = serving(&mut device, read_some(&mut raw, 5)).await;
    assert_eq!(replies, b"\r\r\r\r\r");
    assert!(device.state().is_open());
    assert_eq!(device.state().bitrate(), Some(1_000_000));
    // Its `get_version` and `get_serial_number`.
    raw.write_all(b"V\rN\r").await.unwrap();
    let replies = serving(&mut device, read_some(&mut raw, 12)).await;
    assert_eq!(replies, b"V1010\rNDDSM\r");
    // It sends `t…` lines and reads frames as `t…\r`, and ignores the OK for its frames.
    raw.write_all(b"t60180123456789ABCDEF\r").await.unwrap();
    let frame = within("python-can's frame", device.recv()).await.unwrap();
    assert_eq!(
        frame.data(),
        &[0x01, 0x23, 0x45, 0x67, 0x89, 0xAB, 0xCD, 0xEF]
    );
    let reply = CanFrame::new(0x581, &[0x60, 0, 0x10, 0, 0, 0, 0, 0]).unwrap();
    device.send(&reply).await.unwrap();
    let mut expected = b"\r".to_vec();
    expected.extend(encode_frame(&reply));
    assert_eq!(expected.len(), 23);
    assert_eq!(read_some(&mut raw, 23).await, expected);
    // With timestamps on (Z1), frames carry four more hex digits, which the host decodes.
    raw.write_all(b"C\rZ1\rO\r").await.unwrap();
    assert_eq!(
        serving(&mut device, read_some(&mut raw, 3)).await,
        b"\r\r\r"
    );
    device.send(&reply).await.unwrap();
    let line = read_some(&mut raw, 26).await;
    assert_eq!(line.len(), 26, "{}", line.escape_ascii());
    assert_eq!(decode_line(&line), Ok(SlcanLine::Frame(reply)));
    let mut host = serving(&mut device, SlcanBus::new(raw, 250_000))
        .await
        .unwrap();
    device.send(&reply).await.unwrap();
    assert_eq!(within("a stamped frame", host.recv()).await.unwrap(), reply);
}

#[tokio::test(flavor = "current_thread")]
async fn a_device_that_does_not_answer_is_not_taken_for_an_adapter() {
    let (host_end, _silent) = pty_pair();
    let started = std::time::Instant::now();
    let e = SlcanBus::with_options(
        host_end,
        1_000_000,
        "/dev/ttyTEST",
        Duration::from_millis(150),
    )
    .await
    .expect_err("nobody answers");
    assert!(started.elapsed() < Duration::from_secs(2));
    let text = e.to_string();
    assert!(matches!(e, Error::Timeout { .. }), "{e:?}");
    assert!(
        text.contains("the adapter at /dev/ttyTEST did not answer `C`")
            && text.contains("is it an slcan adapter?"),
        "{text}"
    );
}

/// A fake device on the raw end that answers every line with `reply`.
async fn answer_every_line(mut raw: SerialStream, reply: &'static [u8]) {
    let mut chunk = [0u8; 64];
    while let Ok(n) = raw.read(&mut chunk).await {
        if n == 0 {
            break;
        }
        for _ in chunk[..n].iter().filter(|&&b| b == b'\r') {
            if raw.write_all(reply).await.is_err() {
                return;
            }
        }
    }
}

#[tokio::test(flavor = "current_thread")]
async fn what_the_host_says_about_odd_devices() {
    // Refuses everything: the bit rate is where it shows.
    let (host_end, raw) = pty_pair();
    let fake = tokio::spawn(answer_every_line(raw, b"\x07"));
    let e = SlcanBus::with_options(
        host_end,
        250_000,
        "/dev/ttyREFUSE",
        Duration::from_millis(500),
    )
    .await
    .expect_err("refused");
    fake.abort();
    assert!(matches!(e, Error::Refused(_)), "{e:?}");
    assert!(
        e.to_string()
            .contains("refused the bit rate 250 kbit/s (`S5`)"),
        "{e}"
    );

    // Answers with line noise: a wrong serial speed.
    let (host_end, raw) = pty_pair();
    let fake = tokio::spawn(answer_every_line(raw, b"\xf0\x00\xfe\r"));
    let e = SlcanBus::with_options(
        host_end,
        250_000,
        "/dev/ttyNOISE",
        Duration::from_millis(150),
    )
    .await
    .expect_err("noise");
    fake.abort();
    assert!(e.to_string().contains("only with garbage"), "{e}");

    // A bit rate slcan has no command for is refused before anything is sent.
    let (host_end, _raw) = pty_pair();
    let e = SlcanBus::new(host_end, 83_300).await.expect_err("83.3k");
    assert!(matches!(e, Error::Unsupported(_)), "{e:?}");
    assert!(e.to_string().contains("500000, 800000 or 1000000"), "{e}");
}

#[tokio::test(flavor = "current_thread")]
async fn opening_a_missing_port_says_so() {
    let dir = common::temp_dir("slcan-missing");
    let path = dir.path().join("ttyNONE");
    let e = SlcanBus::open(path.to_str().unwrap(), 1_000_000)
        .await
        .expect_err("no such port");
    assert!(e.to_string().contains("is the adapter plugged in?"), "{e}");
}

#[tokio::test(flavor = "current_thread")]
async fn slcan_by_path_through_socat() {
    let Some(pair) = common::PtyPair::new() else {
        return;
    };
    let mut device =
        SlcanDevice::open(pair.b.to_str().unwrap()).expect("the adapter end of the pty pair");
    let path = pair.a.to_str().unwrap().to_owned();
    let mut host = serving(&mut device, SlcanBus::open(&path, 125_000))
        .await
        .expect("opening by path");
    assert_eq!(host.describe(), format!("slcan {path} at 125 kbit/s"));
    for frame in assorted_frames() {
        host.send(&frame).await.unwrap();
        assert_eq!(
            within("host to adapter", device.recv()).await.unwrap(),
            frame
        );
        device.send(&frame).await.unwrap();
        assert_eq!(within("adapter to host", host.recv()).await.unwrap(), frame);
    }
    serving(&mut device, host.close()).await.unwrap();
    assert!(!device.state().is_open());
}

// ---------------------------------------------------------------------------------------
// (b) garbage and partial lines

#[tokio::test(flavor = "current_thread")]
async fn the_host_skips_garbage_and_reassembles_partial_lines() {
    let (host_end, mut raw) = pty_pair();
    // The fake adapter's three OKs are waiting before the host asks.
    raw.write_all(b"\r\r\r").await.unwrap();
    let mut host = within("handshake", SlcanBus::new(host_end, 1_000_000))
        .await
        .unwrap();
    assert_eq!(read_some(&mut raw, 7).await, b"C\rS8\rO\r");

    // A frame in pieces with pauses, garbage lines in between, a BEL, a z.
    let pieces: [&[u8]; 7] = [
        b"t12",
        b"32A",
        b"ABB\r\x00\xff\xfe\rt9990\rt1239\r",
        b"\x07z\r\n",
        b"T1FFFFF",
        b"F01DE\r",
        b"hello\rr7FF8\r",
    ];
    for piece in pieces {
        raw.write_all(piece).await.unwrap();
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    assert_eq!(
        within("a frame in pieces", host.recv()).await.unwrap(),
        CanFrame::new(0x123, &[0xAA, 0xBB]).unwrap()
    );
    assert_eq!(
        within("an extended frame", host.recv()).await.unwrap(),
        CanFrame::with(0x1FFF_FFF0, true, false, &[0xDE]).unwrap()
    );
    assert_eq!(
        within("a remote frame", host.recv()).await.unwrap(),
        CanFrame::remote(0x7FF, 8).unwrap()
    );
    assert_eq!(host.refusals(), 1);

    // An endless stream of garbage is an error, not a hang; after good lines it is noise
    // on the line (a wrong serial speed garbles every line from the start).
    let noise: Vec<u8> = (0..20).flat_map(|i| [0xA5, 0x80 + i, b'\r']).collect();
    raw.write_all(&noise).await.unwrap();
    let e = within("the garbage error", host.recv())
        .await
        .expect_err("garbage");
    assert!(matches!(e, Error::Protocol(_)), "{e:?}");
    assert!(
        e.to_string()
            .contains("is noisy: 16 garbled lines in a row after"),
        "{e}"
    );

    // And after it, good lines are good again.
    raw.write_all(b"t0011FF\r").await.unwrap();
    assert_eq!(
        within("after the garbage", host.recv()).await.unwrap(),
        CanFrame::new(0x001, &[0xFF]).unwrap()
    );

    // The port closing is a lost connection.
    drop(raw);
    let e = within("the closed port", host.recv())
        .await
        .expect_err("closed");
    assert!(matches!(e, Error::Disconnected(_)), "{e:?}");
}

#[tokio::test(flavor = "current_thread")]
async fn the_adapter_refuses_garbage_and_keeps_going() {
    let (mut raw, adapter_end) = pty_pair();
    let mut device = SlcanDevice::new(adapter_end);
    raw.write_all(b"O\r").await.unwrap();
    assert_eq!(serving(&mut device, read_some(&mut raw, 1)).await, b"\r");

    // Pseudo-random bytes in odd-sized pieces.
    let mut seed = 0x2545_F491_4F6C_DD1Du64;
    let mut noise = Vec::new();
    for _ in 0..2000 {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        noise.push((seed >> 24) as u8);
    }
    noise.push(b'\r');
    for piece in noise.chunks(37) {
        raw.write_all(piece).await.unwrap();
    }
    // The noise may have held any command (`C` among them): end its last line, open the
    // channel again, then a frame in pieces.
    raw.write_all(b"\rO\r").await.unwrap();
    raw.write_all(b"t1").await.unwrap();
    raw.write_all(b"23").await.unwrap();
    raw.write_all(b"1").await.unwrap();
    raw.write_all(b"42\r").await.unwrap();
    let frame = within("the frame after the noise", async {
        loop {
            let frame = device.recv().await.unwrap();
            // The noise may happen to hold a valid frame line; ours is the last one.
            if frame == CanFrame::new(0x123, &[0x42]).unwrap() {
                break frame;
            }
        }
    })
    .await;
    assert_eq!(frame.id(), 0x123);
    // The answers were OKs and BELs, nothing else.
    let answers = read_some(&mut raw, usize::MAX).await;
    assert!(answers.contains(&0x07), "garbage is refused");
    assert!(
        answers
            .iter()
            .all(|&b| b == b'\r' || b == 0x07 || b.is_ascii_alphanumeric()),
        "{}",
        answers.escape_ascii()
    );
}

// ---------------------------------------------------------------------------------------
// (c) SocketCAN over a Unix socket pair, (d) on vcan0

#[cfg(target_os = "linux")]
mod socketcan {
    use std::os::fd::OwnedFd;
    use std::os::unix::net::UnixDatagram;
    use std::path::Path;

    use drivedeck::link::canopen::socketcan::SocketCanBus;

    use super::*;

    fn pair() -> (SocketCanBus, SocketCanBus) {
        let (a, b) = UnixDatagram::pair().expect("a Unix datagram pair");
        (
            SocketCanBus::from_fd(OwnedFd::from(a), "pair-a").unwrap(),
            SocketCanBus::from_fd(OwnedFd::from(b), "pair-b").unwrap(),
        )
    }

    async fn exchange(a: &mut SocketCanBus, b: &mut SocketCanBus) {
        for frame in assorted_frames() {
            a.send(&frame).await.unwrap();
            assert_eq!(within("a to b", b.recv()).await.unwrap(), frame);
            b.send(&frame).await.unwrap();
            assert_eq!(within("b to a", a.recv()).await.unwrap(), frame);
        }
        for frame in assorted_frames() {
            a.send(&frame).await.unwrap();
        }
        for frame in assorted_frames() {
            assert_eq!(within("a burst", b.recv()).await.unwrap(), frame);
        }
    }

    #[tokio::test(flavor = "current_thread")]
    async fn socketcan_frames_cross_a_socket_pair() {
        let (mut a, mut b) = pair();
        assert_eq!(a.describe(), "pair-a");
        exchange(&mut a, &mut b).await;
    }

    /// The kernel's `struct can_frame`: can_id (u32, native = little endian here, with
    /// EFF 8000_0000h and RTR 4000_0000h), len, three bytes of padding, eight data bytes.
    #[cfg(target_endian = "little")]
    #[tokio::test(flavor = "current_thread")]
    async fn socketcan_frames_are_the_kernels_can_frame() {
        let (raw, bus) = UnixDatagram::pair().unwrap();
        raw.set_read_timeout(Some(PATIENCE)).unwrap();
        let mut bus = SocketCanBus::from_fd(OwnedFd::from(bus), "pair").unwrap();
        let mut got = [0u8; 32];

        let sdo = CanFrame::new(0x601, &[0x40, 0x18, 0x10, 0x01]).unwrap();
        bus.send(&sdo).await.unwrap();
        let n = raw.recv(&mut got).unwrap();
        assert_eq!(
            &got[..n],
            &[
                0x01, 0x06, 0, 0, 4, 0, 0, 0, 0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0
            ]
        );

        let extended = CanFrame::with(0x1234_5678, true, false, &[0xAA]).unwrap();
        bus.send(&extended).await.unwrap();
        let n = raw.recv(&mut got).unwrap();
        assert_eq!(
            &got[..n],
            &[
                0x78, 0x56, 0x34, 0x92, 1, 0, 0, 0, 0xAA, 0, 0, 0, 0, 0, 0, 0
            ]
        );

        bus.send(&CanFrame::remote(0x181, 8).unwrap())
            .await
            .unwrap();
        let n = raw.recv(&mut got).unwrap();
        assert_eq!(
            &got[..n],
            &[0x81, 0x01, 0, 0x40, 8, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0]
        );

        // The other way: an error frame (2000_0000h) is skipped, the data frame after it
        // arrives.
        raw.send(&[0x40, 0, 0, 0x20, 8, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0])
            .unwrap();
        raw.send(&[0x81, 0x05, 0, 0, 2, 0, 0, 0, 0x7F, 0x01, 0, 0, 0, 0, 0, 0])
            .unwrap();
        assert_eq!(
            within("the heartbeat", bus.recv()).await.unwrap(),
            CanFrame::new(0x581, &[0x7F, 0x01]).unwrap()
        );
    }

    #[tokio::test(flavor = "current_thread")]
    async fn socketcan_on_vcan0() {
        if !Path::new("/sys/class/net/vcan0").exists() {
            common::skip(
                "no vcan0 on this machine (modprobe vcan; ip link add vcan0 type vcan; ip link set vcan0 up)",
            );
            return;
        }
        let mut a = SocketCanBus::open("vcan0").expect("vcan0");
        let mut b = SocketCanBus::open("vcan0").expect("vcan0 again");
        assert_eq!(a.describe(), "vcan0");
        exchange(&mut a, &mut b).await;
    }

    #[tokio::test(flavor = "current_thread")]
    async fn socketcan_says_what_to_do_about_a_missing_interface() {
        let e = SocketCanBus::open("ddnope7").expect_err("no such interface");
        assert!(
            e.to_string()
                .contains("sudo ip link set ddnope7 up type can bitrate 1000000"),
            "{e}"
        );
        if Path::new("/sys/class/net/lo").exists() {
            let e = SocketCanBus::open("lo").expect_err("lo is not CAN");
            assert!(e.to_string().contains("lo is not a CAN interface"), "{e}");
        }
    }
}

// ---------------------------------------------------------------------------------------
// (e) properties of the codec

fn any_frame() -> impl Strategy<Value = CanFrame> {
    (
        any::<bool>(),
        any::<bool>(),
        any::<u32>(),
        proptest::collection::vec(any::<u8>(), 0..=8),
    )
        .prop_map(|(extended, remote, id, data)| {
            let id = if extended {
                id & 0x1FFF_FFFF
            } else {
                id & 0x7FF
            };
            if remote {
                CanFrame::with(id, extended, true, &vec![0; data.len()]).unwrap()
            } else {
                CanFrame::with(id, extended, false, &data).unwrap()
            }
        })
}

proptest! {
    #[test]
    fn decode_line_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..80)) {
        let _ = decode_line(&bytes);
    }

    #[test]
    fn decode_line_never_panics_on_near_frames(
        kind in prop::sample::select(vec![b't', b'T', b'r', b'R']),
        rest in proptest::collection::vec(
            prop::sample::select(b"0123456789ABCDEFabcdefxZ\r\n\x07 ".to_vec()), 0..40),
    ) {
        let mut line = vec![kind];
        line.extend(rest);
        if let Ok(SlcanLine::Frame(frame)) = decode_line(&line) {
            // Whatever decodes as a frame encodes back to an equivalent line.
            prop_assert_eq!(decode_line(&encode_frame(&frame)), Ok(SlcanLine::Frame(frame)));
        }
    }

    #[test]
    fn frames_round_trip(frame in any_frame(), stamp in 0u16..0xEA60) {
        let line = encode_frame(&frame);
        prop_assert!(line.ends_with(b"\r"));
        prop_assert!(!line[1..].iter().any(u8::is_ascii_lowercase), "uppercase hex");
        prop_assert_eq!(decode_line(&line), Ok(SlcanLine::Frame(frame)));
        // The same with an adapter's timestamp.
        let mut stamped = line[..line.len() - 1].to_vec();
        stamped.extend_from_slice(format!("{stamp:04X}\r").as_bytes());
        prop_assert_eq!(decode_line(&stamped), Ok(SlcanLine::Frame(frame)));
    }

    #[test]
    fn the_splitter_reassembles_any_cut(
        frames in proptest::collection::vec(any_frame(), 1..20),
        cuts in proptest::collection::vec(1usize..40, 1..50),
    ) {
        let stream: Vec<u8> = frames.iter().flat_map(encode_frame).collect();
        let mut splitter = LineSplitter::new();
        let mut got = Vec::new();
        let mut at = 0;
        let mut cut = cuts.iter().cycle();
        while at < stream.len() {
            let end = (at + cut.next().unwrap()).min(stream.len());
            splitter.push(&stream[at..end]);
            at = end;
            while let Some(line) = splitter.next_line() {
                match line {
                    Ok(SlcanLine::Frame(frame)) => got.push(frame),
                    other => prop_assert!(false, "{:?}", other),
                }
            }
        }
        prop_assert_eq!(got, frames);
    }

    #[test]
    fn the_splitter_survives_anything(
        chunks in proptest::collection::vec(proptest::collection::vec(any::<u8>(), 0..100), 0..20),
    ) {
        let mut splitter = LineSplitter::new();
        for chunk in &chunks {
            splitter.push(chunk);
            prop_assert!(splitter.partial().len() <= MAX_LINE);
            while let Some(line) = splitter.next_line() {
                if let Err(e) = line {
                    // Every error can be shown to a user.
                    prop_assert!(!e.to_string().is_empty());
                    if let SlcanError::TooLong(text) = e {
                        prop_assert!(text.len() <= 4 * MAX_LINE);
                    }
                }
            }
        }
        // And a good line after all that still decodes.
        splitter.push(b"\rt7001");
        splitter.push(b"05\r");
        let mut last = None;
        while let Some(line) = splitter.next_line() {
            last = Some(line);
        }
        prop_assert_eq!(
            last,
            Some(Ok(SlcanLine::Frame(CanFrame::new(0x700, &[0x05]).unwrap())))
        );
    }
}
