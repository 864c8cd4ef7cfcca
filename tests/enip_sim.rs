//! The simulated EtherNet/IP adapter on real loopback sockets, spoken to byte by byte with
//! the codecs and plain std sockets (no client link): encapsulation, the Nanotec object
//! services and their refusals, Identity and Assembly objects, Unconnected_Send, class 3,
//! class 1 I/O of both assembly sets, and what a misbehaving client may and may not do to
//! the others.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::io::{ErrorKind, Read, Write};
use std::net::{Ipv4Addr, SocketAddr, SocketAddrV4, TcpStream, UdpSocket};
use std::time::{Duration, Instant};

use drivedeck::od::{Access, Address, Entry, Group, Value};
use drivedeck::pdi::{Command as PdiCommand, Opcode, RxImage, SetValues, TxImage};
use drivedeck::proto::enip::assembly::{self, CmdOffset, CommonIn, CommonOut};
use drivedeck::proto::enip::cip::{
    GeneralStatus, Path, Reply, Request, Segment, UnconnectedSend, class, service,
};
use drivedeck::proto::enip::connection::{
    ForwardClose, ForwardOpen, ForwardOpenReply, NetworkParams, TRANSPORT_CLASS1_CYCLIC,
    encode_forward_close_reply, extended,
};
use drivedeck::proto::enip::cpf::{self, Item, SockAddr};
use drivedeck::proto::enip::encap::{self, Command, HEADER_LEN, Header, Packet, RrData, Status};
use drivedeck::proto::enip::identity::Identity;
use drivedeck::proto::enip::io::IoPacket;
use drivedeck::proto::enip::nanotec::{self, Typed};
use drivedeck::sim::server::enip::AdapterOptions;
use drivedeck::sim::server::{ServerThread, SharedDrive};
use drivedeck::sim::{Drive, World};

/// How long anything may take on a loaded machine before the test gives up.
const WAIT: Duration = Duration::from_secs(10);

fn local() -> SocketAddr {
    "127.0.0.1:0".parse().expect("address")
}

fn options() -> AdapterOptions {
    AdapterOptions {
        io_port: 0,
        ..AdapterOptions::default()
    }
}

fn server() -> ServerThread {
    ServerThread::enip(local(), options()).expect("server")
}

fn connect(addr: SocketAddr) -> TcpStream {
    let tcp = TcpStream::connect(addr).expect("connect");
    tcp.set_read_timeout(Some(WAIT)).expect("timeout");
    tcp.set_nodelay(true).expect("nodelay");
    tcp
}

fn packet(command: Command, session: u32, data: Vec<u8>) -> Vec<u8> {
    Packet::new(command, session, *b"enipsim\0", data).encode()
}

fn recv(tcp: &mut TcpStream) -> Packet {
    let mut header = [0u8; HEADER_LEN];
    tcp.read_exact(&mut header).expect("a reply header");
    let length = usize::from(Header::decode(&header).expect("header").length);
    let mut bytes = header.to_vec();
    bytes.resize(HEADER_LEN + length, 0);
    tcp.read_exact(&mut bytes[HEADER_LEN..])
        .expect("a reply body");
    Packet::decode(&bytes).expect("a reply")
}

/// The adapter closed the connection (EOF, or a reset after it).
fn closed(tcp: &mut TcpStream) -> bool {
    let mut byte = [0u8; 1];
    match tcp.read(&mut byte) {
        Ok(0) => true,
        Ok(_) => false,
        Err(e) => matches!(
            e.kind(),
            ErrorKind::ConnectionReset | ErrorKind::ConnectionAborted
        ),
    }
}

fn exchange(tcp: &mut TcpStream, bytes: &[u8]) -> Packet {
    tcp.write_all(bytes).expect("send");
    recv(tcp)
}

fn cpf_items(packet: &Packet) -> Vec<Item> {
    cpf::decode(&packet.data).expect("CPF items")
}

/// A registered session.
struct Client {
    tcp: TcpStream,
    session: u32,
}

impl Client {
    fn register(addr: SocketAddr) -> Client {
        let mut tcp = connect(addr);
        let reply = exchange(
            &mut tcp,
            &packet(Command::REGISTER_SESSION, 0, encap::register_session_data()),
        );
        assert_eq!(reply.status, Status::SUCCESS);
        assert_ne!(reply.session, 0);
        assert_eq!(reply.data, [1, 0, 0, 0]);
        Client {
            tcp,
            session: reply.session,
        }
    }

    fn raw(&mut self, command: Command, data: Vec<u8>) -> Packet {
        exchange(&mut self.tcp, &packet(command, self.session, data))
    }

    /// SendRRData with a raw Message Router request and extra CPF items.
    fn send_rr(&mut self, request: Vec<u8>, extra: Vec<Item>) -> (Reply, Vec<Item>) {
        let mut items = vec![Item::Null, Item::UnconnectedData(request)];
        items.extend(extra);
        let reply = self.raw(Command::SEND_RR_DATA, RrData::new(5, items).encode());
        assert_eq!(reply.status, Status::SUCCESS, "{}", reply.status);
        let rr = RrData::decode(&reply.data).expect("SendRRData reply");
        assert_eq!(rr.items.first(), Some(&Item::Null));
        let mr = Reply::decode(rr.unconnected().expect("unconnected data")).expect("MR reply");
        (mr, rr.items)
    }

    fn call(&mut self, request: &Request) -> Reply {
        let reply = self.send_rr(request.encode(), vec![]).0;
        assert_eq!(reply.service, request.service | 0x80);
        reply
    }

    fn get_od(&mut self, index: u16, sub: u8) -> Reply {
        self.call(&nanotec::get_od(Address::new(index, sub)))
    }

    fn set_od(&mut self, index: u16, sub: u8, value: &[u8]) -> Reply {
        let mut data = index.to_le_bytes().to_vec();
        data.push(sub);
        data.extend_from_slice(value);
        self.call(&Request::new(service::SET_OD, &nanotec::od_path(), data))
    }

    /// The vendor id, the question every check below asks to see a session still works.
    fn works(&mut self) {
        let reply = self.get_od(0x1018, 1);
        assert_eq!(
            (reply.status, reply.data),
            (GeneralStatus::SUCCESS, vec![0x6C, 0x02, 0, 0])
        );
    }

    fn open(&mut self, open: &ForwardOpen, extra: Vec<Item>) -> (Reply, Vec<Item>) {
        let request = Request::new(
            open.service(),
            &Path::object(class::CONNECTION_MANAGER, 1),
            open.encode(),
        );
        self.send_rr(request.encode(), extra)
    }

