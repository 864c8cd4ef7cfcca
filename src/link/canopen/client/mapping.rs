//! The PDI's PDO mapping: what it changes is read first, the mapping written as spec
//! section 3 prescribes, and put back in a safe order on disconnect.

use super::{CanopenLink, EVENT_TIMER_MS, INHIBIT_100US, Saved};
use crate::link::canopen::CanBus;
use crate::link::{Error, Notice};
use crate::od::Address;
use crate::proto::canopen::pdo::{self, PdoComm, PdoKind, SdoWrite};

impl<B: CanBus> CanopenLink<B> {
    /// Read the current values of what the mapping will change, for the restore.
    pub(super) async fn save(&mut self, writes: &[SdoWrite]) -> Result<(), Error> {
        let mut saved = vec![];
        for w in writes {
            if saved
                .iter()
                .any(|s: &SdoWrite| s.index == w.index && s.sub == w.sub)
            {
                continue;
            }
            if let Ok(data) = self.sdo_upload(w.index, w.sub).await? {
                saved.push(SdoWrite {
                    index: w.index,
                    sub: w.sub,
                    data,
                });
            }
        }
        self.saved = Saved {
            writes: restore_order(saved),
        };
        Ok(())
    }

    /// Map the PDI RPDO and TPDO. `Ok(Err(reason))` when the drive refuses.
    pub(super) async fn map_pdi(&mut self) -> Result<Result<(), String>, Error> {
        let n = self.options.pdo;
        let node = self.options.node;
        let rx_comm = PdoComm {
            cob_id: u32::from(0x200 + 0x100 * u16::from(n - 1) + u16::from(node)),
            transmission: 255,
            inhibit_100us: 0,
            event_ms: 0,
        };
        let tx_comm = PdoComm {
            cob_id: u32::from(0x180 + 0x100 * u16::from(n - 1) + u16::from(node)),
            transmission: 255,
            inhibit_100us: INHIBIT_100US,
            event_ms: EVENT_TIMER_MS,
        };
        let configured =
            pdo::configure(PdoKind::Receive, u16::from(n), node, &rx_comm, &pdo::PDI_RX).and_then(
                |mut writes| {
                    writes.extend(pdo::configure(
                        PdoKind::Transmit,
                        u16::from(n),
                        node,
                        &tx_comm,
                        &pdo::PDI_TX,
                    )?);
                    Ok(writes)
                },
            );
        let writes = match configured {
            Ok(writes) => writes,
            Err(e) => return Ok(Err(e.to_string())),
        };
        self.save(&writes).await?;
        for w in writes {
            if let Err(code) = self.sdo_download(w.index, w.sub, &w.data).await? {
                return Ok(Err(format!(
                    "{} refused with {code}",
                    Address::new(w.index, w.sub)
                )));
            }
        }
        let rx = 0x1400 + u16::from(n - 1);
        let tx = 0x1800 + u16::from(n - 1);
        let keep = if self.options.keep_pdo {
            "kept after disconnecting (keep_pdo=1)"
        } else {
            "restored on disconnect"
        };
        self.notices.push(Notice::info(format!(
            "mapped the PDI: RPDO{n} ({rx:04X}h/{:04X}h, COB-ID {:03X}h) and TPDO{n} ({tx:04X}h/{:04X}h, COB-ID {:03X}h, event-driven, inhibit 2 ms, event timer {EVENT_TIMER_MS} ms); the previous mapping is {keep}",
            rx + 0x200,
            rx_comm.cob_id,
            tx + 0x200,
            tx_comm.cob_id
        )));
        Ok(Ok(()))
    }

    /// Master-less setup (spec 3.1): 1F80h = 08h, the node starts by itself after a
    /// reset; the old value is kept with the mapping's for the restore.
    pub(super) async fn start_by_itself(&mut self) -> Result<(), Error> {
        let old = self.sdo_upload(0x1F80, 0).await?;
        match self
            .sdo_download(0x1F80, 0, &0x08u32.to_le_bytes())
            .await?
        {
            Ok(()) => {
                if let Ok(data) = old {
                    self.saved.writes.push(SdoWrite {
                        index: 0x1F80,
                        sub: 0,
                        data,
                    });
                }
                self.notices.push(Notice::info(format!(
                    "set 1F80h = 08h on node {}: it starts by itself after a reset (master-less); {}",
                    self.options.node,
                    if self.options.keep_pdo {
                        "kept after disconnecting (keep_pdo=1)"
                    } else {
                        "put back on disconnect"
                    }
                )));
            }
            Err(code) => self.notices.push(Notice::info(format!(
                "node {} refused 1F80h = 08h ({code}): it needs an NMT start from a master after each reset",
                self.options.node
            ))),
        }
        Ok(())
    }

