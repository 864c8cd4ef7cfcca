use super::images::identity_of;
use super::*;
use crate::od::Value;
use crate::pdi::{Command as PdiCommand, Opcode, RxImage, SetValues};
use crate::proto::enip::cip::{Path, Request, UnconnectedSend, class, service};
use crate::proto::enip::connection::{
    ForwardClose, ForwardOpen, ForwardOpenReply, NetworkParams, TRANSPORT_CLASS1_CYCLIC,
    encode_forward_close_reply, extended,
};
use crate::proto::enip::cpf::Item;
use crate::proto::enip::encap::{Command, Framed, RrData};
use crate::proto::enip::io::IoPacket;
use crate::proto::enip::nanotec;
use proptest::prelude::*;

const B_IP: Ipv4Addr = Ipv4Addr::new(10, 0, 0, 2);
const A_IP: Ipv4Addr = Ipv4Addr::new(10, 0, 0, 9);
const LOCAL: SocketAddrV4 = SocketAddrV4::new(Ipv4Addr::new(10, 0, 0, 1), 44818);

fn packet(command: Command, session: u32, data: Vec<u8>) -> Vec<u8> {
    Packet::new(command, session, *b"testctx\0", data).encode()
}

fn rr(session: u32, request: &Request, extra: Vec<Item>) -> Vec<u8> {
    let mut items = vec![Item::Null, Item::UnconnectedData(request.encode())];
    items.extend(extra);
    packet(
        Command::SEND_RR_DATA,
        session,
        RrData::new(5, items).encode(),
    )
}

/// The packets of a reply stream.
fn packets(mut bytes: &[u8]) -> Vec<Packet> {
    let mut out = vec![];
    while let Framed::Packet(p, n) = encap::split(bytes) {
        out.push(p);
        bytes = &bytes[n..];
    }
    assert!(bytes.is_empty(), "a partial reply: {bytes:?}");
    out
}

fn mr_reply(bytes: &[u8]) -> (Reply, Vec<Item>) {
    let replies = packets(bytes);
    assert_eq!(replies.len(), 1, "{replies:?}");
    let rr = RrData::decode(&replies[0].data).expect("SendRRData body");
    let reply = Reply::decode(rr.unconnected().expect("unconnected item")).expect("reply");
    (reply, rr.items)
}

struct Bench {
    adapter: Adapter,
    drive: Drive,
    now: Instant,
}

impl Bench {
    fn new() -> Bench {
        Bench {
            adapter: Adapter::new(DEFAULT_MAX_SESSIONS, 2222),
            drive: Drive::new(),
            now: Instant::now(),
        }
    }

    fn send(&mut self, stream: StreamId, bytes: &[u8]) -> Received {
        self.adapter
            .receive(stream, bytes, &mut self.drive, self.now)
    }

    fn client(&mut self, ip: Ipv4Addr) -> (StreamId, u32) {
        let id = self.adapter.accept(LOCAL, SocketAddrV4::new(ip, 50000));
        let out = self.send(
            id,
            &packet(Command::REGISTER_SESSION, 0, encap::register_session_data()),
        );
        let reply = packets(&out.reply).remove(0);
        assert_eq!(reply.status, Status::SUCCESS);
        (id, reply.session)
    }

    fn request(&mut self, (id, session): (StreamId, u32), request: &Request) -> Reply {
        let out = self.send(id, &rr(session, request, vec![]));
        mr_reply(&out.reply).0
    }
}

fn forward_open(transport: u8, path: Vec<u8>, ot: u16, to: u16, serial: u16) -> ForwardOpen {
    ForwardOpen {
        large: false,
        tick: 0x0A,
        timeout_ticks: 0x0E,
        ot_connection: 0,
        to_connection: 0x7000_0000 + u32::from(serial),
        serial,
        vendor: 0x1234,
        originator_serial: 0xABCD_0000 + u32::from(serial),
        timeout_multiplier: 0,
        ot_rpi_us: 10_000,
        ot_params: NetworkParams::point_to_point(ot),
        to_rpi_us: 10_000,
        to_params: NetworkParams::point_to_point(to),
        transport,
        path,
    }
}

