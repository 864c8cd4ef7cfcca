//! One bad frame is not a lost link, on CANopen:
//!
//! - over the in-memory bus, a simulated node behind a test bus that loses, spoils or
//!   refuses chosen frames it sends: an SDO answer lost or broken once is asked for again
//!   (and the trouble named), an abort is the drive's answer (never asked again), a late
//!   answer to an earlier request is skipped;
//! - over slcan on a pseudo-terminal pair, through the worker: a garbled line during a
//!   move is skipped and named in the log; a node whose TPDOs stop, or that stops
//!   altogether, counts as lost only after the configured number of failed exchanges, one
//!   per missed event-timer period; an SDO abort during a move on the PDI-over-SDO path is
//!   the drive's refusal, named, and a lost link only when it repeats.
//!
//! The slcan tests need socat: skipped with a reason without it, and required in CI.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
mod probe;
mod proxy;

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use common::PtyPair;
use drivedeck::cia::AbortCode;
use drivedeck::link::canopen::client::CanopenLink;
use drivedeck::link::canopen::slcan::SlcanDevice;
use drivedeck::link::canopen::{CanBus, MemoryBus};
use drivedeck::link::{CanopenOptions, Error, Link, LinkSpec, Refusal};
use drivedeck::od::{Address, DataType, Value};
use drivedeck::pdi::Action;
use drivedeck::proto::canopen::CanFrame;
use drivedeck::sim::Drive;
use drivedeck::sim::server::SharedDrive;
use drivedeck::sim::server::canopen::{Node, run_node};
use drivedeck::worker::{CommandProgress, Request};
use probe::Probe;
use proxy::{Noise, SerialProxy};

// ---------------------------------------------------------------------------------------
// A node's bus that does wrong on purpose.

/// What the node's bus does to the frames the node sends, and what it saw.
#[derive(Default)]
struct Plan {
    /// SDO answers the node sent so far (lost ones included).
    answers: u64,
    /// Numbers of SDO answers to lose.
    lose: Vec<u64>,
    /// Upload segment answers still to send with the wrong toggle.
    wrong_toggles: u32,
    /// SDO answers still to precede with a late answer for 1000h:00.
    stale_before: u32,
    /// Downloads to this index still to answer with this abort (the node did write).
    refuse: Option<(u16, AbortCode, u64)>,
    mute_tpdos: bool,
    mute_all: bool,
    /// The SDO requests the node received, in order.
    requests: Vec<[u8; 8]>,
}

#[derive(Clone, Default)]
struct Faults(Arc<Mutex<Plan>>);

impl Faults {
    fn plan(&self) -> std::sync::MutexGuard<'_, Plan> {
        self.0.lock().expect("plan")
    }

    /// Lose the `count` SDO answers after the next `after - 1`.
    fn lose_answers(&self, after: u64, count: u64) {
        let mut plan = self.plan();
        let first = plan.answers + after;
        plan.lose.extend(first..first + count);
    }

    /// The SDO requests for `index:sub` with command byte `byte0` (40h upload, 80h abort…).
    fn requests(&self, byte0: u8, index: u16, sub: u8) -> Vec<[u8; 8]> {
        let [lo, hi] = index.to_le_bytes();
        self.plan()
            .requests
            .iter()
            .filter(|r| r[0] == byte0 && r[1..4] == [lo, hi, sub])
            .copied()
            .collect()
    }

    /// The abort codes the node received from the master for `index:sub`.
    fn aborts(&self, index: u16, sub: u8) -> Vec<AbortCode> {
        self.requests(0x80, index, sub)
            .iter()
            .map(|r| AbortCode(u32::from_le_bytes([r[4], r[5], r[6], r[7]])))
            .collect()
    }
}

/// `inner` as node `node` sees it, with `faults` applied to what the node sends.
struct FaultyBus<B> {
    inner: B,
    node: u8,
    faults: Faults,
}

