//! SocketCAN (Linux): `can0` from a PEAK, candleLight, Ixxat or Kvaser USB adapter, a
//! CAN HAT, or `vcan0` for a virtual bus.
//!
//! The socketcan crate does the socket and the kernel's `struct can_frame`; this module
//! converts frames and turns the kernel's errors into what the technician should do.
//!
//! The socket is the crate's blocking `CanSocket` in non-blocking mode under tokio's
//! `AsyncFd`, which is exactly what `socketcan::tokio::CanSocket` is inside; that type
//! cannot be built from an existing descriptor, and this one can, so the tests run the
//! crate's frame code over a Unix socket pair on kernels without CAN.

use std::io;
use std::os::fd::OwnedFd;
use std::path::Path;
use std::time::Duration;

use ::socketcan::{
    CanFrame as WireFrame, EmbeddedFrame, ExtendedId, Frame, Id, Socket, StandardId,
};
use tokio::io::Interest;
use tokio::io::unix::AsyncFd;

use super::CanBus;
use crate::link::Error;
use crate::proto::canopen::CanFrame;

// Linux errno values (the kernel's, the same on every architecture drivedeck runs on).
const ENODEV: i32 = 19;
const EAFNOSUPPORT: i32 = 97;
const ENETDOWN: i32 = 100;
const ENOBUFS: i32 = 105;

/// `ARPHRD_CAN`, the link type of CAN interfaces in `/sys/class/net/*/type`.
const ARPHRD_CAN: &str = "280";
/// `IFF_UP` in `/sys/class/net/*/flags`.
const IFF_UP: u32 = 0x1;

/// How long `send` keeps retrying while the kernel's transmit queue is full (nothing on the
/// bus acknowledges the frames, or the bus is slow).
const QUEUE_FULL_PATIENCE: Duration = Duration::from_millis(200);

/// One node on a SocketCAN interface. Like every raw CAN socket it hears every frame on
/// the interface except its own.
#[derive(Debug)]
pub struct SocketCanBus {
    socket: AsyncFd<::socketcan::CanSocket>,
    name: String,
}

impl SocketCanBus {
    /// Open the CAN interface `iface` (`can0`, `vcan0`). Must run inside a tokio runtime.
    pub fn open(iface: &str) -> Result<Self, Error> {
        check_interface(iface)?;
        let socket = ::socketcan::CanSocket::open(iface).map_err(|e| open_error(iface, e))?;
        Self::from_socket(socket, iface)
    }

    /// A bus over a socket that is already open; `name` goes into messages. Must run inside
    /// a tokio runtime.
    pub fn from_socket(
        socket: ::socketcan::CanSocket,
        name: impl Into<String>,
    ) -> Result<Self, Error> {
        let name = name.into();
        let wrap = |socket: ::socketcan::CanSocket| {
            socket.set_nonblocking(true)?;
            // SAFETY: the `CanSocket` owns its descriptor (a `socket2::Socket`), keeps it
            // open until dropped and always returns it from `as_raw_fd`; the `AsyncFd`
            // owns the socket from here on.
            unsafe { AsyncFd::register(socket) }.map_err(|e| e.into_parts().1)
        };
        let socket = wrap(socket).map_err(|e| Error::Io {
            context: format!("setting up the CAN socket on {name}"),
            source: e,
        })?;
        Ok(SocketCanBus { socket, name })
    }

    /// A bus over any socket descriptor that carries `struct can_frame`s: a CAN_RAW socket,
    /// or one end of a Unix datagram or seqpacket pair in tests.
    pub fn from_fd(fd: OwnedFd, name: impl Into<String>) -> Result<Self, Error> {
        Self::from_socket(::socketcan::CanSocket::from(fd), name)
    }