fn pdi_open(serial: u16) -> ForwardOpen {
    forward_open(
        TRANSPORT_CLASS1_CYCLIC,
        vec![0x20, 0x04, 0x24, 0x64, 0x2C, 0x69, 0x2C, 0x68],
        14,
        10,
        serial,
    )
}

fn class3_open(serial: u16) -> ForwardOpen {
    forward_open(0xA3, vec![0x20, 0x02, 0x24, 0x01], 504, 504, serial)
}

fn cm(service: u8, data: Vec<u8>) -> Request {
    Request::new(service, &Path::object(class::CONNECTION_MANAGER, 1), data)
}

fn opened(reply: &Reply) -> ForwardOpenReply {
    assert!(reply.status.is_success(), "{}", reply.status_text());
    ForwardOpenReply::decode(&reply.data).expect("Forward_Open reply")
}

fn unit_data(session: u32, connection: u32, sequence: u16, request: &Request) -> Vec<u8> {
    let mut data = sequence.to_le_bytes().to_vec();
    data.extend_from_slice(&request.encode());
    let items = vec![
        Item::ConnectedAddress(connection),
        Item::ConnectedData(data),
    ];
    packet(
        Command::SEND_UNIT_DATA,
        session,
        RrData::new(0, items).encode(),
    )
}

fn vendor_id() -> Request {
    nanotec::get_od(Address::new(0x1018, 1))
}

#[test]
fn abort_codes_map_to_the_documented_statuses() {
    let s = |code: AbortCode| status_of_abort(code);
    assert_eq!(s(AbortCode::NO_OBJECT).0, GeneralStatus(0x05));
    assert_eq!(s(AbortCode::NO_SUBINDEX).0, GeneralStatus(0x14));
    assert_eq!(s(AbortCode::READ_ONLY).0, GeneralStatus(0x0E));
    assert_eq!(s(AbortCode::WRITE_ONLY).0, GeneralStatus(0x2C));
    for code in [0x0609_0030, 0x0609_0031, 0x0609_0032, 0x0609_0036] {
        assert_eq!(s(AbortCode(code)), (GeneralStatus(0x09), vec![]));
    }
    assert_eq!(s(AbortCode(0x0607_0013)).0, GeneralStatus(0x13));
    assert_eq!(s(AbortCode(0x0607_0012)).0, GeneralStatus(0x15));
    assert_eq!(s(AbortCode(0x0607_0010)).0, GeneralStatus(0x15));
    assert_eq!(
        s(AbortCode::CANNOT_STORE),
        (GeneralStatus(0x1F), vec![0x0020, 0x0800])
    );
}

#[test]
fn the_identity_comes_from_1018h_and_1008h() {
    let drive = Drive::new();
    let id = identity_of(&drive, LOCAL, false);
    assert_eq!((id.vendor, id.device_type), (0x0558, 0x2B));
    assert_eq!(id.product_code, 0x42);
    // 1018h:03 = 08030000h: major = bits 16-23, minor = bits 0-7.
    assert_eq!(id.revision, (3, 0));
    assert_eq!(id.serial, 0x1234);
    assert_eq!(id.product_name, "drivedeck simulated drive");
    assert_eq!((id.status, id.state), (0, 3));
    assert_eq!(identity_of(&drive, LOCAL, true).status, 1);
}

