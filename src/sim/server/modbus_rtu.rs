//! The simulated drives on a Modbus RTU line: one serial port, one or more slaves, each
//! its own drive answering only its own address (`drivedeck sim --slave 5 --slave 6`).
//! Slave address 0 is broadcast (Modbus over serial line §2.1): a write is executed by
//! every slave and answered by none; anything else sent to 0 is ignored.

use std::io;

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio_serial::{SerialPortBuilderExt, SerialStream};

use super::SharedDrive;
use super::modbus::{ServerOptions, Session, answer_pdu};
use crate::link::Parity;
use crate::proto::modbus::frame::{self, Direction};
use crate::proto::modbus::pdu::Request;

/// The broadcast address.
pub const BROADCAST: u8 = 0;

/// RTU serial settings of the simulated drives (Nanotec factory: slave 5, 19200 8E1).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RtuOptions {
    pub path: String,
    pub baud: u32,
    pub parity: Parity,
    pub stop_bits: u8,
}

/// Open the serial port for the RTU server.
pub fn open_serial(options: &RtuOptions) -> io::Result<SerialStream> {
    tokio_serial::new(options.path.as_str(), options.baud)
        .data_bits(tokio_serial::DataBits::Eight)
        .parity(match options.parity {
            Parity::None => tokio_serial::Parity::None,
            Parity::Even => tokio_serial::Parity::Even,
            Parity::Odd => tokio_serial::Parity::Odd,
        })
        .stop_bits(if options.stop_bits == 2 {
            tokio_serial::StopBits::Two
        } else {
            tokio_serial::StopBits::One
        })
        .open_native_async()
        .map_err(|e| io::Error::other(format!("opening {}: {e}", options.path)))
}

/// One drive on the line: its address and its master's FC 101 cursor.
struct Slave {
    address: u8,
    drive: SharedDrive,
    session: Session,
}

/// Whether a broadcast request is executed: the writes (FC 6, FC 16); reads have nobody
/// to answer to.
fn broadcast_executes(pdu: &[u8]) -> bool {
    matches!(
        Request::decode(pdu),
        Ok(Request::WriteSingle { .. } | Request::WriteMultiple { .. })
    )
}

