//! The table reads the rows on screen by itself: those never read, and those read longer
//! than [`REFRESH_AFTER`] ago, a few at a time. At most [`REFRESH_IN_FLIGHT`] such objects
//! wait for the drive at once and a batch goes out at most every [`REFRESH_INTERVAL`], so
//! the worker's queues (`JOB_QUEUE`, `BULK_QUEUE` in `worker::jobs`) never fill with them
//! and a slow link simply reads them more slowly. Writes and restores read back the
//! objects they wrote the same way (not rate-limited: they are as many as were written).

use std::collections::BTreeMap;

use super::*;

/// Objects the table reads by itself that may wait for the drive at once.
pub const REFRESH_IN_FLIGHT: usize = 8;
/// Seconds between two batches of reads the table makes by itself, at least.
pub const REFRESH_INTERVAL: f64 = 0.25;
/// A row on screen whose value is older than this (seconds) is read again.
pub const REFRESH_AFTER: f64 = 5.0;
/// How long (seconds) a changed value stays highlighted, fading.
pub const CHANGED_FOR: f64 = 4.0;
/// A read not answered after this long (seconds) is given up (a link that went away).
const GIVE_UP_AFTER: f64 = 10.0;

/// The reads outside the bulk one that wait for the drive.
#[derive(Clone, Debug, Default)]
pub struct Refresh {
    /// Each object asked for and not answered yet, with when it was asked.
    in_flight: BTreeMap<Address, f64>,
    /// When the table last sent a batch by itself.
    last_batch: Option<f64>,
    /// How many batches the table sent by itself so far.
    pub batches: usize,
}

impl Refresh {
    /// How many objects wait for the drive.
    pub fn in_flight(&self) -> usize {
        self.in_flight.len()
    }

    pub(super) fn arrived(&mut self, address: Address) {
        self.in_flight.remove(&address);
    }

    pub(super) fn forget(&mut self, addresses: impl Iterator<Item = Address>) {
        for address in addresses {
            self.in_flight.remove(&address);
        }
    }

    pub(super) fn forget_all(&mut self) {
        self.in_flight.clear();
    }
}

impl Browser {
    /// Read `objects` outside the bulk read, each answer into its row.
    pub(super) fn read_back(
        &mut self,
        outbox: &mut Vec<Request>,
        objects: Vec<(Address, DataType)>,
    ) {
        if objects.is_empty() {
            return;
        }
        for (address, _) in &objects {
            self.refresh.in_flight.insert(*address, self.now);
        }
        let count = objects.len();
        self.send(
            outbox,
            Request::ReadMany {
                objects,
                path: ObjectPath::Auto,
            },
            Pending::Refresh(count),
        );
    }

    /// After a restore: read every object it wrote, so the rows show what the drive holds.
    pub(super) fn read_back_restored(&mut self, outbox: &mut Vec<Request>) {
        let Some(restore) = &self.restore else {
            return;
        };
        let mut objects: Vec<(Address, DataType)> = vec![];
        for step in &restore.steps {
            let readable = self
                .catalog()
                .get(step.address)
                .is_some_and(|e| e.access.readable());
            if readable && !objects.iter().any(|(a, _)| *a == step.address) {
                objects.push((step.address, step.dtype));
            }
        }
        self.read_back(outbox, objects);
    }

    /// The rows on screen due for a read, as many as may go now. Nothing while a bulk read
    /// or a restore runs (they read and write themselves) or without a link.
    pub(super) fn refresh_visible(&mut self, outbox: &mut Vec<Request>, connected: bool) {
        let now = self.now;
        if !connected {
            self.refresh.forget_all();
            return;
        }
        self.refresh
            .in_flight
            .retain(|_, asked| now - *asked < GIVE_UP_AFTER);
        let busy = self.bulk.is_some() || self.restore.as_ref().is_some_and(|r| r.running);
        let resting = self
            .refresh
            .last_batch
            .is_some_and(|at| now - at < REFRESH_INTERVAL);
        let room = REFRESH_IN_FLIGHT.saturating_sub(self.refresh.in_flight.len());
        if busy || resting || room == 0 {
            return;
        }
        let due = self.due(room);
        if due.is_empty() {
            return;
        }
        self.refresh.last_batch = Some(now);
        self.refresh.batches += 1;
        self.read_back(outbox, due);
    }

    /// The readable rows on screen not read yet, then those read longest ago (beyond
    /// [`REFRESH_AFTER`]), at most `room`, none already asked for.
    fn due(&self, room: usize) -> Vec<(Address, DataType)> {
        let mut due: Vec<(f64, Address, DataType)> = self
            .visible
            .iter()
            .filter_map(|a| self.catalog().get(*a))
            .filter(|e| e.access.readable() && !self.refresh.in_flight.contains_key(&e.address))
            .filter_map(|e| match self.values.get(&e.address) {
                None => Some((f64::NEG_INFINITY, e.address, e.dtype)),
                Some(cell) if self.now - cell.at >= REFRESH_AFTER => {
                    Some((cell.at, e.address, e.dtype))
                }
                Some(_) => None,
            })
            .collect();
        due.sort_by(|a, b| a.0.total_cmp(&b.0));
        due.into_iter()
            .take(room)
            .map(|(_, address, dtype)| (address, dtype))
            .collect()
    }
}

/// How strongly a value changed `age` seconds ago is highlighted: 1 at once, fading to 0
/// after [`CHANGED_FOR`].
pub(super) fn change_glow(age: f64) -> f32 {
    if (0.0..CHANGED_FOR).contains(&age) {
        (1.0 - age / CHANGED_FOR) as f32
    } else {
        0.0
    }
}
