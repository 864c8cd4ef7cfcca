//! Class 1 I/O datagrams (protocol notes §3.5): UDP packets of two CPF items, the sequenced
//! address (connection id, encapsulation sequence number) and the connected data (CIP
//! sequence count, the 32-bit run/idle header where the direction has one, the assembly).

use super::cpf::{self, Item};
use std::time::{Duration, Instant};

use super::wire::{DecodeError, Put, Reader};

/// Bytes a class 1 packet adds to the assembly: the 16-bit sequence count.
pub const SEQUENCE_COUNT_LEN: u16 = 2;
/// Bytes of the run/idle header.
pub const RUN_IDLE_LEN: u16 = 4;

/// The connection size to ask for in Forward_Open: assembly, sequence count, header.
pub fn connection_size(assembly: u16, run_idle: bool) -> u16 {
    assembly + SEQUENCE_COUNT_LEN + if run_idle { RUN_IDLE_LEN } else { 0 }
}

/// One class 1 packet.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct IoPacket {
    pub connection: u32,
    /// Encapsulation sequence number: +1 per packet sent.
    pub sequence: u32,
    /// CIP sequence count: +1 when the data is new.
    pub count: u16,
    /// The run/idle header: `Some(true)` run, `Some(false)` idle, `None` without header
    /// (modeless, as the T→O direction of Nanotec drives).
    pub run: Option<bool>,
    pub data: Vec<u8>,
}

impl IoPacket {
    pub fn encode(&self) -> Vec<u8> {
        let mut payload = Vec::with_capacity(6 + self.data.len());
        payload.put_u16(self.count);
        if let Some(run) = self.run {
            payload.put_u32(u32::from(run));
        }
        payload.extend_from_slice(&self.data);
        let mut out = Vec::with_capacity(24 + payload.len());
        cpf::encode(
            &[
                Item::SequencedAddress {
                    connection: self.connection,
                    sequence: self.sequence,
                },
                Item::ConnectedData(payload),
            ],
            &mut out,
        );
        out
    }

    /// A datagram of a connection whose packets do (`run_idle`) or do not carry the header.
    pub fn decode(bytes: &[u8], run_idle: bool) -> Result<IoPacket, DecodeError> {
        let items = cpf::decode(bytes)?;
        let (connection, sequence) = items
            .iter()
            .find_map(|i| match i {
                Item::SequencedAddress {
                    connection,
                    sequence,
                } => Some((*connection, *sequence)),
                _ => None,
            })
            .ok_or_else(|| DecodeError::invalid("class 1 packet", "no sequenced address item"))?;
        let payload = items
            .iter()
            .find_map(|i| match i {
                Item::ConnectedData(d) => Some(d.as_slice()),
                _ => None,
            })
            .ok_or_else(|| DecodeError::invalid("class 1 packet", "no connected data item"))?;
        let mut r = Reader::new("class 1 data", payload);
        let count = r.u16("sequence count")?;
        let run = if run_idle {
            Some(r.u32("run/idle header")? & 1 == 1)
        } else {
            None
        };
        Ok(IoPacket {
            connection,
            sequence,
            count,
            run,
            data: r.rest().to_vec(),
        })
    }

    /// The connection id alone, to route a datagram before decoding it in full.
    pub fn connection_of(bytes: &[u8]) -> Option<u32> {
        cpf::decode(bytes).ok()?.iter().find_map(|i| match i {
            Item::SequencedAddress { connection, .. } => Some(*connection),
            _ => None,
        })
    }
}

/// `a` comes after `b` in serial-number arithmetic on 32 bits: less than half the number
/// space ahead, so the encapsulation sequence number may wrap (protocol notes §3.5).
pub fn sequence_after(a: u32, b: u32) -> bool {
    (a.wrapping_sub(b) as i32) > 0
}

/// What a datagram's encapsulation sequence number says about it, against the newest one
/// taken on its connection (protocol notes §3.5).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Arrival {
    /// Newer than any before: its data is the current image.
    Newest,
    /// The same number as the newest: a copy, dropped.
    Duplicate,
    /// Older than the newest: it came out of order, its image is stale, dropped.
    OutOfOrder,
}

