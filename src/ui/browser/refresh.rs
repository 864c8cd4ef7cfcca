//! The table reads the rows on screen by itself: those never read, and those read longer
//! than [`REFRESH_AFTER`] ago, at most [`DictionarySettings::reads_per_second`] objects a
//! second (a bucket of [`REFRESH_IN_FLIGHT`] reads that fills at that rate), and never more
//! than [`REFRESH_IN_FLIGHT`] waiting for the drive at once, so the worker's queues
//! (`JOB_QUEUE`, `BULK_QUEUE` in `worker::jobs`) never fill with them and a slow link simply
//! reads them more slowly. Writes and restores read back the objects they wrote the same
//! way (not rate-limited: they are as many as were written).
//!
//! A model: no egui here.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::{Browser, Pending};
use crate::od::{Address, DataType};
use crate::worker::{ObjectPath, Request};

/// Objects the table reads by itself that may wait for the drive at once, and how many it
/// may read in one go after a pause.
pub const REFRESH_IN_FLIGHT: usize = 8;
/// A row on screen whose value is older than this (seconds) is read again.
pub const REFRESH_AFTER: f64 = 5.0;
/// How long (seconds) a changed value stays highlighted, fading.
pub const CHANGED_FOR: f64 = 4.0;
/// A read not answered after this long (seconds) is given up (a link that went away).
const GIVE_UP_AFTER: f64 = 10.0;
/// The most the reads-per-second box takes.
pub const MOST_READS_PER_SECOND: f64 = 200.0;

/// The dictionary's choices kept with the window's settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct DictionarySettings {
    /// How many objects a second the table reads by itself; 0: it reads none.
    pub reads_per_second: f64,
}

impl Default for DictionarySettings {
    fn default() -> Self {
        Self {
            reads_per_second: 20.0,
        }
    }
}

/// The reads outside the bulk one that wait for the drive.
#[derive(Clone, Debug, Default)]
pub struct Refresh {
    /// Each object asked for and not answered yet, with when it was asked.
    in_flight: BTreeMap<Address, f64>,
    /// Reads the table may make by itself now, and when that was counted.
    allowance: Option<(f64, f64)>,
    /// How many objects the table asked for by itself so far.
    pub sent: usize,
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
    /// Read `objects` outside the bulk read, each answer into its row; `asked` by the
    /// user (a refusal of the request is said), or by the table itself.
    pub(super) fn read_back(&mut self, objects: Vec<(Address, DataType)>, asked: bool) {
        if objects.is_empty() {
            return;
        }
        for (address, _) in &objects {
            self.refresh.in_flight.insert(*address, self.now);
        }
        let count = objects.len();
        self.send(
            Request::ReadMany {
                objects,
                path: ObjectPath::Auto,
            },
            Pending::Refresh { left: count, asked },
        );
    }

    /// After a restore: read every object it wrote, so the rows show what the drive holds.
    pub(super) fn read_back_restored(&mut self) {
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
        self.read_back(objects, true);
    }

    /// The rows on screen due for a read, as many as may go now at `rate` objects a
    /// second. Nothing while a bulk read or a restore runs (they read and write
    /// themselves) or without a link.
    pub(super) fn refresh_visible(&mut self, connected: bool, rate: f64) {
        let now = self.now;
        if !connected || rate <= 0.0 {
            self.refresh.forget_all();
            self.refresh.allowance = None;
            return;
        }
        self.refresh
            .in_flight
            .retain(|_, asked| now - *asked < GIVE_UP_AFTER);
        let burst = REFRESH_IN_FLIGHT as f64;
        let allowance = match self.refresh.allowance {
            None => burst,
            Some((at, left)) => (left + (now - at).max(0.0) * rate).min(burst),
        };
        self.refresh.allowance = Some((now, allowance));
        let busy = self.bulk.is_some() || self.restore.as_ref().is_some_and(|r| r.running);
        let room = REFRESH_IN_FLIGHT
            .saturating_sub(self.refresh.in_flight.len())
            .min(allowance.floor() as usize);
        if busy || room == 0 {
            return;
        }
        let due = self.due(room);
        if due.is_empty() {
            return;
        }
        self.refresh.allowance = Some((now, allowance - due.len() as f64));
        self.refresh.sent += due.len();
        self.read_back(due, false);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::od::Value;

    /// A browser showing the first `rows` readable objects of the built-in catalog.
    fn showing(rows: usize) -> Browser {
        let mut b = Browser::new();
        b.visible = crate::od::builtin()
            .filter("")
            .filter(|e| e.access.readable())
            .take(rows)
            .map(|e| e.address)
            .collect();
        b
    }

    /// Every read asked for answered at once.
    fn answer_all(b: &mut Browser) {
        for (_, request) in b.take_asks() {
            if let Request::ReadMany { objects, .. } = request {
                for (address, _) in objects {
                    b.refresh.arrived(address);
                    b.store_value(address, Ok(Value::Uint(1)), b.now);
                }
            }
        }
    }

    #[test]
    fn the_rows_on_screen_are_read_no_faster_than_the_rate() {
        let rate = 10.0;
        let mut b = showing(40);
        let mut t = 0.0;
        while t < 6.0 {
            b.now = t;
            b.refresh_visible(true, rate);
            assert!(b.refresh.in_flight() <= REFRESH_IN_FLIGHT);
            answer_all(&mut b);
            let allowed = REFRESH_IN_FLIGHT as f64 + rate * t;
            assert!(
                b.refresh.sent as f64 <= allowed + 1e-9,
                "{} at {t}",
                b.refresh.sent
            );
            t += 0.01;
        }
        // 40 rows at 10 a second (8 at once to start with): all read after 3.2 s, none
        // again before they are REFRESH_AFTER old.
        assert!(b.visible.iter().all(|a| b.values.contains_key(a)));
        assert!(
            b.refresh.sent >= 40 && b.refresh.sent < 40 + 2 * 10,
            "{}",
            b.refresh.sent
        );
    }

    #[test]
    fn nothing_is_read_by_itself_at_rate_zero_or_without_a_link() {
        let mut b = showing(10);
        b.now = 1.0;
        b.refresh_visible(true, 0.0);
        b.refresh_visible(false, 10.0);
        assert!(b.take_asks().is_empty());
        assert_eq!(b.refresh.sent, 0);
    }

    #[test]
    fn rows_read_longer_ago_than_refresh_after_are_read_again() {
        let mut b = showing(3);
        b.refresh_visible(true, 100.0);
        answer_all(&mut b);
        assert_eq!(b.refresh.sent, 3);
        b.now = REFRESH_AFTER / 2.0;
        b.refresh_visible(true, 100.0);
        assert!(b.take_asks().is_empty(), "fresh");
        b.now = REFRESH_AFTER;
        b.refresh_visible(true, 100.0);
        assert_eq!(b.refresh.sent, 6, "read again");
    }

    #[test]
    fn a_value_that_differs_from_the_one_before_is_marked() {
        let mut b = showing(1);
        let address = b.visible[0];
        b.store_value(address, Ok(Value::Uint(1)), 1.0);
        assert_eq!(
            b.values[&address].changed, None,
            "the first read changes nothing"
        );
        b.store_value(address, Ok(Value::Uint(1)), 2.0);
        assert_eq!(b.values[&address].changed, None);
        b.store_value(address, Ok(Value::Uint(2)), 3.0);
        assert_eq!(b.values[&address].changed, Some((3.0, Value::Uint(1))));
        assert!(change_glow(0.0) > change_glow(CHANGED_FOR / 2.0));
        assert_eq!(change_glow(CHANGED_FOR), 0.0);
    }
}
