//! Faults: injections, the error history (1003h) and whether a fault's cause is still there.

use super::{Activity, Drive};
use crate::cia::{ErrorCode, HistoryEntry, PowerState};
use crate::injection::Injection;

impl Drive {
    /// Inject a condition of the drive. (Link conditions belong to the link: ignored.)
    pub fn inject(&mut self, injection: Injection) {
        if injection.is_link() {
            return;
        }
        self.injected.insert(injection);
        if !injection.is_reported() {
            // A condition of the machine (a broken wire): the inputs show it.
        } else if injection.is_fault() {
            self.raise_fault(
                injection.error_code(),
                injection.error_number(),
                injection.error_register(),
            );
        } else {
            self.warning = Some(injection.error_code());
            self.record_history(
                injection.error_code(),
                injection.error_number(),
                injection.error_register(),
            );
        }
        self.publish();
    }

    /// Withdraw an injected condition. A fault stays latched until Clear Error.
    pub fn withdraw(&mut self, injection: Injection) {
        self.injected.remove(&injection);
        if !injection.is_fault() && self.warning == Some(injection.error_code()) {
            self.warning = None;
        }
        self.publish();
    }

    /// The fieldbus master stopped talking (an EtherNet/IP I/O connection timed out): the
    /// drive stops and latches fault 8000h (fieldbus monitoring) with the communication
    /// bit in 1001h, until Clear Error.
    pub fn fieldbus_lost(&mut self) {
        self.raise_fault(ErrorCode::FIELDBUS_MONITORING, 0, 0x11);
        self.publish();
    }

    pub fn injected(&self) -> impl Iterator<Item = Injection> + '_ {
        self.injected.iter().copied()
    }

    pub(super) fn raise_fault(&mut self, code: ErrorCode, number: u8, register: u8) {
        self.state = PowerState::Fault;
        self.error_code = code;
        self.activity = Activity::Idle;
        self.halted = false;
        self.quick_stop = None;
        self.torque_demand = 0.0;
        self.record_history(code, number, register);
    }

    pub(super) fn record_history(&mut self, code: ErrorCode, number: u8, register: u8) {
        let count = self.od.int(0x1003, 0).clamp(0, 8) as u8;
        for sub in (1..8u8).rev() {
            let older = self.od.int(0x1003, sub);
            self.od.set_int(0x1003, sub + 1, older);
        }
        let entry = HistoryEntry {
            number,
            class: register,
            code,
        };
        self.od.set_int(0x1003, 1, i64::from(entry.to_raw()));
        self.od.set_int(0x1003, 0, i64::from((count + 1).min(8)));
        let reg = self.od.int(0x1001, 0) as u8 | register;
        self.od.set_int(0x1001, 0, i64::from(reg));
    }

    pub(super) fn fault_cause_present(&self) -> bool {
        self.injected.iter().any(|i| i.is_fault())
    }
}
