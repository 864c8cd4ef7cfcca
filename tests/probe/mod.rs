//! A test's view of the worker thread: connect, send requests, wait for the events a
//! window would see (a command accepted and done, an object read or written, a notice, the
//! link lost and back), and keep every event for the failure message. Shared by the
//! end-to-end tests of every link (`mod probe;`).

#![allow(dead_code)]

use std::sync::Arc;
use std::time::{Duration, Instant};

use drivedeck::link::{FoundDevice, LinkFailure, LinkInfo, LinkSpec};
use drivedeck::od::{Address, DataType, Value};
use drivedeck::pdi::Action;
use drivedeck::worker::{
    CommandProgress, Config, Event, ObjectError, ObjectPath, Request, RequestId, Sample, Worker,
};

pub struct Probe {
    pub worker: Worker,
    /// Every event received so far, oldest first.
    pub seen: Vec<Event>,
    /// The newest value of every signal, merged over the samples received so far.
    pub last: Option<Sample>,
}

impl Default for Probe {
    fn default() -> Self {
        Self::new()
    }
}

impl Probe {
    /// A worker with the default configuration, not connected.
    pub fn new() -> Probe {
        Probe {
            worker: Worker::spawn(Config::default(), Arc::new(|| {})).expect("worker thread"),
            seen: vec![],
            last: None,
        }
    }

    /// A worker on simulated time (its clock jumps ahead whenever it only waits) connected
    /// to the in-process simulated drive: for tests that only wait for the drive.
    pub fn on_simulated_time() -> Probe {
        let config = Config {
            simulated_time: true,
            ..Config::default()
        };
        let mut probe = Probe {
            worker: Worker::spawn(config, Arc::new(|| {})).expect("worker thread"),
            seen: vec![],
            last: None,
        };
        probe.connect_first(LinkSpec::Sim);
        probe
    }

    /// A worker connected to `spec`, with its first sample in.
    pub fn connected(spec: LinkSpec) -> Probe {
        let mut probe = Probe::new();
        probe.connect_first(spec);
        probe
    }

    /// Connect to `spec` and wait for the first sample.
    fn connect_first(&mut self, spec: LinkSpec) {
        let probe = self;
        probe.send(Request::Connect(spec));
        probe.wait("connected", Duration::from_secs(10), |e| {
            matches!(e, Event::Connected(_))
        });
        probe.wait(
            "a sample",
            Duration::from_secs(5),
            |e| matches!(e, Event::Samples(s) if !s.is_empty()),
        );
    }

    /// A worker connected to `spec` with the motor turning slowly (a velocity command
    /// accepted), the link counting as lost after `lost_after` failed exchanges in a row;
    /// and the velocity command's id.
    pub fn turning(spec: LinkSpec, lost_after: u32) -> (Probe, RequestId) {
        let mut probe = Probe::connected(spec);
        probe.send(Request::SetLostAfter(lost_after));
        let id = probe.start(Action::Velocity { speed: 60 });
        (probe, id)
    }

    /// Ask to connect to `spec`: the worker's first answer, `Event::Connected` or
    /// `Event::ConnectFailed`.
    pub fn connect(&mut self, spec: LinkSpec) -> Event {
        self.send(Request::Connect(spec));
        self.wait(
            "the connection or its failure",
            Duration::from_secs(10),
            |e| matches!(e, Event::Connected(_) | Event::ConnectFailed { .. }),
        )
    }

    /// What the link said of itself when it last connected.
    pub fn link_info(&self) -> LinkInfo {
        self.seen
            .iter()
            .rev()
            .find_map(|e| match e {
                Event::Connected(info) => Some(info.clone()),
                _ => None,
            })
            .expect("connected")
    }

    pub fn send(&self, request: Request) -> RequestId {
        self.worker.send(request).expect("request queued")
    }

    /// Send `action` and wait until the drive accepted it.
    pub fn start(&mut self, action: Action) -> RequestId {
        let id = self.send(Request::Command(action));
        self.accepted(id);
        id
    }

    /// Wait until the drive accepted command `id`.
    pub fn accepted(&mut self, id: RequestId) {
        self.wait(
            "the command accepted",
            Duration::from_secs(5),
            |e| matches!(e, Event::Progress { id: i, progress: CommandProgress::Accepted } if *i == id),
        );
    }

    /// An absolute move to `target` at `speed`: done, its return value the target.
    pub fn move_absolute(&mut self, target: i32, speed: i16) {
        let done = self.command(
            Action::MoveAbsolute { target, speed },
            Duration::from_secs(15),
        );
        assert_eq!(
            done,
            CommandProgress::Done {
                return_value: target
            },
            "the move to {target} at {speed}; notices: {:#?}",
            self.notices()
        );
    }