impl<B: CanBus> FaultyBus<B> {
    /// What goes on the bus instead of `frame` (nothing, itself, another frame, more).
    fn spoil(&self, frame: &CanFrame) -> Vec<CanFrame> {
        let mut plan = self.faults.plan();
        let node = u16::from(self.node);
        let Some(cob) = frame.cob_id() else {
            return vec![*frame];
        };
        if plan.mute_all {
            return vec![];
        }
        let tpdo = [0x180, 0x280, 0x380, 0x480].map(|base| base + node);
        if plan.mute_tpdos && tpdo.contains(&cob) {
            return vec![];
        }
        if cob != 0x580 + node {
            return vec![*frame];
        }
        plan.answers += 1;
        let number = plan.answers;
        if let Some(at) = plan.lose.iter().position(|n| *n == number) {
            plan.lose.remove(at);
            return vec![];
        }
        let mut data = [0u8; 8];
        data[..frame.len()].copy_from_slice(frame.data());
        let index = u16::from_le_bytes([data[1], data[2]]);
        if let Some((refused, code, left)) = plan.refuse
            && left > 0
            && data[0] == 0x60
            && index == refused
        {
            plan.refuse = Some((refused, code, left - 1));
            let mut abort = [0x80, data[1], data[2], data[3], 0, 0, 0, 0];
            abort[4..].copy_from_slice(&code.0.to_le_bytes());
            return vec![CanFrame::new(cob, &abort).expect("abort frame")];
        }
        if plan.wrong_toggles > 0 && data[0] & 0xE0 == 0 {
            plan.wrong_toggles -= 1;
            data[0] ^= 0x10;
            return vec![CanFrame::new(cob, &data).expect("segment")];
        }
        if plan.stale_before > 0 {
            plan.stale_before -= 1;
            // 1000h:00 (device type), as a late answer to a read long given up on.
            let stale = CanFrame::new(cob, &[0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00])
                .expect("stale frame");
            return vec![stale, *frame];
        }
        vec![*frame]
    }
}

impl<B: CanBus> CanBus for FaultyBus<B> {
    async fn send(&mut self, frame: &CanFrame) -> Result<(), Error> {
        for frame in self.spoil(frame) {
            self.inner.send(&frame).await?;
        }
        Ok(())
    }

    async fn recv(&mut self) -> Result<CanFrame, Error> {
        let frame = self.inner.recv().await?;
        if frame.cob_id() == Some(0x600 + u16::from(self.node)) {
            let mut data = [0u8; 8];
            data[..frame.len()].copy_from_slice(frame.data());
            self.faults.plan().requests.push(data);
        }
        Ok(frame)
    }

    fn describe(&self) -> String {
        format!("{} (with faults)", self.inner.describe())
    }
}

/// Serve a simulated drive as `node` on `bus`, through a faulty bus.
async fn serve(bus: impl CanBus, node: u8, fixed_mapping: bool, faults: Faults) {
    let drive = SharedDrive::new(Drive::new());
    let built = {
        let mut d = drive.lock();
        Node::new(node, &mut d).with_fixed_mapping(fixed_mapping)
    };
    let bus = FaultyBus {
        inner: bus,
        node,
        faults,
    };
    let _ = run_node(bus, built, drive).await;
}

fn memory_spec(node: u8) -> LinkSpec {
    format!("canopen+sim://?node={node}").parse().expect("spec")
}

/// Our master on a memory bus with a faulty node 1 on it, connected (PDI on PDOs).
async fn master_and_node() -> (CanopenLink<drivedeck::link::canopen::MemoryPort>, Faults) {
    let bus = MemoryBus::new();
    let faults = Faults::default();
    tokio::spawn(serve(bus.port(), 1, false, faults.clone()));
    let mut link = CanopenLink::connect(memory_spec(1), bus.port(), CanopenOptions::default())
        .await
        .expect("connect");
    assert!(link.info().description.contains("RPDO1/TPDO1"));
    let connecting = link.take_recovered();
    assert!(connecting.is_empty(), "{connecting:#?}");
    // Only the requests of the test count.
    faults.plan().requests.clear();
    (link, faults)
}

// ---------------------------------------------------------------------------------------
// (a) SDO over the in-memory bus

#[test]
fn an_sdo_answer_lost_once_is_asked_for_again_and_the_log_says_so() {
    common::runtime().block_on(async {
        let (mut link, faults) = master_and_node().await;
        faults.lose_answers(1, 1);
        let started = Instant::now();
        let read = link
            .read_object(Address::new(0x1018, 1), DataType::Unsigned32)
            .await
            .expect("the read survives one lost answer");
        let took = started.elapsed();
        assert_eq!(read, Ok(Value::Uint(0x26C)));
        // The node was asked twice, and told the first transfer was given up (05040000h).
        assert_eq!(faults.requests(0x40, 0x1018, 1).len(), 2);
        assert_eq!(faults.aborts(0x1018, 1), [AbortCode::SDO_TIMEOUT]);
        let recovered = link.take_recovered();
        assert!(
            recovered
                .iter()
                .any(|t| t.contains("SDO upload of 1018h:01h")
                    && t.contains("no answer within")
                    && t.contains("answered on try 2")),
            "{recovered:#?}"
        );
        // One try's wait (a third of 500 ms), not the whole budget.
        assert!(took < Duration::from_millis(450), "took {took:?}");
        assert!(link.take_recovered().is_empty(), "reported once");
    });
}