    fn close(&mut self, open: &ForwardOpen) -> Reply {
        let close = ForwardClose {
            tick: 0x0A,
            timeout_ticks: 0x0E,
            triad: open.triad(),
            path: open.path.clone(),
        };
        self.call(&Request::new(
            service::FORWARD_CLOSE,
            &Path::object(class::CONNECTION_MANAGER, 1),
            close.encode(),
        ))
    }

    fn identity_status(&mut self) -> u16 {
        let reply = self.call(&Request::new(
            service::GET_ATTRIBUTE_SINGLE,
            &Path::attribute(class::IDENTITY, 1, 5),
            vec![],
        ));
        u16::from_le_bytes(reply.data.try_into().expect("2 bytes"))
    }
}

fn status(reply: &Reply) -> (u8, Vec<u16>) {
    (reply.status.0, reply.additional.clone())
}

/// Forward_Open of class 1 with `points` and connection sizes; RPI 10 ms and a timeout
/// multiplier of 7 (5 s), so a loaded machine never times out by accident.
fn class1(serial: u16, points: (u16, u16), ot_size: u16, to_size: u16) -> ForwardOpen {
    ForwardOpen {
        large: false,
        tick: 0x0A,
        timeout_ticks: 0x0E,
        ot_connection: 0,
        to_connection: 0x2000_0000 | u32::from(serial),
        serial,
        vendor: 0x1234,
        originator_serial: 0x0DD0_0000 | u32::from(serial),
        timeout_multiplier: 7,
        ot_rpi_us: 10_000,
        ot_params: NetworkParams::point_to_point(ot_size),
        to_rpi_us: 10_000,
        to_params: NetworkParams::point_to_point(to_size),
        transport: TRANSPORT_CLASS1_CYCLIC,
        path: Path(vec![
            Segment::Class(class::ASSEMBLY),
            Segment::Instance(assembly::DEFAULT_CONFIG_INSTANCE),
            Segment::ConnectionPoint(points.0),
            Segment::ConnectionPoint(points.1),
        ])
        .encode(),
    }
}

fn pdi(serial: u16) -> ForwardOpen {
    class1(serial, (105, 104), 14, 10)
}

fn common(serial: u16) -> ForwardOpen {
    class1(serial, (101, 100), 134, 130)
}

fn class3(serial: u16) -> ForwardOpen {
    ForwardOpen {
        transport: 0xA3,
        ot_params: NetworkParams::from_u16(0x4200 | 504),
        to_params: NetworkParams::from_u16(0x4200 | 504),
        ot_rpi_us: 2_000_000,
        to_rpi_us: 2_000_000,
        path: Path::object(class::MESSAGE_ROUTER, 1).encode(),
        ..class1(serial, (0, 0), 0, 0)
    }
}

fn move_to(target: i32, toggle: bool) -> RxImage {
    let mut command = PdiCommand::new(Opcode::MoveAbsolute);
    command.toggle = toggle;
    RxImage::new(
        SetValues {
            value1: target,
            value2: 200,
            value3: 0,
        },
        command,
    )
}

/// The originator's side of a class 1 connection.
struct Io {
    udp: UdpSocket,
    accepted: ForwardOpenReply,
    target: SocketAddr,
    sequence: u32,
    to_header: bool,
}

impl Io {
    /// Forward_Open, announcing a UDP socket of our own in a sockaddr T→O item.
    fn open(client: &mut Client, server: &ServerThread, open: &ForwardOpen) -> Io {
        let udp = UdpSocket::bind("127.0.0.1:0").expect("UDP");
        udp.set_read_timeout(Some(WAIT)).expect("timeout");
        let port = udp.local_addr().expect("local").port();
        let announce = Item::SockaddrTo(SockAddr::new(SocketAddrV4::new(
            Ipv4Addr::UNSPECIFIED,
            port,
        )));
        let (reply, items) = client.open(open, vec![announce]);
        assert_eq!(status(&reply), (0, vec![]), "{}", reply.status_text());
        let accepted = ForwardOpenReply::decode(&reply.data).expect("Forward_Open reply");
        assert_ne!(accepted.ot_connection, 0);
        assert_eq!(accepted.to_connection, open.to_connection);
        assert_eq!(accepted.triad, open.triad());
        assert_eq!((accepted.ot_api_us, accepted.to_api_us), (10_000, 10_000));
        let sockaddr = items
            .iter()
            .find_map(|i| match i {
                Item::SockaddrOt(s) => Some(SocketAddr::V4(s.socket())),
                _ => None,
            })
            .expect("a sockaddr O→T item");
        assert_eq!(Some(sockaddr), server.io, "the adapter's real I/O address");
        Io {
            udp,
            accepted,
            target: sockaddr,
            sequence: 0,
            to_header: open.to_params.size == 14 || open.to_params.size == 134,
        }
    }

    fn send(&mut self, run: bool, data: Vec<u8>) {
        self.sequence += 1;
        let packet = IoPacket {
            connection: self.accepted.ot_connection,
            sequence: self.sequence,
            count: self.sequence as u16,
            run: Some(run),
            data,
        };
        self.udp
            .send_to(&packet.encode(), self.target)
            .expect("send O→T");
    }

    fn recv(&self) -> IoPacket {
        let mut buffer = [0u8; 1024];
        let (n, _) = self.udp.recv_from(&mut buffer).expect("a T→O packet");
        let packet = IoPacket::decode(&buffer[..n], self.to_header).expect("T→O packet");
        assert_eq!(packet.connection, self.accepted.to_connection);
        packet
    }

    /// Send `data` at about the RPI until a T→O packet satisfies `done`.
    fn until(&mut self, data: &[u8], what: &str, done: impl Fn(&IoPacket) -> bool) -> IoPacket {
        let deadline = Instant::now() + WAIT;
        loop {
            self.send(true, data.to_vec());
            let packet = self.recv();
            if done(&packet) {
                return packet;
            }
            assert!(Instant::now() < deadline, "waiting for {what}");
        }
    }
}

fn wait_for(what: &str, mut done: impl FnMut() -> bool) {
    let deadline = Instant::now() + WAIT;
    while !done() {
        assert!(Instant::now() < deadline, "waiting for {what}");
        std::thread::sleep(Duration::from_millis(10));
    }
}

// ------------------------------------------------------------------------ encapsulation