/// The consumer's side of one connection's sequence numbers: only a datagram newer than
/// every one before carries the current image (protocol notes §3.5).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Newest {
    sequence: Option<u32>,
}

impl Newest {
    /// Judge a datagram's sequence number, remembering it when it is the newest. The
    /// first datagram of a connection is the newest, whatever its number.
    pub fn arrive(&mut self, sequence: u32) -> Arrival {
        match self.sequence {
            Some(newest) if sequence == newest => Arrival::Duplicate,
            Some(newest) if !sequence_after(sequence, newest) => Arrival::OutOfOrder,
            _ => {
                self.sequence = Some(sequence);
                Arrival::Newest
            }
        }
    }

    /// The newest sequence number taken so far.
    pub fn sequence(&self) -> Option<u32> {
        self.sequence
    }
}

/// The production schedule of one direction of a class 1 connection: absolute deadlines
/// `start + k × RPI`, so a late wake-up shortens the next wait instead of pushing every
/// later packet back (no drift), and a wake-up later than a whole RPI skips the slots it
/// missed instead of sending a burst to catch up. Sans-IO: the caller reads the clock.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Schedule {
    next: Instant,
    period: Duration,
}

impl Schedule {
    /// The first packet is due at `start`. A zero period is taken as 1 µs.
    pub fn new(start: Instant, period: Duration) -> Schedule {
        Schedule {
            next: start,
            period: period.max(Duration::from_micros(1)),
        }
    }

    /// When the next packet is due.
    pub fn due(&self) -> Instant {
        self.next
    }

    pub fn period(&self) -> Duration {
        self.period
    }

    /// A packet was sent at `now` (at or after [`Schedule::due`]): the next one is due one
    /// period after the slot just served, or at the first slot still ahead of `now` when
    /// whole periods were missed. Returns how many slots were skipped.
    pub fn sent(&mut self, now: Instant) -> u32 {
        self.next += self.period;
        if self.next > now {
            return 0;
        }
        let behind = now - self.next;
        let skipped = (behind.as_nanos() / self.period.as_nanos()) as u32 + 1;
        self.next += self.period * skipped;
        skipped
    }
}

/// Percentiles of a set of intervals (nearest rank on the sorted values): p50, p99, max.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Spread {
    pub count: usize,
    pub p50: Duration,
    pub p99: Duration,
    pub max: Duration,
}