    /// Send `action` and wait for its final outcome.
    pub fn command(&mut self, action: Action, timeout: Duration) -> CommandProgress {
        let id = self.send(Request::Command(action));
        self.outcome(id, timeout)
    }

    fn keep(&mut self, event: Event) {
        if let Event::Samples(samples) = &event {
            for sample in samples {
                self.last = Some(match &self.last {
                    Some(older) => sample.merged_over(older),
                    None => *sample,
                });
            }
        }
        self.seen.push(event);
    }

    /// Wait for an event matching `want`, keeping every event seen on the way.
    pub fn wait(&mut self, what: &str, timeout: Duration, want: impl Fn(&Event) -> bool) -> Event {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.worker.recv_timeout(left) {
                Ok(event) => {
                    let hit = want(&event);
                    self.keep(event.clone());
                    if hit {
                        return event;
                    }
                }
                Err(_) => panic!(
                    "no {what} within {timeout:?}; the last sample: {:?}; seen: {:#?}",
                    self.last,
                    self.seen
                        .iter()
                        .filter(|e| !matches!(e, Event::Samples(_) | Event::Health(_)))
                        .collect::<Vec<_>>()
                ),
            }
        }
    }

    /// The final outcome of command `id`.
    pub fn outcome(&mut self, id: u64, timeout: Duration) -> CommandProgress {
        match self.wait(
            "the outcome",
            timeout,
            |e| matches!(e, Event::Progress { id: i, progress } if *i == id && progress.is_final()),
        ) {
            Event::Progress { progress, .. } => progress,
            _ => unreachable!(),
        }
    }

    /// Read one object through the worker.
    pub fn read(
        &mut self,
        address: Address,
        dtype: DataType,
        path: ObjectPath,
    ) -> Result<Value, ObjectError> {
        let id = self.send(Request::ReadObject {
            address,
            dtype: Some(dtype),
            path,
        });
        match self.wait(
            "the read",
            Duration::from_secs(5),
            |e| matches!(e, Event::ObjectRead { id: i, .. } if *i == id),
        ) {
            Event::ObjectRead { result, .. } => result,
            _ => unreachable!(),
        }
    }

    /// The vendor id, 1018h:01h, read over `path` (26Ch on the simulated drive).
    pub fn vendor_id(&mut self, path: ObjectPath) -> Result<Value, ObjectError> {
        self.read(Address::new(0x1018, 1), DataType::Unsigned32, path)
    }

    /// The device name, 1008h, read over `path`: a string, longer than one frame on most
    /// links ("drivedeck simulated drive" on the simulated drive).
    pub fn device_name(&mut self, path: ObjectPath) -> Result<Value, ObjectError> {
        self.read(Address::new(0x1008, 0), DataType::VisibleString, path)
    }

    /// Write one object through the worker.
    pub fn write(
        &mut self,
        address: Address,
        dtype: DataType,
        value: Value,
        path: ObjectPath,
    ) -> Result<(), ObjectError> {
        let id = self.send(Request::WriteObject {
            address,
            dtype,
            value,
            path,
        });
        self.written(id)
    }

    /// The result of write request `id`.
    pub fn written(&mut self, id: RequestId) -> Result<(), ObjectError> {
        match self.wait(
            "the write",
            Duration::from_secs(10),
            |e| matches!(e, Event::ObjectWritten { id: i, .. } if *i == id),
        ) {
            Event::ObjectWritten { result, .. } => result,
            _ => unreachable!(),
        }
    }

    /// Send a scan or a discovery and wait for what it found.
    pub fn scan(
        &mut self,
        request: Request,
        timeout: Duration,
    ) -> Result<Vec<FoundDevice>, LinkFailure> {
        let id = self.send(request);
        match self.wait(
            "the scan",
            timeout,
            |e| matches!(e, Event::Scanned { id: i, .. } if *i == id),
        ) {
            Event::Scanned { result, .. } => result,
            _ => unreachable!(),
        }
    }

    /// Wait until the link is lost (not disconnected by request): the reason.
    pub fn lost(&mut self, timeout: Duration) -> String {
        match self.wait("the link loss", timeout, |e| {
            matches!(e, Event::Disconnected { reason: Some(_) })
        }) {
            Event::Disconnected {
                reason: Some(reason),
            } => reason,
            _ => unreachable!(),
        }
    }

    /// Wait until the worker says it will try to connect again.
    pub fn retrying(&mut self, timeout: Duration) {
        self.wait("a retry", timeout, |e| {
            matches!(
                e,
                Event::ConnectFailed {
                    retry_in: Some(_),
                    ..
                }
            )
        });
    }

    /// Wait until the worker is connected (again): what the link says of itself.
    pub fn reconnected(&mut self, timeout: Duration) -> LinkInfo {
        match self.wait("the reconnection", timeout, |e| {
            matches!(e, Event::Connected(_))
        }) {
            Event::Connected(info) => info,
            _ => unreachable!(),
        }
    }

    /// The link dropped (or a reconnection under way) among the events after the first
    /// `from` (a connection that needed a second try is not the trouble under test).
    pub fn dropped_since(&self, from: usize) -> Option<&Event> {
        self.seen[from..]
            .iter()
            .find(|e| matches!(e, Event::Disconnected { .. } | Event::ConnectFailed { .. }))
    }

    /// The link was not dropped after the first `from` events.
    pub fn never_dropped_since(&self, from: usize) {
        let dropped = self.dropped_since(from);
        assert!(
            dropped.is_none(),
            "the link was dropped: {dropped:?}; notices: {:#?}",
            self.notices()
        );
    }

    /// The link was never dropped since the probe connected.
    pub fn never_dropped(&self) {
        self.never_dropped_since(0);
    }

    /// Every sample received so far, oldest first.
    pub fn samples(&self) -> Vec<Sample> {
        self.seen
            .iter()
            .filter_map(|e| match e {
                Event::Samples(s) => Some(s.clone()),
                _ => None,
            })
            .flatten()
            .collect()
    }

    /// Let events arrive for a while; the merged newest values afterwards.
    pub fn settle(&mut self, time: Duration) -> Sample {
        let until = Instant::now() + time;
        while Instant::now() < until {
            if let Ok(event) = self.worker.recv_timeout(Duration::from_millis(20)) {
                self.keep(event);
            }
        }
        self.last.expect("samples")
    }

    /// Wait for a sample that satisfies `want`; a loaded machine may need a few cycles
    /// more than a quiet one, so tests wait for what they assert on.
    pub fn sample_where(
        &mut self,
        what: &str,
        timeout: Duration,
        want: impl Fn(&Sample) -> bool,
    ) -> Sample {
        match self.wait(
            what,
            timeout,
            |e| matches!(e, Event::Samples(s) if s.iter().any(&want)),
        ) {
            Event::Samples(s) => *s.iter().rev().find(|x| want(x)).expect("matched"),
            _ => unreachable!(),
        }
    }

    /// A notice seen so far that says all of `words`.
    pub fn notice_with(&self, words: &[&str]) -> Option<String> {
        self.notices()
            .into_iter()
            .find(|n| words.iter().all(|w| n.contains(w)))
    }

    /// A notice that says all of `words`, seen already or coming within a few seconds.
    pub fn expect_notice(&mut self, words: &[&str]) -> String {
        if let Some(notice) = self.notice_with(words) {
            return notice;
        }
        match self.wait(
            &format!("a notice with {words:?}"),
            Duration::from_secs(5),
            |e| matches!(e, Event::Notice(n) if words.iter().all(|w| n.text.contains(w))),
        ) {
            Event::Notice(n) => n.text,
            _ => unreachable!(),
        }
    }

    /// The link counted as lost after exactly `lost_after` failed exchanges in a row, the
    /// drive having stopped answering at `cut` (each failed exchange takes at least
    /// `per_exchange`): the message says so and what was done to the drive, and the
    /// worker said when it would give up. The reason.
    pub fn lost_after_exactly(
        &mut self,
        lost_after: u32,
        cut: Instant,
        per_exchange: Duration,
    ) -> String {
        let reason = self.lost(Duration::from_secs(20));
        let took = cut.elapsed();
        assert!(
            reason.contains(&format!("{lost_after} exchanges failed in a row")),
            "{reason}"
        );
        assert!(reason.contains("no answer within"), "{reason}");
        assert!(
            reason.contains("halt"),
            "what was done to the drive: {reason}"
        );
        // Never sooner than the failed exchanges before the last could take.
        assert!(
            took >= per_exchange * (lost_after - 1),
            "lost after {took:?}"
        );
        let said = format!("the link counts as lost after {lost_after} failures in a row");
        assert!(
            self.notice_with(&[&said]).is_some(),
            "{:#?}",
            self.notices()
        );
        reason
    }

    /// The notices the worker has sent so far.
    pub fn notices(&self) -> Vec<String> {
        self.seen
            .iter()
            .filter_map(|e| match e {
                Event::Notice(n) => Some(n.text.clone()),
                _ => None,
            })
            .collect()
    }
}
