//! Property tests of every EtherNet/IP decoder that reads bytes from the network: none
//! panics on any input, and what the encoders write decodes back to itself.

use proptest::prelude::*;

use super::assembly::{self, CmdOffset, CommonIn, CommonOut};
use super::cip::{Path, Reply, Request, Segment, UnconnectedSend};
use super::connection::{ForwardClose, ForwardOpen, ForwardOpenReply, NetworkParams, Triad};
use super::cpf::{self, Item, SockAddr};
use super::encap::{self, Command, Framed, Packet};
use super::identity::Identity;
use super::io::IoPacket;
use super::nanotec::Typed;

fn bytes(max: usize) -> impl Strategy<Value = Vec<u8>> {
    proptest::collection::vec(any::<u8>(), 0..max)
}

fn sockaddr() -> impl Strategy<Value = SockAddr> {
    (any::<u16>(), any::<u32>()).prop_map(|(port, ip)| SockAddr {
        family: 2,
        port,
        ip: ip.into(),
    })
}

fn item() -> impl Strategy<Value = Item> {
    prop_oneof![
        Just(Item::Null),
        any::<u32>().prop_map(Item::ConnectedAddress),
        (any::<u32>(), any::<u32>()).prop_map(|(connection, sequence)| Item::SequencedAddress {
            connection,
            sequence
        }),
        bytes(64).prop_map(Item::UnconnectedData),
        bytes(64).prop_map(Item::ConnectedData),
        sockaddr().prop_map(Item::SockaddrOt),
        sockaddr().prop_map(Item::SockaddrTo),
    ]
}

fn segment() -> impl Strategy<Value = Segment> {
    prop_oneof![
        any::<u16>().prop_map(Segment::Class),
        any::<u16>().prop_map(Segment::Instance),
        any::<u16>().prop_map(Segment::Attribute),
        any::<u16>().prop_map(Segment::ConnectionPoint),
        any::<u16>().prop_map(Segment::Member),
        any::<[u8; 8]>().prop_map(Segment::ElectronicKey),
        (1u16..14, proptest::collection::vec(any::<u8>(), 1..2))
            .prop_map(|(port, link)| Segment::Port { port, link }),
        (2u16..14, proptest::collection::vec(any::<u8>(), 2..16))
            .prop_map(|(port, link)| Segment::Port { port, link }),
        proptest::collection::vec(any::<u8>(), 0..8).prop_map(|mut d| {
            if d.len() % 2 == 1 {
                d.push(0);
            }
            Segment::Data(d)
        }),
    ]
}

fn params() -> impl Strategy<Value = NetworkParams> {
    (any::<u16>()).prop_map(NetworkParams::from_u16)
}