#[test]
fn sessions_identity_services_and_interfaces() {
    let server = server();
    let a = Client::register(server.addr);
    let mut b = Client::register(server.addr);
    assert_ne!(a.session, b.session, "one handle per connection");

    // ListIdentity over TCP: the identity with the address the connection reached.
    let reply = b.raw(Command::LIST_IDENTITY, vec![]);
    assert_eq!((reply.status, reply.session), (Status::SUCCESS, b.session));
    let items = cpf_items(&reply);
    let [Item::Identity(identity)] = items.as_slice() else {
        panic!("{items:?}")
    };
    assert_eq!(SocketAddr::V4(identity.socket.socket()), server.addr);
    assert_eq!(
        (identity.vendor, identity.device_type, identity.product_code),
        (0x0558, 0x2B, 0x42)
    );
    assert_eq!((identity.revision, identity.serial), ((3, 0), 0x1234));
    assert_eq!(identity.product_name, "drivedeck simulated drive");
    assert_eq!((identity.status, identity.state), (0, 3));

    // ListServices: one "Communications" item, CIP over TCP and class 0/1 over UDP.
    let reply = b.raw(Command::LIST_SERVICES, vec![]);
    let items = cpf_items(&reply);
    let [Item::Other { kind: 0x0100, data }] = items.as_slice() else {
        panic!("{items:?}")
    };
    assert_eq!(&data[..4], &[1, 0, 0x20, 0x01]);
    assert_eq!(&data[4..], b"Communications\0\0");

    // ListInterfaces: none.
    let reply = b.raw(Command::LIST_INTERFACES, vec![]);
    assert_eq!(reply.data, [0, 0]);

    // NOP has no reply: the next reply is the ListIdentity's.
    b.tcp
        .write_all(&packet(Command::NOP, b.session, vec![1, 2, 3]))
        .expect("NOP");
    let reply = b.raw(Command::LIST_IDENTITY, vec![]);
    assert_eq!(reply.command, Command::LIST_IDENTITY);

    // A second RegisterSession on the same connection keeps the first handle.
    let reply = b.raw(Command::REGISTER_SESSION, encap::register_session_data());
    assert_eq!((reply.status, reply.session), (Status(0x0001), b.session));

    // RegisterSession with a wrong length or protocol version.
    let mut tcp = connect(server.addr);
    let reply = exchange(
        &mut tcp,
        &packet(Command::REGISTER_SESSION, 0, vec![1, 0, 0, 0, 0, 0]),
    );
    assert_eq!((reply.status, reply.session), (Status(0x65), 0));
    let reply = exchange(
        &mut tcp,
        &packet(Command::REGISTER_SESSION, 0, vec![2, 0, 0, 0]),
    );
    assert_eq!(reply.status, Status(0x69));
    assert_eq!(reply.data, [1, 0, 0, 0], "the supported version");
    // The connection is still good for a proper one.
    let reply = exchange(
        &mut tcp,
        &packet(Command::REGISTER_SESSION, 0, encap::register_session_data()),
    );
    assert_eq!(reply.status, Status::SUCCESS);

    // UnRegisterSession: no reply, the connection closes; the others carry on.
    b.tcp
        .write_all(&packet(Command::UNREGISTER_SESSION, b.session, vec![]))
        .expect("UnRegisterSession");
    assert!(closed(&mut b.tcp));
    let mut a = a;
    a.works();
}

#[test]
fn list_identity_over_udp_on_the_tcp_port() {
    let server = server();
    let udp = UdpSocket::bind("127.0.0.1:0").expect("UDP");
    udp.set_read_timeout(Some(WAIT)).expect("timeout");
    udp.send_to(&packet(Command::LIST_IDENTITY, 0, vec![]), server.addr)
        .expect("send");
    let mut buffer = [0u8; 600];
    let (n, from) = udp.recv_from(&mut buffer).expect("a reply");
    assert_eq!(from, server.addr);
    let reply = Packet::decode(&buffer[..n]).expect("reply");
    assert_eq!(reply.context, *b"enipsim\0");
    let items = cpf_items(&reply);
    let [Item::Identity(identity)] = items.as_slice() else {
        panic!("{items:?}")
    };
    let identity: &Identity = identity;
    assert_eq!(SocketAddr::V4(identity.socket.socket()), server.addr);
    assert_eq!(identity.vendor, 0x0558);
    // Anything else on that port is ignored; ListIdentity still answers after it.
    udp.send_to(b"garbage", server.addr).expect("send");
    udp.send_to(&packet(Command::LIST_IDENTITY, 0, vec![]), server.addr)
        .expect("send");
    let (n, _) = udp.recv_from(&mut buffer).expect("a reply");
    assert_eq!(
        Packet::decode(&buffer[..n]).map(|p| p.command),
        Ok(Command::LIST_IDENTITY)
    );
}

#[test]
fn bound_to_every_interface_the_identity_says_0_0_0_0() {
    let server =
        ServerThread::enip("0.0.0.0:0".parse().expect("address"), options()).expect("server");
    let port = server.addr.port();
    let at = SocketAddr::from((Ipv4Addr::LOCALHOST, port));
    let udp = UdpSocket::bind("127.0.0.1:0").expect("UDP");
    udp.set_read_timeout(Some(WAIT)).expect("timeout");
    udp.send_to(&packet(Command::LIST_IDENTITY, 0, vec![]), at)
        .expect("send");
    let mut buffer = [0u8; 600];
    let (n, _) = udp.recv_from(&mut buffer).expect("a reply");
    let items = cpf_items(&Packet::decode(&buffer[..n]).expect("reply"));
    let [Item::Identity(identity)] = items.as_slice() else {
        panic!("{items:?}")
    };
    assert_eq!(
        identity.socket.socket(),
        SocketAddrV4::new(Ipv4Addr::UNSPECIFIED, port)
    );
    // Over TCP it names the address the connection reached.
    let mut c = Client::register(at);
    let items = cpf_items(&c.raw(Command::LIST_IDENTITY, vec![]));
    let [Item::Identity(identity)] = items.as_slice() else {
        panic!("{items:?}")
    };
    assert_eq!(SocketAddr::V4(identity.socket.socket()), at);
}

#[test]
fn sessions_beyond_the_maximum_are_refused() {
    let server = ServerThread::enip(
        local(),
        AdapterOptions {
            max_sessions: 2,
            io_port: 0,
        },
    )
    .expect("server");
    let mut a = Client::register(server.addr);
    let b = Client::register(server.addr);
    let mut tcp = connect(server.addr);
    let reply = exchange(
        &mut tcp,
        &packet(Command::REGISTER_SESSION, 0, encap::register_session_data()),
    );
    assert_eq!((reply.status, reply.session), (Status(0x0002), 0));
    // A session ending frees its place.
    drop(b);
    wait_for("the third session", || {
        exchange(
            &mut tcp,
            &packet(Command::REGISTER_SESSION, 0, encap::register_session_data()),
        )
        .status
            == Status::SUCCESS
    });
    a.works();
}

// ------------------------------------------------------------------------ the OD services