#[test]
fn production_follows_the_rpi_and_silence_latches_fault_8000h() {
    let mut b = Bench::new();
    let client = b.client(B_IP);
    let reply = b.request(client, &cm(service::FORWARD_OPEN, pdi_open(1).encode()));
    let accepted = opened(&reply);
    let t0 = b.now;
    let first = b.adapter.poll(&mut b.drive, t0);
    assert_eq!(first.len(), 1);
    assert_eq!(first[0].to, SocketAddrV4::new(B_IP, 2222));
    let p = IoPacket::decode(&first[0].bytes, false).expect("T→O");
    assert_eq!(
        (p.connection, p.sequence, p.count, p.run),
        (accepted.to_connection, 1, 1, None)
    );
    assert_eq!(p.data, b.drive.tx_image().to_bytes());
    assert!(
        b.adapter
            .poll(&mut b.drive, t0 + Duration::from_millis(5))
            .is_empty()
    );
    let second = b.adapter.poll(&mut b.drive, t0 + Duration::from_millis(10));
    assert_eq!(
        IoPacket::decode(&second[0].bytes, false).map(|p| p.sequence),
        Ok(2)
    );
    // The first O→T packet may take up to a second (the timeout itself is 40 ms).
    let at = t0 + Duration::from_millis(900);
    assert!(!b.adapter.poll(&mut b.drive, at).is_empty());
    let ot = |sequence: u32, run: bool, data: Vec<u8>| {
        IoPacket {
            connection: accepted.ot_connection,
            sequence,
            count: sequence as u16,
            run: Some(run),
            data,
        }
        .encode()
    };
    let rx = RxImage::new(
        SetValues {
            value1: 2000,
            value2: 200,
            value3: 0,
        },
        PdiCommand::new(Opcode::MoveAbsolute),
    );
    let image = rx.to_bytes().to_vec();
    // Idle, then from a stranger, then old: nothing applies.
    b.adapter.io_datagram(
        SocketAddrV4::new(B_IP, 2222),
        &ot(5, false, image.clone()),
        &mut b.drive,
        at,
    );
    b.adapter.io_datagram(
        SocketAddrV4::new(A_IP, 2222),
        &ot(6, true, image.clone()),
        &mut b.drive,
        at,
    );
    b.adapter.io_datagram(
        SocketAddrV4::new(B_IP, 2222),
        &ot(4, true, image.clone()),
        &mut b.drive,
        at,
    );
    assert_eq!(b.drive.rx_image(), RxImage::default());
    assert_eq!(b.adapter.io_connection().map(|io| io.received), Some(1));
    b.adapter.io_datagram(
        SocketAddrV4::new(B_IP, 2222),
        &ot(7, true, image),
        &mut b.drive,
        at,
    );
    assert_eq!(b.drive.rx_image(), rx);
    // Fed at `at`: alive 39 ms later, gone at 40 ms with the fault.
    assert!(
        !b.adapter
            .poll(&mut b.drive, at + Duration::from_millis(39))
            .is_empty()
    );
    assert!(
        b.adapter
            .poll(&mut b.drive, at + Duration::from_millis(40))
            .is_empty()
    );
    assert!(b.adapter.io_connection().is_none());
    assert_eq!(b.drive.tx_image().error_code, 0x8000);
    assert_eq!(b.adapter.next_due(), None);
}

#[test]
fn a_class_1_connection_outlives_its_session_and_closes_by_triad() {
    let mut b = Bench::new();
    let first = b.client(B_IP);
    opened(&b.request(first, &cm(service::FORWARD_OPEN, pdi_open(1).encode())));
    b.adapter.disconnect(first.0);
    assert!(b.adapter.io_connection().is_some());
    let again = b.client(B_IP);
    let close = ForwardClose {
        tick: 0x0A,
        timeout_ticks: 0x0E,
        triad: pdi_open(1).triad(),
        path: vec![],
    };
    let reply = b.request(again, &cm(service::FORWARD_CLOSE, close.encode()));
    assert!(reply.status.is_success());
    assert_eq!(reply.data, encode_forward_close_reply(&pdi_open(1).triad()));
    assert!(b.adapter.io_connection().is_none());
    assert_eq!(
        b.drive.tx_image().error_code,
        0,
        "no fault on Forward_Close"
    );
}