proptest! {
    #[test]
    fn no_decoder_panics_on_any_bytes(data in bytes(300)) {
        let _ = encap::split(&data);
        let _ = Packet::decode(&data);
        let _ = encap::decode_register_session(&data);
        let _ = encap::RrData::decode(&data);
        let _ = cpf::decode(&data);
        let _ = Identity::decode(&data);
        let _ = Path::decode(&data);
        let _ = Request::decode(&data).map(|r| r.path());
        let _ = Reply::decode(&data);
        let _ = UnconnectedSend::decode(&data);
        let _ = ForwardOpen::decode(false, &data);
        let _ = ForwardOpen::decode(true, &data);
        let _ = ForwardOpenReply::decode(&data);
        let _ = ForwardClose::decode(&data);
        let _ = IoPacket::decode(&data, true);
        let _ = IoPacket::decode(&data, false);
        let _ = IoPacket::connection_of(&data);
        let _ = Typed::decode(&data);
        let _ = CommonIn::decode(&data);
        let _ = CommonOut::decode(&data);
        let _ = assembly::decode_pdi_ot(&data, CmdOffset::Seven);
        let _ = assembly::decode_pdi_ot(&data, CmdOffset::Eight);
        let _ = super::nanotec::decode_request_data(&data);
        let _ = super::identity::decode_list_identity_reply(&data);
        if let Ok(packet) = Packet::decode(&data) {
            let _ = super::describe::describe(&packet);
        }
    }

    #[test]
    fn near_valid_messages_do_not_panic_either(
        command in prop_oneof![Just(0x6Fu16), Just(0x70), Just(0x63), Just(0x65)],
        items in proptest::collection::vec(item(), 0..4),
        cut in any::<prop::sample::Index>(),
        flip in any::<prop::sample::Index>(),
        xor in 1u8..=255,
    ) {
        let mut body = vec![0, 0, 0, 0, 10, 0];
        cpf::encode(&items, &mut body);
        let mut packet = Packet::new(Command(command), 1, [0; 8], body).encode();
        let at = flip.index(packet.len());
        packet[at] ^= xor;
        let cut = cut.index(packet.len() + 1);
        let packet = &packet[..cut];
        let _ = encap::split(packet);
        if let Ok(p) = Packet::decode(packet) {
            let _ = super::describe::describe(&p);
            if let Ok(rr) = encap::RrData::decode(&p.data)
                && let Some(router) = rr.unconnected()
            {
                let _ = Request::decode(router);
                let _ = Reply::decode(router);
            }
        }
    }

    #[test]
    fn packets_round_trip_and_the_stream_splits_anywhere(
        a in bytes(100),
        b in bytes(100),
        session in any::<u32>(),
        context in any::<[u8; 8]>(),
        cut in any::<prop::sample::Index>(),
    ) {
        let first = Packet::new(Command::SEND_RR_DATA, session, context, a);
        let second = Packet::new(Command::SEND_UNIT_DATA, session, context, b);
        let mut stream = first.encode();
        stream.extend(second.encode());
        let cut = cut.index(stream.len() + 1);
        // Whatever arrived so far: whole messages come out whole, the rest waits.
        let mut buffer = stream[..cut].to_vec();
        let mut out = vec![];
        while let Framed::Packet(p, used) = encap::split(&buffer) {
            out.push(p);
            buffer.drain(..used);
        }
        buffer.extend_from_slice(&stream[cut..]);
        while let Framed::Packet(p, used) = encap::split(&buffer) {
            out.push(p);
            buffer.drain(..used);
        }
        prop_assert!(buffer.is_empty());
        prop_assert_eq!(out, vec![first, second]);
    }

    #[test]
    fn cpf_items_round_trip(items in proptest::collection::vec(item(), 0..6)) {
        let mut out = vec![];
        cpf::encode(&items, &mut out);
        prop_assert_eq!(cpf::decode(&out), Ok(items));
    }

    #[test]
    fn paths_round_trip(segments in proptest::collection::vec(segment(), 0..6)) {
        let path = Path(segments);
        let bytes = path.encode();
        prop_assert_eq!(bytes.len() % 2, 0, "padded to words");
        prop_assert_eq!(Path::decode(&bytes), Ok(path));
    }

    #[test]
    fn requests_and_replies_round_trip(
        service in 0u8..0x80,
        segments in proptest::collection::vec(segment(), 0..4),
        data in bytes(40),
        status in any::<u8>(),
        additional in proptest::collection::vec(any::<u16>(), 0..3),
    ) {
        let request = Request::new(service, &Path(segments), data.clone());
        prop_assert_eq!(Request::decode(&request.encode()), Ok(request));
        let reply = Reply {
            service: service | 0x80,
            status: super::cip::GeneralStatus(status),
            additional,
            data,
        };
        prop_assert_eq!(Reply::decode(&reply.encode()), Ok(reply));
    }

    #[test]
    fn connection_services_round_trip(
        large in any::<bool>(),
        ids in any::<(u32, u32, u16, u16, u32)>(),
        rpis in any::<(u32, u32)>(),
        ot in params(),
        to in params(),
        transport in any::<u8>(),
        multiplier in 0u8..8,
        path in proptest::collection::vec(any::<u16>(), 0..6),
        application in bytes(8),
    ) {
        let path: Vec<u8> = path.iter().flat_map(|w| w.to_le_bytes()).collect();
        let open = ForwardOpen {
            large,
            tick: 0x0A,
            timeout_ticks: 0x0E,
            ot_connection: ids.0,
            to_connection: ids.1,
            serial: ids.2,
            vendor: ids.3,
            originator_serial: ids.4,
            timeout_multiplier: multiplier,
            ot_rpi_us: rpis.0,
            ot_params: ot,
            to_rpi_us: rpis.1,
            to_params: to,
            transport,
            path: path.clone(),
        };
        prop_assert_eq!(ForwardOpen::decode(large, &open.encode()), Ok(open));
        let mut application = application;
        if application.len() % 2 == 1 {
            application.pop();
        }
        let triad = Triad { serial: ids.2, vendor: ids.3, originator_serial: ids.4 };
        let reply = ForwardOpenReply {
            ot_connection: ids.0,
            to_connection: ids.1,
            triad,
            ot_api_us: rpis.0,
            to_api_us: rpis.1,
            application,
        };
        prop_assert_eq!(ForwardOpenReply::decode(&reply.encode()), Ok(reply));
        let close = ForwardClose { tick: 3, timeout_ticks: 9, triad, path };
        prop_assert_eq!(ForwardClose::decode(&close.encode()), Ok(close));
    }

    #[test]
    fn io_packets_round_trip(
        connection in any::<u32>(),
        sequence in any::<u32>(),
        count in any::<u16>(),
        run in proptest::option::of(any::<bool>()),
        data in bytes(140),
    ) {
        let packet = IoPacket { connection, sequence, count, run, data };
        prop_assert_eq!(IoPacket::decode(&packet.encode(), run.is_some()), Ok(packet));
    }

    #[test]
    fn assemblies_round_trip(raw in proptest::collection::vec(any::<u8>(), 128..=128)) {
        // Any 128 bytes are a Common assembly; the reserved tail is written as zeros.
        let input = CommonIn::decode(&raw).expect("128 bytes");
        prop_assert_eq!(CommonIn::decode(&input.encode()), Ok(input));
        let output = CommonOut::decode(&raw).expect("128 bytes");
        prop_assert_eq!(CommonOut::decode(&output.encode()), Ok(output));
        let rx = assembly::decode_pdi_ot(&raw[..8], CmdOffset::Seven).expect("8 bytes");
        for cmd in [CmdOffset::Seven, CmdOffset::Eight] {
            prop_assert_eq!(assembly::decode_pdi_ot(&assembly::encode_pdi_ot(&rx, cmd), cmd), Ok(rx));
        }
    }

    #[test]
    fn typed_values_round_trip(code in any::<u16>(), data in bytes(64)) {
        let typed = Typed { dtype_code: code, data };
        prop_assert_eq!(Typed::decode(&typed.encode()), Ok(typed));
    }
}