    fn io_error(&self, what: &str, e: io::Error) -> Error {
        match e.raw_os_error() {
            Some(ENETDOWN) => Error::Refused(down_message(&self.name)),
            Some(ENODEV) => Error::Disconnected(format!(
                "the CAN interface {} is gone while {what}: was the adapter unplugged?",
                self.name
            )),
            _ if e.kind() == io::ErrorKind::UnexpectedEof => {
                Error::Disconnected(format!("{}: the socket closed while {what}", self.name))
            }
            _ => Error::Io {
                context: format!("{}: {what}", self.name),
                source: e,
            },
        }
    }
}

/// The frame as the socketcan crate carries it.
fn to_wire(frame: &CanFrame) -> Option<WireFrame> {
    let id: Id = if frame.is_extended() {
        ExtendedId::new(frame.id())?.into()
    } else {
        StandardId::new(u16::try_from(frame.id()).ok()?)?.into()
    };
    if frame.is_remote() {
        WireFrame::new_remote(id, frame.len())
    } else {
        WireFrame::new(id, frame.data())
    }
}

/// A data or remote frame from the socketcan crate.
fn from_wire(frame: &impl Frame) -> Result<CanFrame, crate::proto::canopen::FrameError> {
    let remote = frame.is_remote_frame();
    let zeros = [0u8; 8];
    let data = if remote {
        &zeros[..frame.dlc().min(8)]
    } else {
        frame.data()
    };
    CanFrame::with(frame.raw_id(), frame.is_extended(), remote, data)
}

impl CanBus for SocketCanBus {
    async fn send(&mut self, frame: &CanFrame) -> Result<(), Error> {
        let wire = to_wire(frame)
            .ok_or_else(|| Error::Protocol(format!("{frame} does not fit a CAN frame")))?;
        let deadline = tokio::time::Instant::now() + QUEUE_FULL_PATIENCE;
        loop {
            let sent = self
                .socket
                .async_io(Interest::WRITABLE, |socket| socket.write_frame(&wire))
                .await;
            match sent {
                Ok(()) => return Ok(()),
                // The kernel's transmit queue is full: wait for the bus to take frames.
                Err(e) if e.raw_os_error() == Some(ENOBUFS) => {
                    if tokio::time::Instant::now() >= deadline {
                        return Err(Error::Timeout {
                            what: format!(
                                "sending {frame} on {}: the transmit queue stays full, so nothing on the bus acknowledges frames (is the drive powered and connected, its bit rate the interface's, the bus terminated with 120 Ω at both ends?)",
                                self.name
                            ),
                            after: QUEUE_FULL_PATIENCE,
                        });
                    }
                    tokio::time::sleep(Duration::from_millis(2)).await;
                }
                Err(e) => return Err(self.io_error(&format!("sending {frame}"), e)),
            }
        }
    }

    async fn recv(&mut self) -> Result<CanFrame, Error> {
        loop {
            let read = self
                .socket
                .async_io(Interest::READABLE, |socket| socket.read_frame())
                .await;
            let frame = match read {
                Ok(frame) => frame,
                Err(e) => return Err(self.io_error("receiving", e)),
            };
            let converted = match &frame {
                WireFrame::Data(data) => from_wire(data),
                WireFrame::Remote(remote) => from_wire(remote),
                // Only arrive when asked for with an error filter; nothing to hand a node.
                WireFrame::Error(error) => {
                    tracing::warn!("{}: CAN error frame: {}", self.name, error.into_error());
                    continue;
                }
            };
            return converted.map_err(|e| {
                Error::Protocol(format!(
                    "{}: a frame the kernel should not deliver: {e}",
                    self.name
                ))
            });
        }
    }

    fn describe(&self) -> String {
        self.name.clone()
    }
}

fn missing_message(iface: &str) -> String {
    format!(
        "there is no CAN interface {iface} on this machine (`ip -br link` lists the interfaces): plug in the adapter and bring it up with `sudo ip link set {iface} up type can bitrate 1000000` (at the drive's bit rate); for a virtual bus: `sudo modprobe vcan; sudo ip link add vcan0 type vcan; sudo ip link set vcan0 up`; a CANable with slcan firmware is canopen+slcan:///dev/ttyACM0 instead"
    )
}

