//! EtherNet/IP class 1 I/O keeps producing whatever holds the thread that owns the link:
//! the O→T producer and T→O consumer run on threads of their own, not as tasks on the
//! worker's runtime. Behaviour, not speed: only a generous lower bound on the packets.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::time::{Duration, Instant};

use drivedeck::link::enip::client::EnipLink;
use drivedeck::link::{Link, LinkSpec};
use drivedeck::proto::enip::io::IoPacket;
use drivedeck::sim::server::ServerThread;
use drivedeck::sim::server::enip::AdapterOptions;

const RPI_MS: u64 = 2;
const BLOCK: Duration = Duration::from_millis(200);

fn bytes_of(raw: &str) -> Vec<u8> {
    let digits: Vec<u8> = raw
        .bytes()
        .filter(u8::is_ascii_hexdigit)
        .map(|c| (c as char).to_digit(16).unwrap_or(0) as u8)
        .collect();
    digits
        .chunks(2)
        .map(|p| p[0] << 4 | p.get(1).copied().unwrap_or(0))
        .collect()
}

/// The simulated adapter with class 1 I/O on any port, the link to it at RPI_MS, and a
/// runtime of one thread (the link's, as the worker's).
fn served() -> (ServerThread, LinkSpec, tokio::runtime::Runtime) {
    let server = ServerThread::enip(
        ([127, 0, 0, 1], 0).into(),
        AdapterOptions {
            io_port: 0,
            ..AdapterOptions::default()
        },
    )
    .expect("the simulated adapter");
    let spec: LinkSpec = format!("enip://{}?io=pdi&rpi={RPI_MS}&udp=0", server.addr)
        .parse()
        .expect("spec");
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .expect("runtime");
    (server, spec, runtime)
}

#[test]
fn class_1_io_keeps_producing_and_consuming_while_the_links_thread_is_blocked() {
    // The server lives to the end of the test.
    let (_server, spec, runtime) = served();
    runtime.block_on(async {
        let mut link = EnipLink::connect(&spec).await.expect("connected");
        let rx = link.read_rx().await.expect("the RX image");
        link.exchange(rx.as_ref()).await.expect("an exchange");
        let _ = link.take_trace();
        let (sent_before, received_before, _) = link.io_counts().expect("class 1 I/O open");
        // A slow task: it holds the runtime's only thread without yielding.
        let blocked = Instant::now();
        tokio::spawn(async { std::thread::sleep(BLOCK) })
            .await
            .expect("the slow task");
        let held = blocked.elapsed();
        let (sent_after, received_after, _) = link.io_counts().expect("class 1 I/O open");
        let trace = link.take_trace();

        let slots = held.as_millis() as u64 / RPI_MS;
        let (sent, received) = (sent_after - sent_before, received_after - received_before);
        assert!(
            sent >= slots / 2,
            "{sent} O→T packets while the thread was held {held:?} at RPI {RPI_MS} ms"
        );
        assert!(
            received >= slots / 2,
            "{received} T→O packets taken while the thread was held {held:?}"
        );

        // What went out meanwhile: one connection, consecutive sequence numbers, RUN.
        let packets: Vec<IoPacket> = trace
            .iter()
            .filter(|r| r.sent && r.text.starts_with("class 1 O→T"))
            .map(|r| IoPacket::decode(&bytes_of(&r.raw), true).expect("an O→T packet"))
            .collect();
        assert!(
            packets.len() as u64 >= slots / 2,
            "{} traced",
            packets.len()
        );
        for pair in packets.windows(2) {
            assert_eq!(pair[1].connection, pair[0].connection);
            assert_eq!(
                pair[1].sequence,
                pair[0].sequence.wrapping_add(1),
                "sequence numbers +1 per packet"
            );
            assert_eq!(pair[1].count, pair[0].count, "the outputs did not change");
        }
        assert!(
            packets.iter().all(|p| p.run == Some(true)),
            "RUN throughout"
        );

        // And the link goes on as before.
        link.exchange(rx.as_ref()).await.expect("an exchange after");
        link.close().await.expect("closed");
        let (sent_closed, _, _) = link.io_counts().unwrap_or_default();
        assert_eq!(sent_closed, 0, "no I/O connection after close");
    });
}

/// A flood of datagrams at the T→O socket: the I/O goes on, the strays are counted, and a
/// consumer at real-time priority goes back to ordinary priority, said once in the log.
#[test]
fn a_flood_at_the_io_socket_lowers_the_consumer_and_the_io_goes_on() {
    // The server lives to the end of the test.
    let (_server, spec, runtime) = served();
    runtime.block_on(async {
        let mut link = EnipLink::connect(&spec).await.expect("connected");
        let rx = link.read_rx().await.expect("the RX image");
        link.exchange(rx.as_ref()).await.expect("an exchange");
        let raised = matches!(
            link.io_consumer_priority(),
            Some(drivedeck::link::enip::priority::Priority::Realtime(_))
        );
        let target = link.io_local().expect("class 1 I/O open");
        let target = std::net::SocketAddr::from(([127, 0, 0, 1], target.port()));
        let flood = std::net::UdpSocket::bind(("127.0.0.1", 0)).expect("a UDP socket");
        for k in 0..3_000u32 {
            let _ = flood.send_to(&k.to_le_bytes(), target);
        }
        tokio::time::sleep(Duration::from_millis(300)).await;
        let (_, _, stray) = link.io_counts().expect("class 1 I/O open");
        assert!(stray > 0, "the flood's datagrams were counted as strays");
        link.exchange(rx.as_ref())
            .await
            .expect("an exchange after the flood");
        let said = link.take_recovered();
        if raised {
            assert!(
                said.iter()
                    .any(|s| s.contains("datagrams reached the T→O socket") && s.contains("ordinary")),
                "the flood is said: {said:?}"
            );
            assert_eq!(
                link.io_consumer_priority(),
                Some(drivedeck::link::enip::priority::Priority::Normal)
            );
        } else {
            eprintln!(
                "SKIPPED (in part): real-time priority is not granted here, so the consumer was never raised and the flood guard's lowering was not exercised"
            );
        }
        link.close().await.expect("closed");
    });
}