#[test]
fn a_write_whose_answer_is_lost_once_is_sent_again() {
    common::runtime().block_on(async {
        let (mut link, faults) = master_and_node().await;
        faults.lose_answers(1, 1);
        let written = link
            .write_object(
                Address::new(0x6081, 0),
                DataType::Unsigned32,
                &Value::Uint(777),
            )
            .await
            .expect("the write survives one lost answer");
        assert_eq!(written, Ok(()));
        assert_eq!(
            link.read_object(Address::new(0x6081, 0), DataType::Unsigned32)
                .await
                .expect("link"),
            Ok(Value::Uint(777))
        );
        let recovered = link.take_recovered();
        assert!(
            recovered
                .iter()
                .any(|t| t.contains("SDO download to 6081h:00h") && t.contains("try 2")),
            "{recovered:#?}"
        );
    });
}

#[test]
fn a_wrong_toggle_aborts_the_transfer_and_starts_it_again() {
    common::runtime().block_on(async {
        let (mut link, faults) = master_and_node().await;
        faults.plan().wrong_toggles = 1;
        let name = link
            .read_object(Address::new(0x1008, 0), DataType::VisibleString)
            .await
            .expect("the segmented read survives one wrong toggle");
        assert_eq!(name, Ok(Value::Text("drivedeck simulated drive".into())));
        assert_eq!(faults.requests(0x40, 0x1008, 0).len(), 2);
        assert_eq!(
            faults.aborts(0x1008, 0),
            [AbortCode::TOGGLE_BIT_NOT_ALTERNATED]
        );
        let recovered = link.take_recovered();
        assert!(
            recovered
                .iter()
                .any(|t| t.contains("SDO upload of 1008h:00h")
                    && t.contains("toggle")
                    && t.contains("answered on try 2")),
            "{recovered:#?}"
        );
    });
}

#[test]
fn a_late_answer_to_an_earlier_request_is_skipped_not_sent_again() {
    common::runtime().block_on(async {
        let (mut link, faults) = master_and_node().await;
        faults.plan().stale_before = 1;
        let read = link
            .read_object(Address::new(0x1018, 1), DataType::Unsigned32)
            .await
            .expect("the read takes its own answer");
        assert_eq!(read, Ok(Value::Uint(0x26C)));
        // Asked once: a second request would leave an answer to arrive late next time.
        assert_eq!(faults.requests(0x40, 0x1018, 1).len(), 1);
        assert!(faults.aborts(0x1018, 1).is_empty());
        let recovered = link.take_recovered();
        assert!(
            recovered
                .iter()
                .any(|t| t.contains("an answer for 1000h:00h") && t.contains("skipped")),
            "{recovered:#?}"
        );
    });
}

#[test]
fn an_abort_is_the_drives_answer_and_never_asked_again() {
    common::runtime().block_on(async {
        let (mut link, faults) = master_and_node().await;
        let missing = link
            .read_object(Address::new(0x1018, 9), DataType::Unsigned32)
            .await
            .expect("link");
        assert_eq!(missing, Err(Refusal::Abort(AbortCode::NO_SUBINDEX)));
        assert_eq!(faults.requests(0x40, 0x1018, 9).len(), 1);
        assert!(link.take_recovered().is_empty());
    });
}

#[test]
fn when_every_try_goes_wrong_the_error_names_each() {
    common::runtime().block_on(async {
        let (mut link, faults) = master_and_node().await;
        // Nothing at all: a timeout after the whole budget, the tries counted.
        faults.lose_answers(1, 3);
        let error = link
            .read_object(Address::new(0x1018, 1), DataType::Unsigned32)
            .await
            .expect_err("three answers lost");
        let text = error.to_string();
        assert!(matches!(error, Error::Timeout { .. }), "{text}");
        assert!(
            text.contains("SDO upload of 1018h:01h from node 1")
                && text.contains("3 tries")
                && text.contains("no answer within 500 ms"),
            "{text}"
        );
        assert_eq!(faults.requests(0x40, 0x1018, 1).len(), 3);
        // A lost answer, then broken ones: each try's trouble named.
        faults.lose_answers(1, 1);
        faults.plan().wrong_toggles = 2;
        let error = link
            .read_object(Address::new(0x1008, 0), DataType::VisibleString)
            .await
            .expect_err("no valid answer");
        let Error::NoValidReply {
            tries, troubles, ..
        } = &error
        else {
            panic!("{error:?}")
        };
        assert_eq!(*tries, 3);
        assert!(troubles[0].starts_with("no answer within"), "{troubles:?}");
        assert!(troubles[1].contains("toggle"), "{troubles:?}");
        assert!(troubles[2].contains("toggle"), "{troubles:?}");
        // And the link still works.
        assert_eq!(
            link.read_object(Address::new(0x1018, 1), DataType::Unsigned32)
                .await
                .expect("link"),
            Ok(Value::Uint(0x26C))
        );
    });
}