    /// Put the saved mapping back; the writes the node refused, named (with their abort).
    pub(super) async fn restore(&mut self) -> Result<Vec<String>, Error> {
        let writes = std::mem::take(&mut self.saved.writes);
        let mut refused = vec![];
        for w in writes {
            if let Err(code) = self.sdo_download(w.index, w.sub, &w.data).await? {
                refused.push(format!("{}: abort {code}", Address::new(w.index, w.sub)));
            }
        }
        Ok(refused)
    }
}

/// The saved communication and mapping values, in the order that puts them back safely:
/// each PDO invalid first, its mapping count 0, the entries, the count, the parameters, and
/// its original COB-ID last (CiA 301, protocol notes §2.3).
pub(super) fn restore_order(saved: Vec<SdoWrite>) -> Vec<SdoWrite> {
    let mut out = vec![];
    let comm_indices: Vec<u16> = {
        let mut v: Vec<u16> = saved
            .iter()
            .filter(|w| (0x1400..0x1600).contains(&w.index) || (0x1800..0x1A00).contains(&w.index))
            .map(|w| w.index)
            .collect();
        v.dedup();
        v
    };
    let find = |index: u16, sub: u8| {
        saved
            .iter()
            .find(|w| w.index == index && w.sub == sub)
            .cloned()
    };
    for comm in comm_indices {
        let mapping = comm + 0x200;
        let cob = find(comm, 1);
        if let Some(cob) = &cob {
            let raw = u32::from_le_bytes(
                cob.data
                    .get(..4)
                    .and_then(|b| b.try_into().ok())
                    .unwrap_or([0; 4]),
            );
            out.push(SdoWrite::u32(comm, 1, raw | pdo::COB_INVALID));
        }
        out.push(SdoWrite::u8(mapping, 0, 0));
        let count = find(mapping, 0)
            .and_then(|w| w.data.first().copied())
            .unwrap_or(0);
        for sub in 1..=count.min(8) {
            if let Some(entry) = find(mapping, sub) {
                out.push(entry);
            }
        }
        if let Some(count) = find(mapping, 0) {
            out.push(count);
        }
        for sub in [2u8, 3, 5] {
            if let Some(parameter) = find(comm, sub) {
                out.push(parameter);
            }
        }
        if let Some(cob) = cob {
            out.push(cob);
        }
    }
    // Everything else (1F80h) after the PDOs.
    out.extend(saved.iter().filter(|w| !is_pdo_object(w.index)).cloned());
    out
}

/// PDO communication (1400h-15FFh, 1800h-19FFh) and mapping (1600h-17FFh, 1A00h-1BFFh).
pub(super) fn is_pdo_object(index: u16) -> bool {
    (0x1400..0x1C00).contains(&index)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    pub(super) fn restore_puts_the_cob_id_back_last_and_invalidates_first() {
        let saved = vec![
            SdoWrite::u32(0x1400, 1, 0x0000_0201),
            SdoWrite::u8(0x1600, 0, 2),
            SdoWrite::u32(0x1600, 1, 0x6040_0010),
            SdoWrite::u32(0x1600, 2, 0x6060_0008),
            SdoWrite::u8(0x1400, 2, 255),
        ];
        let order = restore_order(saved);
        let shown: Vec<String> = order.iter().map(|w| w.to_string()).collect();
        assert_eq!(
            shown,
            [
                "1400h:01h = 80000201h",
                "1600h:00h = 00h",
                "1600h:01h = 60400010h",
                "1600h:02h = 60600008h",
                "1600h:00h = 02h",
                "1400h:02h = FFh",
                "1400h:01h = 00000201h",
            ]
        );
    }
}