/// Serve Modbus RTU on an open serial port until the task is dropped: each of `slaves`
/// (address, drive) answers the requests to its own address.
pub async fn serve_rtu<S>(
    mut port: S,
    slaves: Vec<(u8, SharedDrive)>,
    options: ServerOptions,
) -> io::Result<()>
where
    S: tokio::io::AsyncRead + tokio::io::AsyncWrite + Unpin,
{
    let mut slaves: Vec<Slave> = slaves
        .into_iter()
        .map(|(address, drive)| Slave {
            address,
            drive,
            session: Session::default(),
        })
        .collect();
    let mut buffer = Vec::with_capacity(512);
    let mut chunk = [0u8; 256];
    loop {
        // A frame that never completes is dropped after a silence (the RTU frame gap).
        let read =
            tokio::time::timeout(std::time::Duration::from_millis(50), port.read(&mut chunk)).await;
        match read {
            Err(_) => {
                buffer.clear();
                continue;
            }
            Ok(Ok(0)) => return Ok(()),
            Ok(Ok(n)) => buffer.extend_from_slice(&chunk[..n]),
            Ok(Err(e)) => return Err(e),
        }
        loop {
            match frame::decode_rtu(&buffer, Direction::Request) {
                Ok(Some((frame, used))) => {
                    buffer.drain(..used);
                    if frame.slave == BROADCAST {
                        if broadcast_executes(&frame.pdu) {
                            for slave in &mut slaves {
                                // No reply to a broadcast, not even an exception.
                                let _ = answer_pdu(
                                    &slave.drive,
                                    &mut slave.session,
                                    &frame.pdu,
                                    &options,
                                );
                            }
                        }
                        continue;
                    }
                    let Some(slave) = slaves.iter_mut().find(|s| s.address == frame.slave) else {
                        continue; // another device's request
                    };
                    if let Some(pdu) =
                        answer_pdu(&slave.drive, &mut slave.session, &frame.pdu, &options)
                    {
                        port.write_all(&frame::encode_rtu(slave.address, &pdu))
                            .await?;
                        port.flush().await?;
                    }
                }
                Ok(None) => break,
                Err(_) => {
                    // Bad CRC or garbage: wait for the gap and start afresh.
                    buffer.clear();
                    break;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use tokio::io::DuplexStream;

    use super::*;
    use crate::proto::modbus::registers::PDI_RX;
    use crate::sim::Drive;

    /// The next frame the line sends back to the master.
    async fn reply(master: &mut DuplexStream, buffer: &mut Vec<u8>) -> frame::RtuFrame {
        let mut chunk = [0u8; 256];
        loop {
            if let Some((frame, used)) =
                frame::decode_rtu(buffer, Direction::Response).expect("a good frame")
            {
                buffer.drain(..used);
                return frame;
            }
            let n = master.read(&mut chunk).await.expect("read");
            assert!(n > 0, "the line closed");
            buffer.extend_from_slice(&chunk[..n]);
        }
    }

    async fn send(master: &mut DuplexStream, slave: u8, request: &Request) {
        master
            .write_all(&frame::encode_rtu(slave, &request.encode()))
            .await
            .expect("write");
    }

    fn set_value_1(value: u32) -> Request {
        Request::WriteMultiple {
            address: PDI_RX,
            values: vec![(value >> 16) as u16, value as u16],
        }
    }

    const READ_SET_VALUE_1: Request = Request::ReadHolding {
        address: PDI_RX,
        count: 2,
    };

    #[tokio::test(flavor = "current_thread")]
    async fn two_slaves_on_one_line_answer_only_their_own_address_and_both_take_a_broadcast() {
        let (mut master, line) = tokio::io::duplex(1024);
        let drives = [
            SharedDrive::new(Drive::new()),
            SharedDrive::new(Drive::new()),
        ];
        let slaves = vec![(5, drives[0].clone()), (6, drives[1].clone())];
        tokio::spawn(serve_rtu(line, slaves, ServerOptions::default()));
        let mut buffer = vec![];
        // A write to slave 5 is slave 5's alone, answered by slave 5.
        send(&mut master, 5, &set_value_1(0x0001_0002)).await;
        let answer = reply(&mut master, &mut buffer).await;
        assert_eq!(answer.slave, 5);
        // Nobody is slave 7: its request goes unanswered, and the next answer on the line
        // is slave 6's to its own read, with slave 6's own (untouched) value.
        send(&mut master, 7, &READ_SET_VALUE_1).await;
        send(&mut master, 6, &READ_SET_VALUE_1).await;
        let answer = reply(&mut master, &mut buffer).await;
        assert_eq!(answer.slave, 6);
        assert_eq!(answer.pdu, [3, 4, 0, 0, 0, 0]);
        send(&mut master, 5, &READ_SET_VALUE_1).await;
        let answer = reply(&mut master, &mut buffer).await;
        assert_eq!((answer.slave, answer.pdu), (5, vec![3, 4, 0, 1, 0, 2]));
        // A broadcast write: both execute it, neither answers (the next answer is the read's).
        send(&mut master, BROADCAST, &set_value_1(0x0003_0004)).await;
        // A broadcast read is not executed (nor answered).
        send(&mut master, BROADCAST, &READ_SET_VALUE_1).await;
        for (slave, drive) in [(5u8, &drives[0]), (6, &drives[1])] {
            send(&mut master, slave, &READ_SET_VALUE_1).await;
            let answer = reply(&mut master, &mut buffer).await;
            assert_eq!((answer.slave, answer.pdu), (slave, vec![3, 4, 0, 3, 0, 4]));
            assert_eq!(
                drive.lock().read(crate::od::Address::new(0x2291, 1)),
                Ok(crate::od::Value::Int(0x0003_0004))
            );
        }
    }
}