fn down_message(iface: &str) -> String {
    if iface.starts_with("vcan") {
        format!("the CAN interface {iface} is down: `sudo ip link set {iface} up`")
    } else {
        format!(
            "the CAN interface {iface} is down: `sudo ip link set {iface} up type can bitrate 1000000` (at the drive's bit rate)"
        )
    }
}

/// Find what is wrong with `iface` before opening it, from what `/sys/class/net` says.
/// Where there is no `/sys`, the socket's own error has to do.
fn check_interface(iface: &str) -> Result<(), Error> {
    let net = Path::new("/sys/class/net");
    if !net.is_dir() {
        return Ok(());
    }
    if iface.is_empty() || iface.contains('/') || iface == "." || iface == ".." {
        return Err(Error::Unsupported(format!(
            "`{iface}` is not a network interface name (can0, vcan0)"
        )));
    }
    let dir = net.join(iface);
    if !dir.exists() {
        return Err(Error::Refused(missing_message(iface)));
    }
    if let Ok(kind) = std::fs::read_to_string(dir.join("type"))
        && kind.trim() != ARPHRD_CAN
    {
        return Err(Error::Unsupported(format!(
            "{iface} is not a CAN interface (link type {}); `ip -br link` lists the interfaces, CAN ones are usually can0 or vcan0",
            kind.trim()
        )));
    }
    if let Ok(flags) = std::fs::read_to_string(dir.join("flags"))
        && let Ok(flags) = u32::from_str_radix(flags.trim().trim_start_matches("0x"), 16)
        && flags & IFF_UP == 0
    {
        return Err(Error::Refused(down_message(iface)));
    }
    Ok(())
}

fn open_error(iface: &str, e: io::Error) -> Error {
    match e.raw_os_error() {
        Some(ENODEV) => Error::Refused(missing_message(iface)),
        Some(EAFNOSUPPORT) => Error::Unsupported(format!(
            "this kernel has no SocketCAN (opening {iface}: {e}): `sudo modprobe can_raw`, or use an slcan adapter (canopen+slcan:///dev/ttyACM0)"
        )),
        Some(ENETDOWN) => Error::Refused(down_message(iface)),
        _ => Error::Io {
            context: format!("opening CAN interface {iface}"),
            source: e,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_convert_both_ways() {
        for frame in [
            CanFrame::new(0x601, &[0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0]).unwrap(),
            CanFrame::new(0x000, &[]).unwrap(),
            CanFrame::remote(0x181, 8).unwrap(),
            CanFrame::with(0x1FFF_FFFF, true, false, &[1, 2, 3]).unwrap(),
            CanFrame::with(0x10, true, true, &[0; 5]).unwrap(),
        ] {
            let wire = to_wire(&frame).unwrap();
            assert_eq!(wire.is_extended(), frame.is_extended());
            let back = match wire {
                WireFrame::Data(f) => from_wire(&f),
                WireFrame::Remote(f) => from_wire(&f),
                WireFrame::Error(_) => panic!("{frame} became an error frame"),
            };
            assert_eq!(back.unwrap(), frame);
        }
    }

    #[test]
    fn a_missing_interface_says_how_to_make_one() {
        let e = open_error("can7", io::Error::from_raw_os_error(ENODEV)).to_string();
        assert!(
            e.contains("sudo ip link set can7 up type can bitrate 1000000"),
            "{e}"
        );
        let e = down_message("vcan0");
        assert!(e.contains("sudo ip link set vcan0 up"), "{e}");
        let e = open_error("can0", io::Error::from_raw_os_error(EAFNOSUPPORT)).to_string();
        assert!(e.contains("modprobe can_raw"), "{e}");
    }
}