#[test]
fn class_3_repeats_the_reply_to_a_repeated_sequence_count() {
    let mut b = Bench::new();
    let client = b.client(B_IP);
    let c3 = opened(&b.request(client, &cm(service::FORWARD_OPEN, class3_open(3).encode())));
    let write = nanotec::set_od(Address::new(0x2031, 0), &1000u32.to_le_bytes()).expect("SetOD");
    let first = b.send(client.0, &unit_data(client.1, c3.ot_connection, 9, &write));
    b.drive
        .write(Address::new(0x2031, 0), Value::Uint(1200))
        .expect("write");
    let again = b.send(client.0, &unit_data(client.1, c3.ot_connection, 9, &write));
    assert_eq!(first.reply, again.reply);
    assert_eq!(
        b.drive.read(Address::new(0x2031, 0)),
        Ok(Value::Uint(1200)),
        "not run twice"
    );
    let reply = packets(&again.reply).remove(0);
    let rr = RrData::decode(&reply.data).expect("body");
    assert_eq!(rr.items[0], Item::ConnectedAddress(c3.to_connection));
}

/// Valid packets of client A, to be mutated.
fn a_packets(session: u32) -> Vec<Vec<u8>> {
    let close = ForwardClose {
        tick: 0x0A,
        timeout_ticks: 0x0E,
        triad: class3_open(40).triad(),
        path: vec![],
    };
    let wrapped = UnconnectedSend {
        tick: 0x0A,
        timeout_ticks: 0x0E,
        request: vendor_id().encode(),
        route: vec![0x01, 0x00],
    };
    vec![
        packet(Command::REGISTER_SESSION, 0, encap::register_session_data()),
        packet(Command::LIST_IDENTITY, 0, vec![]),
        packet(Command::LIST_SERVICES, 0, vec![]),
        packet(Command::NOP, 0, vec![1, 2]),
        rr(session, &vendor_id(), vec![]),
        rr(
            session,
            &nanotec::set_od(Address::new(0x2031, 0), &[1, 2, 3, 4]).expect("SetOD"),
            vec![],
        ),
        rr(
            session,
            &nanotec::get_od_rockwell(Address::new(0x1008, 0)),
            vec![],
        ),
        rr(
            session,
            &cm(service::FORWARD_OPEN, class3_open(40).encode()),
            vec![],
        ),
        rr(
            session,
            &cm(service::FORWARD_OPEN, pdi_open(41).encode()),
            vec![Item::SockaddrTo(SockAddr::new(SocketAddrV4::new(
                A_IP, 2222,
            )))],
        ),
        rr(session, &cm(service::FORWARD_CLOSE, close.encode()), vec![]),
        rr(
            session,
            &cm(service::UNCONNECTED_SEND, wrapped.encode()),
            vec![],
        ),
        unit_data(session, 0x5D00_0001, 1, &vendor_id()),
        rr(
            session,
            &Request::new(0x0E, &Path::attribute(4, 104, 3), vec![]),
            vec![],
        ),
        rr(
            session,
            &Request::new(0x01, &Path::object(1, 1), vec![]),
            vec![],
        ),
        packet(Command::UNREGISTER_SESSION, session, vec![]),
    ]
}

/// B registered, with a class 3 and the class 1 connection; A connected.
fn two_clients() -> (Bench, (StreamId, u32), ForwardOpenReply, IoInfo, StreamId) {
    let mut b = Bench::new();
    let client = b.client(B_IP);
    let c3 = opened(&b.request(client, &cm(service::FORWARD_OPEN, class3_open(1).encode())));
    opened(&b.request(client, &cm(service::FORWARD_OPEN, pdi_open(2).encode())));
    let io = b.adapter.io_connection().expect("class 1");
    let a = b.adapter.accept(LOCAL, SocketAddrV4::new(A_IP, 40000));
    (b, client, c3, io, a)
}