#[test]
fn objects_by_get_od_set_od_and_rockwell() {
    let server = server();
    let mut c = Client::register(server.addr);
    // The vendor's own example bytes for the request, and 1018h:01 = 26Ch.
    let (reply, _) = c.send_rr(
        vec![0x32, 0x02, 0x20, 0x64, 0x24, 0x01, 0x18, 0x10, 0x01],
        vec![],
    );
    assert_eq!(reply.encode(), [0xB2, 0, 0, 0, 0x6C, 0x02, 0, 0]);
    // Native sizes: u8, i8, u16, i32.
    assert_eq!(c.get_od(0x1018, 0).data, [4]);
    assert_eq!(c.get_od(0x6060, 0).data, [0]);
    assert_eq!(c.get_od(0x6041, 0).data.len(), 2);
    assert_eq!(c.get_od(0x6064, 0).data.len(), 4);
    // 2014h (the IPv4 address) as GetOD Rockwell: UNSIGNED32, 4 bytes.
    let reply = c.call(&nanotec::get_od_rockwell(Address::new(0x2014, 0)));
    let typed = Typed::decode(&reply.data).expect("typed");
    assert_eq!((typed.dtype_code, typed.data.len()), (0x0007, 4));
    let reply = c.call(&nanotec::get_od_rockwell(Address::new(0x6060, 0)));
    assert_eq!(
        reply.data,
        [0x02, 0x00, 0x01, 0x00, 0x00],
        "INTEGER8, 1 byte"
    );
    // SetOD of 2031h = 304h, the vendor's example, and read back.
    let (reply, _) = c.send_rr(
        vec![
            0x33, 0x02, 0x20, 0x64, 0x24, 0x01, 0x31, 0x20, 0x00, 0x04, 0x03, 0x00, 0x00,
        ],
        vec![],
    );
    assert_eq!(reply.encode(), [0xB3, 0, 0, 0]);
    assert_eq!(c.get_od(0x2031, 0).data, [0x04, 0x03, 0, 0]);
    assert_eq!(
        server.drive().lock().read(Address::new(0x2031, 0)),
        Ok(Value::Uint(0x304))
    );
    // 1 and 2 byte objects.
    assert!(c.set_od(0x6060, 0, &[1]).status.is_success());
    assert_eq!(c.get_od(0x6060, 0).data, [1]);
    assert!(
        c.set_od(0x6099, 1, &150u32.to_le_bytes())
            .status
            .is_success()
    );
    assert!(
        c.set_od(0x1017, 0, &500u16.to_le_bytes())
            .status
            .is_success()
    );
    assert_eq!(c.get_od(0x1017, 0).data, [0xF4, 0x01]);
    // Strings come whole, in their own length.
    assert_eq!(c.get_od(0x1008, 0).data, b"drivedeck simulated drive");
    let reply = c.call(&nanotec::get_od_rockwell(Address::new(0x1009, 0)));
    assert_eq!(
        Typed::decode(&reply.data),
        Ok(Typed {
            dtype_code: 0x0009,
            data: b"SIM-1".to_vec()
        })
    );
    assert_eq!(c.get_od(0x4041, 0).data, [0x53, 0x49, 0x4D, 0x01]);
}

#[test]
fn drive_refusals_map_to_cip_statuses() {
    // The built-in dictionary has no write-only object: add one.
    let mut catalog = drivedeck::od::builtin().clone();
    catalog.insert(Entry {
        address: Address::new(0x2FF0, 0),
        object_name: "Write-only test object".into(),
        name: "Write-only test object".into(),
        dtype: drivedeck::od::DataType::Unsigned32,
        access: Access::Wo,
        unit: None,
        description: String::new(),
        default: None,
        min: None,
        max: None,
        group: Group::Manufacturer,
        role: drivedeck::od::Role::WriteOnly,
        bits: Vec::new(),
    });
    let drive = SharedDrive::new(Drive::with_catalog(&catalog, World::default()));
    let server = ServerThread::enip_with(local(), options(), drive).expect("server");
    let mut c = Client::register(server.addr);
    let get = |c: &mut Client, index, sub| status(&c.get_od(index, sub));
    let set = |c: &mut Client, index, sub, value: &[u8]| status(&c.set_od(index, sub, value));
    // Object missing: path destination unknown; subindex missing: attribute not supported.
    assert_eq!(get(&mut c, 0x2FFF, 0), (0x05, vec![]));
    assert_eq!(get(&mut c, 0x1018, 9), (0x14, vec![]));
    assert_eq!(set(&mut c, 0x2FFF, 0, &[1]), (0x05, vec![]));
    assert_eq!(set(&mut c, 0x1018, 9, &[1]), (0x14, vec![]));
    // Read-only: not settable; write-only: not gettable (and settable).
    assert_eq!(set(&mut c, 0x1018, 1, &[0x6C, 2, 0, 0]), (0x0E, vec![]));
    assert_eq!(get(&mut c, 0x2FF0, 0), (0x2C, vec![]));
    assert_eq!(set(&mut c, 0x2FF0, 0, &[1, 2, 3, 4]), (0, vec![]));
    // A value outside the object's range (2009h: node id 1..127).
    assert_eq!(set(&mut c, 0x2009, 0, &[200]), (0x09, vec![]));
    assert_eq!(set(&mut c, 0x2009, 0, &[0]), (0x09, vec![]));
    // Value sizes: shorter and longer than the object, none at all, more than 4 bytes.
    assert_eq!(set(&mut c, 0x2031, 0, &[1, 2]), (0x13, vec![]));
    assert_eq!(set(&mut c, 0x2009, 0, &[1, 2]), (0x15, vec![]));
    assert_eq!(set(&mut c, 0x2031, 0, &[]), (0x13, vec![]));
    assert_eq!(set(&mut c, 0x2031, 0, &[1, 2, 3, 4, 5]), (0x15, vec![]));
    // GetOD takes exactly index and subindex.
    let short = Request::new(service::GET_OD, &nanotec::od_path(), vec![0x18, 0x10]);
    assert_eq!(status(&c.call(&short)), (0x13, vec![]));
    let long = Request::new(service::GET_OD, &nanotec::od_path(), vec![0x18, 0x10, 1, 0]);
    assert_eq!(status(&c.call(&long)), (0x15, vec![]));
    // Anything else: vendor specific, the abort code low word first (store refused:
    // 1010h:01 takes only the signature "save").
    assert_eq!(
        set(&mut c, 0x1010, 1, &[1, 0, 0, 0]),
        (0x1F, vec![0x0020, 0x0800])
    );
    // Other services on 64h, other instances.
    let other = Request::new(0x0E, &nanotec::od_path(), vec![0x18, 0x10, 1]);
    assert_eq!(status(&c.call(&other)), (0x08, vec![]));
    let instance2 = Request::new(
        service::GET_OD,
        &Path::object(class::NANOTEC_OD, 2),
        vec![0x18, 0x10, 1],
    );
    assert_eq!(status(&c.call(&instance2)), (0x05, vec![]));
    c.works();
}