// ---------------------------------------------------------------------------------------
// Through the worker, over slcan on a pseudo-terminal pair.

/// A faulty simulated node served behind an emulated slcan adapter on one end of a pty
/// pair, in a thread of its own; the master connects to `pair.b`.
struct PtyNode {
    pair: PtyPair,
    faults: Faults,
}

impl PtyNode {
    /// `None` (after `skip_or_fail`) without socat.
    fn start(node: u8, fixed_mapping: bool) -> Option<PtyNode> {
        let pair = PtyPair::new()?;
        let faults = Faults::default();
        let path = pair.a.to_str().expect("utf-8 path").to_owned();
        let served = faults.clone();
        let (ready, opened) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            common::runtime().block_on(async move {
                let device = SlcanDevice::open(&path).expect("the adapter end");
                let _ = ready.send(());
                serve(device, node, fixed_mapping, served).await;
            });
        });
        opened
            .recv_timeout(Duration::from_secs(5))
            .expect("the node's adapter end opened");
        Some(PtyNode { pair, faults })
    }

    fn spec(&self, node: u8) -> LinkSpec {
        common::slcan_spec(&self.pair.b, node)
    }
}

/// One turn at 120 rpm: about half a second of motion.
const A_MOVE: Action = Action::MoveRelative {
    distance: 3600,
    speed: 120,
};

// (b) a garbled line during a move

#[test]
fn slcan_a_garbled_line_during_a_move_is_skipped_and_named() {
    let (Some(host), Some(device)) = (PtyPair::new(), PtyPair::new()) else {
        return;
    };
    let _sim = common::Sim::slcan(&device.a, 1, &[]);
    let proxy = SerialProxy::start(&host.b, &device.b, true);
    let mut probe = Probe::connected(common::slcan_spec(&host.a, 1));
    let id = probe.start(A_MOVE);
    // The first SDO answer from here on (a sampled object's), and a TPDO after it.
    proxy.noise_on(1, Noise::Flip, b"t581");
    proxy.noise_on(1, Noise::Flip, b"t181");
    let outcome = probe.outcome(id, Duration::from_secs(15));
    assert!(
        matches!(outcome, CommandProgress::Done { .. }),
        "the move did not survive a garbled line: {outcome:?}; {:#?}",
        probe.notices()
    );
    assert_eq!(proxy.applied(), [Noise::Flip, Noise::Flip]);
    let spoiled = proxy.spoiled();
    // The garbled lines reach the log, counted, with what was wrong with them…
    let skipped = probe.expect_notice(&["slcan", "garbled line", "skipped"]);
    assert!(skipped.contains("malformed slcan frame"), "{skipped}");
    // …and the SDO answer lost with one is asked for again, and said so.
    let sdo = probe.expect_notice(&["SDO ", "answered on try 2"]);
    assert!(
        sdo.contains("no answer within"),
        "{sdo}; spoiled: {spoiled:?}"
    );
    probe.never_dropped();
}

// (c) lost after the configured count of missed TPDO periods

/// "…Cause: N exchanges failed in a row; the last: …: no answer within X ms…" (what to do
/// leads the reason, the cause follows): N and X.
fn failed_and_silence(reason: &str) -> (u32, u64) {
    let cause = reason.rsplit("Cause: ").next().unwrap_or(reason);
    let count = cause
        .split(" exchanges failed in a row")
        .next()
        .and_then(|n| n.trim().parse().ok())
        .unwrap_or_else(|| panic!("no count in {reason:?}"));
    let silence = cause
        .split("; the last: ")
        .nth(1)
        .and_then(|last| last.split("no answer within ").nth(1))
        .and_then(|rest| rest.split(" ms").next())
        .and_then(|ms| ms.parse().ok())
        .unwrap_or_else(|| panic!("no silence in {reason:?}"));
    (count, silence)
}

