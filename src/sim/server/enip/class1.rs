//! Class 1 I/O: O→T datagrams in, due T→O datagrams out, the originator's silence, discovery.

use std::net::SocketAddrV4;
use std::time::Instant;

use super::adapter::Adapter;
use super::images::{common_in, cpf_data, services_item};
use super::{Datagram, answer, write_int};
use crate::proto::enip::assembly::{self, AssemblySet, CommonOut};
use crate::proto::enip::cpf::Item;
use crate::proto::enip::encap::{Command, Packet, Status};
use crate::proto::enip::io::{IoPacket, sequence_after};
use crate::sim::Drive;

impl Adapter {
    /// A datagram on the I/O UDP socket.
    pub fn io_datagram(
        &mut self,
        from: SocketAddrV4,
        bytes: &[u8],
        drive: &mut Drive,
        now: Instant,
    ) {
        if self.restarted(drive) {
            return;
        }
        let Some(io) = self.io.as_mut() else {
            return;
        };
        if IoPacket::connection_of(bytes) != Some(io.ot_id) || *from.ip() != io.originator {
            return;
        }
        let Ok(packet) = IoPacket::decode(bytes, io.ot_header) else {
            return;
        };
        if packet.data.len() != io.set.ot_len(io.cmd) {
            return;
        }
        if io
            .last_sequence
            .is_some_and(|last| !sequence_after(packet.sequence, last))
        {
            return;
        }
        io.last_sequence = Some(packet.sequence);
        io.last_ot = Some(now);
        io.received += 1;
        if packet.run == Some(false) {
            return; // idle: the originator holds its outputs back
        }
        match io.set {
            AssemblySet::Pdi => {
                if let Ok(rx) = assembly::decode_pdi_ot(&packet.data, io.cmd) {
                    drive.write_rx(&rx);
                }
            }
            AssemblySet::Common => {
                if let Ok(out) = CommonOut::decode(&packet.data) {
                    write_int(drive, 0x60FE, 1, i64::from(out.digital_outputs));
                    for (i, v) in out.nanoj_inputs.iter().enumerate() {
                        write_int(drive, 0x2400, i as u8 + 1, i64::from(*v));
                    }
                    drive.write_rx(&out.rx);
                }
            }
        }
    }

    /// Time passes: the T→O datagram when one is due, and the end of a connection whose
    /// originator went silent (the drive latches fault 8000h).
    pub fn poll(&mut self, drive: &mut Drive, now: Instant) -> Vec<Datagram> {
        if self.restarted(drive) {
            return vec![];
        }
        let Some(io) = self.io.as_mut() else {
            return vec![];
        };
        if now >= io.deadline() {
            self.io = None;
            drive.fieldbus_lost();
            return vec![];
        }
        if now < io.next_send {
            return vec![];
        }
        io.sequence = io.sequence.wrapping_add(1);
        io.count = io.count.wrapping_add(1);
        let data = match io.set {
            AssemblySet::Pdi => drive.tx_image().to_bytes().to_vec(),
            AssemblySet::Common => common_in(drive).encode().to_vec(),
        };
        let packet = IoPacket {
            connection: io.to_id,
            sequence: io.sequence,
            count: io.count,
            run: io.to_header.then_some(true),
            data,
        };
        io.next_send += io.to_rpi;
        if io.next_send <= now {
            // Late (a loaded machine): no burst to catch up.
            io.next_send = now + io.to_rpi;
        }
        vec![Datagram {
            to: io.target,
            bytes: packet.encode(),
        }]
    }

    /// When [`Adapter::poll`] has something to do next.
    pub fn next_due(&self) -> Option<Instant> {
        self.io.as_ref().map(|io| io.next_send.min(io.deadline()))
    }

    /// A datagram on the discovery UDP socket (the TCP port): ListIdentity and
    /// ListServices are answered, everything else ignored. `local` is the socket's address.
    pub fn discovery(&self, bytes: &[u8], local: SocketAddrV4, drive: &Drive) -> Option<Vec<u8>> {
        if drive.rebooting() {
            return None;
        }
        let packet = Packet::decode(bytes).ok()?;
        let items = match packet.command {
            Command::LIST_IDENTITY => vec![Item::Identity(Box::new(self.identity(drive, local)))],
            Command::LIST_SERVICES => vec![services_item()],
            _ => return None,
        };
        Some(answer(&packet, Status::SUCCESS, cpf_data(&items)).encode())
    }
}