// --------------------------------------------------------------- misbehaving clients

#[test]
fn bad_requests_get_their_status_and_leave_other_sessions_alone() {
    let server = server();
    let mut b = Client::register(server.addr);
    let mut a = Client::register(server.addr);
    let mr = |a: &mut Client, bytes: Vec<u8>| status(&a.send_rr(bytes, vec![]).0);

    // A session handle that is not this connection's.
    let reply = exchange(
        &mut a.tcp,
        &packet(
            Command::SEND_RR_DATA,
            b.session,
            RrData::new(5, vec![Item::Null, Item::UnconnectedData(vec![])]).encode(),
        ),
    );
    assert_eq!(reply.status, Status(0x64));
    b.works();
    let reply = exchange(
        &mut a.tcp,
        &packet(Command::SEND_UNIT_DATA, a.session + 1000, vec![]),
    );
    assert_eq!(reply.status, Status(0x64));

    // A header in two pieces, the rest after a pause.
    let whole = Packet::new(
        Command::SEND_RR_DATA,
        a.session,
        [7; 8],
        RrData::new(
            5,
            vec![
                Item::Null,
                Item::UnconnectedData(nanotec::get_od(Address::new(0x1018, 1)).encode()),
            ],
        )
        .encode(),
    )
    .encode();
    a.tcp.write_all(&whole[..10]).expect("first piece");
    std::thread::sleep(Duration::from_millis(50));
    b.works();
    a.tcp.write_all(&whole[10..30]).expect("second piece");
    std::thread::sleep(Duration::from_millis(50));
    a.tcp.write_all(&whole[30..]).expect("the rest");
    let reply = recv(&mut a.tcp);
    assert_eq!((reply.status, reply.context), (Status::SUCCESS, [7; 8]));

    // An unknown command: status 0001h, and the connection stays.
    let reply = a.raw(Command(0x00FF), vec![1, 2, 3]);
    assert_eq!(
        (reply.command, reply.status),
        (Command(0x00FF), Status(0x0001))
    );
    a.works();

    // A malformed SendRRData body, CPF, or one without a request.
    assert_eq!(
        a.raw(Command::SEND_RR_DATA, vec![0, 0]).status,
        Status(0x0003)
    );
    assert_eq!(
        a.raw(Command::SEND_RR_DATA, vec![0, 0, 0, 0, 5, 0, 9, 0])
            .status,
        Status(0x0003)
    );
    assert_eq!(
        a.raw(
            Command::SEND_RR_DATA,
            RrData::new(5, vec![Item::Null]).encode()
        )
        .status,
        Status(0x0003)
    );
    // SendUnitData for a connection that does not exist.
    let items = vec![Item::ConnectedAddress(77), Item::ConnectedData(vec![0, 0])];
    assert_eq!(
        a.raw(Command::SEND_UNIT_DATA, RrData::new(0, items).encode())
            .status,
        Status(0x0003)
    );
    b.works();

    // Message Router requests: unknown service, class; malformed and overlong paths.
    assert_eq!(
        mr(&mut a, vec![0x4B, 0x02, 0x20, 0x64, 0x24, 0x01]),
        (0x08, vec![])
    );
    assert_eq!(
        mr(&mut a, vec![0x0E, 0x03, 0x20, 0x77, 0x24, 0x01, 0x30, 0x01]),
        (0x05, vec![])
    );
    assert_eq!(
        mr(&mut a, vec![0x32, 0x01, 0x60, 0x00]),
        (0x04, vec![]),
        "network segment"
    );
    assert_eq!(
        mr(&mut a, vec![0x32, 0x02, 0x34, 0x07, 0, 0]),
        (0x04, vec![]),
        "bad key"
    );
    assert_eq!(
        mr(&mut a, vec![0x32, 0x01, 0x24, 0x01]),
        (0x04, vec![]),
        "no class"
    );
    assert_eq!(
        mr(&mut a, vec![0x32, 0x09, 0x20, 0x64]),
        (0x26, vec![]),
        "path too long"
    );
    assert_eq!(mr(&mut a, vec![0x32]), (0x13, vec![]));
    assert_eq!(
        mr(&mut a, vec![0xB2, 0x00]),
        (0x08, vec![]),
        "a reply as request"
    );
    // A truncated SetOD: index and subindex, no value.
    assert_eq!(
        mr(
            &mut a,
            vec![0x33, 0x02, 0x20, 0x64, 0x24, 0x01, 0x31, 0x20, 0x00]
        ),
        (0x13, vec![])
    );
    assert_eq!(
        mr(&mut a, vec![0x33, 0x02, 0x20, 0x64, 0x24, 0x01, 0x31]),
        (0x13, vec![])
    );
    b.works();
    a.works();

    // A header announcing more than the adapter takes: 0065h, and only that connection
    // closes.
    let mut huge = Packet::new(Command::SEND_RR_DATA, a.session, [9; 8], vec![]).encode();
    huge[2..4].copy_from_slice(&0xFFFFu16.to_le_bytes());
    a.tcp.write_all(&huge).expect("overlong header");
    a.tcp.write_all(&[0xAA; 100]).expect("some of its body");
    let reply = recv(&mut a.tcp);
    assert_eq!((reply.status, reply.context), (Status(0x65), [9; 8]));
    assert!(closed(&mut a.tcp));
    b.works();

    // Garbage as the first bytes of a connection: an unknown command of no length.
    let mut c = connect(server.addr);
    let mut garbage = vec![0xEE, 0xEE, 0x00, 0x00];
    garbage.extend_from_slice(&[0xEE; 20]);
    c.write_all(&garbage).expect("garbage");
    let reply = recv(&mut c);
    assert_eq!(
        (reply.command, reply.status),
        (Command(0xEEEE), Status(0x0001))
    );
    let reply = exchange(&mut c, &packet(Command::LIST_IDENTITY, 0, vec![]));
    assert_eq!(reply.status, Status::SUCCESS);
    b.works();
}

// ------------------------------------------------------- Identity, Assembly, routing