#[test]
fn a_node_whose_tpdos_stop_is_lost_after_the_configured_number_of_missed_periods() {
    let Some(node) = PtyNode::start(4, false) else {
        return;
    };
    let (mut probe, _) = Probe::turning(node.spec(4), 5);

    // A gap shorter than the allowance: failed exchanges, then the link recovers.
    node.faults.plan().mute_tpdos = true;
    let failed = probe.expect_notice(&["an exchange with the drive failed", "TPDO1"]);
    assert!(
        failed.contains("no answer within 500 ms") && failed.contains("lost after 5"),
        "{failed}"
    );
    node.faults.plan().mute_tpdos = false;
    probe.expect_notice(&["the link recovered after"]);
    probe.never_dropped();

    // For good this time (SDO still answers: the node is as if pre-operational). One
    // failed exchange at 500 ms without a TPDO, one more per 100 ms event-timer period.
    let cut = Instant::now();
    node.faults.plan().mute_tpdos = true;
    let reason = probe.lost(Duration::from_secs(10));
    let took = cut.elapsed();
    assert!(reason.contains("TPDO1 from node 4"), "{reason}");
    assert_eq!(failed_and_silence(&reason), (5, 500 + 4 * 100), "{reason}");
    assert!(took >= Duration::from_millis(700), "lost after {took:?}");
}

#[test]
fn a_node_that_stops_altogether_is_lost_after_the_configured_count() {
    let Some(node) = PtyNode::start(6, false) else {
        return;
    };
    let (mut probe, _) = Probe::turning(node.spec(6), 4);
    let cut = Instant::now();
    node.faults.plan().mute_all = true;
    let reason = probe.lost(Duration::from_secs(10));
    let took = cut.elapsed();
    // The cycle's SDO read fails first (all its tries, 500 ms), then the TPDO checks:
    // at 500 ms of silence, then one per 100 ms period.
    let failed = probe.expect_notice(&["an exchange with the drive failed"]);
    assert!(failed.contains("lost after 4"), "{failed}");
    let (count, silence) = failed_and_silence(&reason);
    assert_eq!(count, 4, "{reason}");
    assert!(reason.contains("TPDO1 from node 6"), "{reason}");
    assert!(
        (600..=800).contains(&silence) && silence % 100 == 0,
        "the last failure after {silence} ms without a TPDO: {reason}"
    );
    assert!(took >= Duration::from_millis(600), "lost after {took:?}");
}

// (d) an SDO abort during a move, PDI over SDO

#[test]
fn an_sdo_abort_during_a_move_is_a_refusal_and_a_lost_link_only_when_it_repeats() {
    let Some(node) = PtyNode::start(2, true) else {
        return;
    };
    let mut probe = Probe::connected(node.spec(2));
    let connected = probe.link_info().description;
    assert!(connected.contains("PDI over SDO"), "{connected}");
    probe.send(Request::SetLostAfter(3));

    // Once: the exchange that writes the move's values is refused, the next one goes
    // through, and the move completes.
    node.faults.plan().refuse = Some((0x2291, AbortCode::DEVICE_STATE, 1));
    let id = probe.send(Request::Command(A_MOVE));
    let outcome = probe.outcome(id, Duration::from_secs(15));
    assert!(
        matches!(outcome, CommandProgress::Done { .. }),
        "{outcome:?}; {:#?}",
        probe.notices()
    );
    let refused = probe.expect_notice(&["an exchange with the drive failed", "refused"]);
    assert!(
        refused.contains("08000022h") && refused.contains("present device state"),
        "{refused}"
    );
    probe.expect_notice(&["the link recovered after 1 failed exchange"]);
    // The refusal was the drive's answer: nothing was given up on, no abort sent to it.
    assert!(
        node.faults.plan().requests.iter().all(|r| r[0] != 0x80),
        "the master aborted a transfer"
    );
    probe.never_dropped();

    // Every time: three failed exchanges in a row, each the same refusal, lose the link.
    node.faults.plan().refuse = Some((0x2291, AbortCode::DEVICE_STATE, u64::MAX));
    probe.send(Request::Command(Action::MoveRelative {
        distance: -3600,
        speed: 120,
    }));
    let reason = probe.lost(Duration::from_secs(10));
    assert!(
        reason.contains("3 exchanges failed in a row")
            && reason.contains("08000022h")
            && reason.contains("present device state"),
        "{reason}"
    );
}