/// B's session, class 3 and class 1 connections all still work.
fn b_is_untouched(b: &mut Bench, client: (StreamId, u32), c3: &ForwardOpenReply, io: &IoInfo) {
    assert_eq!(b.adapter.session(client.0), Some(client.1));
    let reply = b.request(client, &vendor_id());
    assert_eq!(
        (reply.status, reply.data),
        (GeneralStatus::SUCCESS, vec![0x6C, 2, 0, 0])
    );
    let out = b.send(
        client.0,
        &unit_data(client.1, c3.ot_connection, 0xBEEF, &vendor_id()),
    );
    let reply = packets(&out.reply).remove(0);
    assert_eq!(reply.status, Status::SUCCESS);
    let items = RrData::decode(&reply.data).expect("body").items;
    assert_eq!(items[0], Item::ConnectedAddress(c3.to_connection));
    let mut expected = 0xBEEFu16.to_le_bytes().to_vec();
    expected.extend_from_slice(&Reply::success(0x32, vec![0x6C, 2, 0, 0]).encode());
    assert_eq!(items[1], Item::ConnectedData(expected));
    let now = b.adapter.io_connection().expect("class 1 still open");
    assert_eq!(
        (now.ot_connection, now.to_connection, now.triad, now.target),
        (io.ot_connection, io.to_connection, io.triad, io.target)
    );
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

    #[test]
    fn arbitrary_bytes_never_disturb_another_session(
        chunks in proptest::collection::vec(proptest::collection::vec(any::<u8>(), 0..80), 0..12),
        register_first in any::<bool>(),
    ) {
        let (mut b, client, c3, io, a) = two_clients();
        if register_first {
            b.send(a, &packet(Command::REGISTER_SESSION, 0, encap::register_session_data()));
        }
        for chunk in &chunks {
            let out = b.send(a, chunk);
            packets(&out.reply);
            if out.close {
                break;
            }
        }
        for chunk in &chunks {
            b.adapter.io_datagram(SocketAddrV4::new(A_IP, 2222), chunk, &mut b.drive, b.now);
            let _ = b.adapter.discovery(chunk, LOCAL, &b.drive);
        }
        b_is_untouched(&mut b, client, &c3, &io);
    }

    #[test]
    fn mutated_packets_never_disturb_another_session(
        picks in proptest::collection::vec(0usize..15, 1..8),
        mutations in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 0..6),
        cut in any::<prop::sample::Index>(),
        truncate in any::<bool>(),
        chunk in 1usize..64,
    ) {
        let (mut b, client, c3, io, a) = two_clients();
        let out = b.send(a, &packet(Command::REGISTER_SESSION, 0, encap::register_session_data()));
        let session = packets(&out.reply)[0].session;
        let all = a_packets(session);
        let mut stream: Vec<u8> = picks.iter().flat_map(|i| all[*i].clone()).collect();
        for (at, byte) in &mutations {
            let at = at.index(stream.len());
            stream[at] = *byte;
        }
        if truncate {
            stream.truncate(cut.index(stream.len() + 1));
        }
        for piece in stream.chunks(chunk) {
            let out = b.send(a, piece);
            packets(&out.reply);
            if out.close {
                break;
            }
        }
        b_is_untouched(&mut b, client, &c3, &io);
    }
}

#[test]
fn the_mutation_base_is_valid() {
    // Every packet of `a_packets` gets its answer (the proptest mutates real requests).
    let (mut b, client, c3, io, a) = two_clients();
    let out = b.send(
        a,
        &packet(Command::REGISTER_SESSION, 0, encap::register_session_data()),
    );
    let session = packets(&out.reply)[0].session;
    let all = a_packets(session);
    let replies: Vec<Packet> = all[1..all.len() - 1]
        .iter()
        .flat_map(|p| packets(&b.send(a, p).reply))
        .collect();
    // NOP has no reply; everything else succeeds at the encapsulation level, except the
    // SendUnitData to a connection A does not have.
    assert_eq!(replies.len(), all.len() - 3);
    let statuses: Vec<u32> = replies.iter().map(|p| p.status.0).collect();
    assert_eq!(statuses, [0, 0, 0, 0, 0, 0, 0, 0, 0, 3, 0, 0]);
    let (conflict, _) = mr_reply(&replies[6].encode());
    assert_eq!(conflict.additional, [extended::OWNERSHIP_CONFLICT]);
    let (closed, _) = mr_reply(&replies[7].encode());
    assert!(
        closed.status.is_success(),
        "A closes its own class 3 connection"
    );
    let out = b.send(a, &all[all.len() - 1]);
    assert!(out.close && out.reply.is_empty(), "UnRegisterSession");
    b_is_untouched(&mut b, client, &c3, &io);
}