#[test]
fn identity_and_assembly_objects() {
    let server = server();
    let mut c = Client::register(server.addr);
    let all = c.call(&Request::new(
        service::GET_ATTRIBUTES_ALL,
        &Path::object(class::IDENTITY, 1),
        vec![],
    ));
    assert!(all.status.is_success());
    assert_eq!(&all.data[..6], &[0x58, 0x05, 0x2B, 0x00, 0x42, 0x00]);
    assert_eq!(&all.data[6..8], &[3, 0], "revision");
    assert_eq!(&all.data[10..14], &0x1234u32.to_le_bytes());
    assert_eq!(all.data[14], 25);
    assert_eq!(&all.data[15..], b"drivedeck simulated drive");
    let attribute = |c: &mut Client, n: u16| {
        c.call(&Request::new(
            service::GET_ATTRIBUTE_SINGLE,
            &Path::attribute(class::IDENTITY, 1, n),
            vec![],
        ))
    };
    let expected: [&[u8]; 7] = [
        &[0x58, 0x05],
        &[0x2B, 0x00],
        &[0x42, 0x00],
        &[3, 0],
        &[0, 0],
        &[0x34, 0x12, 0, 0],
        &all.data[14..],
    ];
    for (n, bytes) in (1..=7).zip(expected) {
        assert_eq!(attribute(&mut c, n).data, bytes, "attribute {n}");
    }
    assert_eq!(status(&attribute(&mut c, 8)), (0x14, vec![]));
    let instance2 = c.call(&Request::new(
        service::GET_ATTRIBUTES_ALL,
        &Path::object(class::IDENTITY, 2),
        vec![],
    ));
    assert_eq!(status(&instance2), (0x05, vec![]));

    // Assemblies: the current data of every instance.
    let data = |c: &mut Client, instance: u16| {
        c.call(&Request::new(
            service::GET_ATTRIBUTE_SINGLE,
            &Path::attribute(class::ASSEMBLY, instance, 3),
            vec![],
        ))
    };
    let tx = TxImage::from_bytes(&data(&mut c, 104).data).expect("8 bytes");
    assert_eq!(tx.error_code, 0);
    assert_eq!(data(&mut c, 105).data.len(), 8);
    let common_in = CommonIn::decode(&data(&mut c, 100).data).expect("128 bytes");
    assert_eq!(common_in.tx.error_code, 0);
    assert_eq!(
        CommonOut::decode(&data(&mut c, 101).data).map(|o| o.rx),
        Ok(RxImage::default())
    );
    assert_eq!(status(&data(&mut c, 102)), (0x05, vec![]));
    let size = c.call(&Request::new(
        service::GET_ATTRIBUTE_SINGLE,
        &Path::attribute(class::ASSEMBLY, 100, 4),
        vec![],
    ));
    assert_eq!(size.data, [128, 0]);
}

#[test]
fn unconnected_send_wraps_any_request() {
    let server = server();
    let mut c = Client::register(server.addr);
    let wrap = |request: &Request| {
        Request::new(
            service::UNCONNECTED_SEND,
            &Path::object(class::CONNECTION_MANAGER, 1),
            UnconnectedSend {
                tick: 0x0A,
                timeout_ticks: 0x0E,
                request: request.encode(),
                // Backplane, slot 0, as pycomm3 and rseip route.
                route: vec![0x01, 0x00],
            }
            .encode(),
        )
    };
    // The reply is the embedded request's.
    let (reply, _) = c.send_rr(
        wrap(&nanotec::get_od(Address::new(0x1018, 1))).encode(),
        vec![],
    );
    assert_eq!(reply.encode(), [0xB2, 0, 0, 0, 0x6C, 0x02, 0, 0]);
    let (reply, _) = c.send_rr(
        wrap(&nanotec::get_od(Address::new(0x2FFF, 0))).encode(),
        vec![],
    );
    assert_eq!((reply.service, reply.status.0), (0xB2, 0x05));
    let set = nanotec::set_od(Address::new(0x2031, 0), &900u32.to_le_bytes()).expect("SetOD");
    let (reply, _) = c.send_rr(wrap(&set).encode(), vec![]);
    assert_eq!(reply.encode(), [0xB3, 0, 0, 0]);
    assert_eq!(c.get_od(0x2031, 0).data, 900u32.to_le_bytes());
    // A Forward_Open inside one (how rseip opens class 3).
    let open = class3(60);
    let (reply, _) = c.send_rr(
        wrap(&Request::new(
            service::FORWARD_OPEN,
            &Path::object(class::CONNECTION_MANAGER, 1),
            open.encode(),
        ))
        .encode(),
        vec![],
    );
    assert_eq!((reply.service, reply.status.0), (0xD4, 0x00));
    // Truncated: not enough data.
    let (reply, _) = c.send_rr(vec![0x52, 0x02, 0x20, 0x06, 0x24, 0x01, 0x0A], vec![]);
    assert_eq!((reply.service, reply.status.0), (0xD2, 0x13));
}

#[test]
fn class_3_connected_messages() {
    let server = server();
    let mut c = Client::register(server.addr);
    let open = class3(3);
    let (reply, items) = c.open(&open, vec![]);
    assert!(reply.status.is_success(), "{}", reply.status_text());
    assert_eq!(items.len(), 2, "no sockaddr item for class 3");
    let accepted = ForwardOpenReply::decode(&reply.data).expect("reply");
    assert_eq!(accepted.to_connection, open.to_connection);
    assert_eq!(accepted.ot_api_us, 2_000_000);
    let connected = |c: &mut Client, connection: u32, sequence: u16, request: &Request| {
        let mut data = sequence.to_le_bytes().to_vec();
        data.extend_from_slice(&request.encode());
        let items = vec![
            Item::ConnectedAddress(connection),
            Item::ConnectedData(data),
        ];
        c.raw(Command::SEND_UNIT_DATA, RrData::new(0, items).encode())
    };
    let reply = connected(
        &mut c,
        accepted.ot_connection,
        1,
        &nanotec::get_od(Address::new(0x1018, 1)),
    );
    assert_eq!(reply.status, Status::SUCCESS);
    let rr = RrData::decode(&reply.data).expect("body");
    let mut expected = vec![1, 0];
    expected.extend_from_slice(&[0xB2, 0, 0, 0, 0x6C, 0x02, 0, 0]);
    assert_eq!(
        rr.items,
        [
            Item::ConnectedAddress(accepted.to_connection),
            Item::ConnectedData(expected)
        ]
    );
    // SetOD over the connection.
    let set = nanotec::set_od(Address::new(0x2031, 0), &1100u32.to_le_bytes()).expect("SetOD");
    let reply = connected(&mut c, accepted.ot_connection, 2, &set);
    let rr = RrData::decode(&reply.data).expect("body");
    assert_eq!(rr.items[1], Item::ConnectedData(vec![2, 0, 0xB3, 0, 0, 0]));
    assert_eq!(c.get_od(0x2031, 0).data, 1100u32.to_le_bytes());
    // The same triad again is a duplicate.
    let (reply, _) = c.open(&open, vec![]);
    assert_eq!(status(&reply), (0x01, vec![extended::CONNECTION_IN_USE]));
    // Another session cannot use the connection; it dies with its TCP session.
    let mut other = Client::register(server.addr);
    let reply = connected(
        &mut other,
        accepted.ot_connection,
        3,
        &nanotec::get_od(Address::new(0x1018, 1)),
    );
    assert_eq!(reply.status, Status(0x0003));
    // Forward_Close ends it.
    assert!(c.close(&open).status.is_success());
    let reply = connected(
        &mut c,
        accepted.ot_connection,
        4,
        &nanotec::get_od(Address::new(0x1018, 1)),
    );
    assert_eq!(reply.status, Status(0x0003));
    // Class 3 to anything but the Message Router.
    let mut elsewhere = class3(4);
    elsewhere.path = Path::object(class::IDENTITY, 1).encode();
    let (reply, _) = c.open(&elsewhere, vec![]);
    assert_eq!(
        status(&reply),
        (0x01, vec![extended::INVALID_CONNECTION_POINT])
    );
    other.works();
}

