//! A test's view of the worker thread: send requests, wait for the events a window would
//! see, and keep every event for the failure message. Shared by the end-to-end tests of
//! every link (`mod probe;`).

#![allow(dead_code)]

use std::sync::Arc;
use std::time::{Duration, Instant};

use drivedeck::link::LinkSpec;
use drivedeck::od::{Address, DataType, Value};
use drivedeck::worker::{
    CommandProgress, Config, Event, ObjectError, ObjectPath, Request, Sample, Worker,
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

    /// A worker connected to `spec`, with its first sample in.
    pub fn connected(spec: LinkSpec) -> Probe {
        let mut probe = Probe::new();
        probe.send(Request::Connect(spec));
        probe.wait("connected", Duration::from_secs(10), |e| {
            matches!(e, Event::Connected(_))
        });
        probe.wait(
            "a sample",
            Duration::from_secs(5),
            |e| matches!(e, Event::Samples(s) if !s.is_empty()),
        );
        probe
    }

    pub fn send(&self, request: Request) -> u64 {
        self.worker.send(request).expect("request queued")
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