impl Spread {
    pub fn of(intervals: &[Duration]) -> Spread {
        let mut sorted = intervals.to_vec();
        sorted.sort_unstable();
        let at = |q: f64| {
            sorted
                .get(((sorted.len() as f64 - 1.0) * q).round() as usize)
                .copied()
                .unwrap_or_default()
        };
        Spread {
            count: sorted.len(),
            p50: at(0.5),
            p99: at(0.99),
            max: at(1.0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_schedule_keeps_absolute_deadlines_and_skips_what_it_missed() {
        let t0 = Instant::now();
        let ms = Duration::from_millis;
        let mut s = Schedule::new(t0, ms(2));
        assert_eq!(s.due(), t0);
        // Woken 0.5 ms late: the next slot stays at 2 ms, not 2.5.
        assert_eq!(s.sent(t0 + Duration::from_micros(500)), 0);
        assert_eq!(s.due(), t0 + ms(2));
        assert_eq!(s.sent(t0 + ms(2)), 0);
        assert_eq!(s.due(), t0 + ms(4));
        // The packet due at 4 went at 7: slot 6 is skipped, the next is 8 (no burst).
        assert_eq!(s.sent(t0 + ms(7)), 1);
        assert_eq!(s.due(), t0 + ms(8));
        // Exactly on a slot boundary: that slot is gone, the next one is ahead.
        assert_eq!(s.sent(t0 + ms(10)), 1);
        assert_eq!(s.due(), t0 + ms(12));
        assert!(s.due() > t0 + ms(10));
    }

    #[test]
    fn the_spread_of_intervals() {
        let ms = Duration::from_millis;
        let mut v: Vec<Duration> = (0..100).map(|_| ms(1)).collect();
        v[37] = ms(9);
        let s = Spread::of(&v);
        assert_eq!((s.count, s.p50, s.p99, s.max), (100, ms(1), ms(1), ms(9)));
        v[38] = ms(5);
        assert_eq!(Spread::of(&v).p99, ms(5));
        assert_eq!(Spread::of(&[]), Spread::default());
    }

    #[test]
    fn the_newest_datagram_by_sequence_number_wrapping_included() {
        let mut newest = Newest::default();
        assert_eq!(
            newest.arrive(7),
            Arrival::Newest,
            "the first, whatever it is"
        );
        assert_eq!(newest.arrive(8), Arrival::Newest);
        assert_eq!(newest.arrive(8), Arrival::Duplicate);
        assert_eq!(newest.arrive(6), Arrival::OutOfOrder);
        // One lost: a gap is no reason to drop the next.
        assert_eq!(newest.arrive(10), Arrival::Newest);
        assert_eq!(newest.arrive(9), Arrival::OutOfOrder);
        assert_eq!(newest.sequence(), Some(10));
        // Across the wrap: 0 comes after FFFFFFFFh, FFFFFFFEh does not after 1.
        let mut newest = Newest::default();
        assert_eq!(newest.arrive(u32::MAX - 1), Arrival::Newest);
        assert_eq!(newest.arrive(u32::MAX), Arrival::Newest);
        assert_eq!(newest.arrive(0), Arrival::Newest);
        assert_eq!(newest.arrive(1), Arrival::Newest);
        assert_eq!(newest.arrive(u32::MAX - 1), Arrival::OutOfOrder);
        assert_eq!(newest.arrive(u32::MAX), Arrival::OutOfOrder);
        assert_eq!(newest.arrive(1), Arrival::Duplicate);
        assert!(sequence_after(0x8000_0000, 1));
        assert!(
            !sequence_after(0x8000_0001, 1),
            "half the space ahead is behind"
        );
    }

    #[test]
    fn the_ot_packet_of_the_pdi_set_byte_for_byte() {
        let packet = IoPacket {
            connection: 0x1000_0001,
            sequence: 5,
            count: 3,
            run: Some(true),
            data: vec![0xD0, 0x07, 0, 0, 0xC8, 0x00, 0x00, 0x14],
        };
        let bytes = packet.encode();
        assert_eq!(
            bytes,
            [
                0x02, 0x00, // item count
                0x02, 0x80, 0x08, 0x00, 0x01, 0x00, 0x00, 0x10, 0x05, 0x00, 0x00,
                0x00, // sequenced address
                0xB1, 0x00, 0x0E, 0x00, // connected data, 2 + 4 + 8 bytes
                0x03, 0x00, // sequence count
                0x01, 0x00, 0x00, 0x00, // run
                0xD0, 0x07, 0x00, 0x00, 0xC8, 0x00, 0x00, 0x14,
            ]
        );
        assert_eq!(IoPacket::decode(&bytes, true), Ok(packet));
        assert_eq!(IoPacket::connection_of(&bytes), Some(0x1000_0001));
        assert_eq!(connection_size(8, true), 14);
        assert_eq!(connection_size(8, false), 10);
    }

    #[test]
    fn modeless_and_idle_packets() {
        let to = IoPacket {
            connection: 7,
            sequence: 1,
            count: 1,
            run: None,
            data: vec![0x37, 0x16, 0, 0, 0xD0, 0x07, 0, 0],
        };
        let bytes = to.encode();
        assert_eq!(bytes.len(), 2 + 12 + 4 + 2 + 8);
        assert_eq!(IoPacket::decode(&bytes, false), Ok(to));
        let idle = IoPacket {
            connection: 7,
            sequence: 2,
            count: 2,
            run: Some(false),
            data: vec![],
        };
        assert_eq!(IoPacket::decode(&idle.encode(), true), Ok(idle));
        assert!(IoPacket::decode(&[0x01, 0x00, 0xB1, 0x00, 0x00, 0x00], false).is_err());
        assert!(IoPacket::decode(&[], false).is_err());
    }
}