// --------------------------------------------------------------------- class 1 I/O

#[test]
fn pdi_io_moves_the_motor() {
    let server = server();
    let mut c = Client::register(server.addr);
    let open = pdi(1);
    let mut io = Io::open(&mut c, &server, &open);
    assert_eq!(
        c.identity_status() & 1,
        1,
        "owned while the connection is open"
    );
    // T→O at the RPI, numbered from 1 up, with the drive's TX image.
    let first = io.recv();
    let mut last = first.sequence;
    for _ in 0..5 {
        let packet = io.recv();
        assert_eq!(packet.sequence, last.wrapping_add(1));
        assert_eq!(packet.count, packet.sequence as u16);
        assert_eq!(packet.run, None);
        assert_eq!(packet.data.len(), 8);
        last = packet.sequence;
    }
    // Idle packets do not move it.
    let target = move_to(2000, false).to_bytes().to_vec();
    for _ in 0..3 {
        io.send(false, target.clone());
        io.recv();
    }
    assert_eq!(server.drive().lock().rx_image(), RxImage::default());
    // PDI-Cmd 20 (0x14): Absolute Move to 2000 at 200 rpm.
    let packet = io.until(&target, "the move to 2000", |p| {
        TxImage::from_bytes(&p.data).is_ok_and(|tx| tx.return_value == 2000)
    });
    let tx = TxImage::from_bytes(&packet.data).expect("TX image");
    assert_eq!(tx.error_code, 0);
    assert!((server.drive().lock().position() - 2000.0).abs() < 0.5);
    // The same move again with the toggle bit: back to 0.
    let back = move_to(0, true).to_bytes().to_vec();
    io.until(&back, "the move back to 0", |p| {
        TxImage::from_bytes(&p.data).is_ok_and(|tx| tx.return_value == 0)
    });
    // Forward_Close: the triad comes back, no fault, the drive is free again.
    let reply = c.close(&open);
    assert!(reply.status.is_success(), "{}", reply.status_text());
    assert_eq!(reply.data, encode_forward_close_reply(&open.triad()));
    assert_eq!(c.identity_status() & 1, 0);
    assert_eq!(server.drive().lock().tx_image().error_code, 0);
    let (reply, _) = c.open(&pdi(2), vec![]);
    assert!(
        reply.status.is_success(),
        "a new connection after the close"
    );
}

#[test]
fn pdi_io_with_the_command_at_byte_8_and_a_t_to_o_header() {
    let server = server();
    let mut c = Client::register(server.addr);
    // 9-byte O→T assembly + 6 = 15; T→O 8 + 6 = 14 (with a run/idle header).
    let open = class1(5, (105, 104), 15, 14);
    let mut io = Io::open(&mut c, &server, &open);
    let first = io.recv();
    assert_eq!(first.run, Some(true));
    let data = assembly::encode_pdi_ot(&move_to(-1000, false), CmdOffset::Eight);
    assert_eq!(data.len(), 9);
    io.until(&data, "the move to -1000", |p| {
        TxImage::from_bytes(&p.data).is_ok_and(|tx| tx.return_value == -1000)
    });
    // Assembly 105 reads back in the connection's layout.
    let reply = c.call(&Request::new(
        service::GET_ATTRIBUTE_SINGLE,
        &Path::attribute(class::ASSEMBLY, 105, 3),
        vec![],
    ));
    assert_eq!(reply.data, data);
    assert!(c.close(&open).status.is_success());
}

#[test]
fn common_io_carries_the_process_values() {
    let server = server();
    let mut c = Client::register(server.addr);
    let open = common(7);
    let mut io = Io::open(&mut c, &server, &open);
    let first = io.recv();
    let common_in = CommonIn::decode(&first.data).expect("128 bytes");
    assert_eq!(common_in.tx.error_code, 0);
    assert_eq!(common_in.position, 0);
    let mut nanoj_inputs = [0i32; assembly::NANOJ_INPUTS];
    nanoj_inputs[0] = 42;
    nanoj_inputs[26] = -7;
    let out = CommonOut {
        rx: move_to(2000, false),
        digital_outputs: 0x0001_0000,
        nanoj_inputs,
    };
    let packet = io.until(&out.encode(), "the move to 2000", |p| {
        CommonIn::decode(&p.data).is_ok_and(|i| i.position == 2000)
    });
    let common_in = CommonIn::decode(&packet.data).expect("128 bytes");
    assert_eq!(common_in.tx.return_value, 2000);
    let drive = server.drive().lock();
    assert_eq!(
        drive.read(Address::new(0x60FE, 1)),
        Ok(Value::Uint(0x0001_0000))
    );
    assert_eq!(drive.read(Address::new(0x2400, 1)), Ok(Value::Int(42)));
    assert_eq!(drive.read(Address::new(0x2400, 27)), Ok(Value::Int(-7)));
    drop(drive);
    assert!(c.close(&open).status.is_success());
}

#[test]
fn one_class_1_connection_at_a_time() {
    let server = server();
    let mut a = Client::register(server.addr);
    let mut b = Client::register(server.addr);
    let open = pdi(11);
    let (reply, _) = a.open(&open, vec![]);
    assert!(reply.status.is_success());
    // Another set or another originator: ownership conflict; the same triad: duplicate.
    let (reply, _) = b.open(&common(12), vec![]);
    assert_eq!(status(&reply), (0x01, vec![extended::OWNERSHIP_CONFLICT]));
    let (reply, _) = b.open(&pdi(13), vec![]);
    assert_eq!(status(&reply), (0x01, vec![extended::OWNERSHIP_CONFLICT]));
    let (reply, _) = a.open(&open, vec![]);
    assert_eq!(status(&reply), (0x01, vec![extended::CONNECTION_IN_USE]));
    // Forward_Close of a triad nobody opened.
    let reply = b.close(&pdi(14));
    assert_eq!(status(&reply), (0x01, vec![extended::CONNECTION_NOT_FOUND]));
    // The connection outlives the TCP session that opened it...
    drop(a);
    let mut again = Client::register(server.addr);
    let (reply, _) = again.open(&common(15), vec![]);
    assert_eq!(status(&reply), (0x01, vec![extended::OWNERSHIP_CONFLICT]));
    // ...and ends by Forward_Close from any session of the originator.
    assert!(again.close(&open).status.is_success());
    let (reply, _) = b.open(&common(16), vec![]);
    assert!(reply.status.is_success(), "{}", reply.status_text());
    assert!(b.close(&common(16)).status.is_success());
}

#[test]
fn forward_open_refusals() {
    let server = server();
    let mut c = Client::register(server.addr);
    let refused = |c: &mut Client, open: ForwardOpen| status(&c.open(&open, vec![]).0);
    // Sizes: O→T, T→O.
    assert_eq!(
        refused(&mut c, class1(1, (105, 104), 16, 10)),
        (0x01, vec![0x0127, 14])
    );
    assert_eq!(
        refused(&mut c, class1(1, (105, 104), 14, 12)),
        (0x01, vec![0x0128, 10])
    );
    assert_eq!(
        refused(&mut c, class1(1, (101, 100), 14, 130)),
        (0x01, vec![0x0127, 134])
    );
    // Connection points that are not a set.
    assert_eq!(
        refused(&mut c, class1(1, (105, 100), 14, 10)),
        (0x01, vec![0x0117])
    );
    assert_eq!(
        refused(&mut c, class1(1, (150, 151), 14, 10)),
        (0x01, vec![0x0117])
    );
    // RPI outside 1 ms to 10 s.
    let mut fast = pdi(1);
    fast.ot_rpi_us = 500;
    assert_eq!(refused(&mut c, fast), (0x01, vec![0x0111]));
    let mut slow = pdi(1);
    slow.to_rpi_us = 20_000_000;
    assert_eq!(refused(&mut c, slow), (0x01, vec![0x0111]));
    // An electronic key of another vendor; Nanotec's and a zero key are fine.
    let keyed = |vendor: u16| {
        let mut open = pdi(1);
        let mut key = [0u8; 8];
        key[..2].copy_from_slice(&vendor.to_le_bytes());
        let mut path = Path(vec![Segment::ElectronicKey(key)]).encode();
        path.extend_from_slice(&open.path);
        open.path = path;
        open
    };
    assert_eq!(refused(&mut c, keyed(0x0001)), (0x01, vec![0x0114]));
    // Transport class 2, and a path that does not decode.
    let mut class2 = pdi(1);
    class2.transport = 0x02;
    assert_eq!(refused(&mut c, class2), (0x01, vec![0x0103]));
    let mut garbled = pdi(1);
    garbled.path = vec![0x60, 0x00];
    assert_eq!(refused(&mut c, garbled), (0x01, vec![0x0315]));
    // Truncated request data.
    let (reply, _) = c.send_rr(vec![0x54, 0x02, 0x20, 0x06, 0x24, 0x01, 0x0A, 0x0E], vec![]);
    assert_eq!(status(&reply), (0x13, vec![]));
    // Nothing was opened by any of it; the keyed and the Large_Forward_Open ones work.
    let open = keyed(0x0558);
    let (reply, _) = c.open(&open, vec![]);
    assert!(reply.status.is_success(), "{}", reply.status_text());
    assert!(c.close(&open).status.is_success());
    let mut large = keyed(0);
    large.large = true;
    let (reply, _) = c.open(&large, vec![]);
    assert_eq!(reply.service, 0xDB);
    assert!(reply.status.is_success(), "{}", reply.status_text());
    assert!(c.close(&large).status.is_success());
}

#[test]
fn a_silent_originator_loses_the_connection_and_the_drive_faults() {
    let server = server();
    let mut c = Client::register(server.addr);
    // RPI 10 ms, multiplier 0: 40 ms without O→T ends it.
    let mut open = pdi(21);
    open.timeout_multiplier = 0;
    let mut io = Io::open(&mut c, &server, &open);
    let hold = RxImage::default().to_bytes().to_vec();
    io.send(true, hold.clone());
    io.recv();
    assert_eq!(c.identity_status() & 1, 1);
    // Silence.
    wait_for("fault 8000h", || {
        server.drive().lock().tx_image().error_code == 0x8000
    });
    assert_eq!(c.get_od(0x603F, 0).data, [0x00, 0x80]);
    assert_eq!(c.identity_status() & 1, 0, "no longer owned");
    // Production stopped: what is left in the socket drains, then nothing comes.
    io.udp
        .set_read_timeout(Some(Duration::from_millis(300)))
        .expect("timeout");
    let deadline = Instant::now() + WAIT;
    let mut buffer = [0u8; 256];
    while io.udp.recv_from(&mut buffer).is_ok() {
        assert!(Instant::now() < deadline, "T→O packets keep coming");
    }
    // Late O→T packets are ignored, the connection is gone: a new one opens.
    io.send(true, hold);
    let (reply, _) = c.open(&pdi(22), vec![]);
    assert!(reply.status.is_success(), "{}", reply.status_text());
    assert_eq!(
        server.drive().lock().tx_image().error_code,
        0x8000,
        "latched until Clear Error"
    );
}

// --------------------------------------------------------------------------- the CLI

#[test]
fn drivedeck_sim_serves_enip_and_says_where() {
    let (sim, _) = common::Sim::enip(&[]);
    let banner = &sim.banner;
    // "serving the simulated drive on EtherNet/IP 127.0.0.1:P (class 1 I/O on UDP
    // 127.0.0.1:Q, vendor 558h)"
    let word_after = |marker: &str| -> SocketAddr {
        banner
            .split(marker)
            .nth(1)
            .and_then(|rest| rest.split([' ', ',']).next())
            .and_then(|a| a.parse().ok())
            .unwrap_or_else(|| panic!("no address after {marker:?} in {banner:?}"))
    };
    assert!(
        banner.starts_with("serving the simulated drive on EtherNet/IP 127.0.0.1:"),
        "{banner}"
    );
    assert!(banner.trim_end().ends_with(", vendor 558h)"), "{banner}");
    let tcp = word_after("EtherNet/IP ");
    let io = word_after("I/O on UDP ");
    assert_ne!(tcp.port(), 0);
    assert_ne!(io.port(), 0);
    let mut c = Client::register(tcp);
    c.works();
    let udp = UdpSocket::bind("127.0.0.1:0").expect("UDP");
    udp.set_read_timeout(Some(WAIT)).expect("timeout");
    udp.send_to(&packet(Command::LIST_IDENTITY, 0, vec![]), tcp)
        .expect("ListIdentity");
    let mut buffer = [0u8; 600];
    let (n, _) = udp.recv_from(&mut buffer).expect("ListIdentity reply");
    assert!(Packet::decode(&buffer[..n]).is_ok());
    drop(sim);
}
