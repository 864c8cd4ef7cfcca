//! NMT (CiA 301): the module-control command, the heartbeat / boot-up frame, and the COB-IDs
//! of the predefined connection set (protocol notes §2.2 to §2.4). Sans-IO: frames in, values out.
//!
//! ```text
//! NMT command   000h  [cs, node]      cs: 01 start, 02 stop, 80h pre-op, 81h reset node,
//!                                         82h reset communication; node 0 = all nodes
//! heartbeat     700h+node  [state]    00 boot-up, 04 stopped, 05 operational, 7Fh pre-op
//! ```

use std::fmt;

use super::CanFrame;

/// A standard (11-bit) data frame; see [`CanFrame::standard`].
pub(crate) fn data_frame(cob_id: u16, data: &[u8]) -> CanFrame {
    CanFrame::standard(cob_id, data)
}

/// COB-IDs of the CiA 301 predefined connection set (protocol notes §2.2 to §2.4).
///
/// Node-IDs are 1..=127 on CANopen. The helpers do not check that (every `u8` gives an 11-bit
/// identifier, so nothing overflows); [`classify`](super::classify) only recognises 1..=127.
pub mod cob {
    /// NMT module control (master → all nodes).
    pub const NMT: u16 = 0x000;
    /// SYNC.
    pub const SYNC: u16 = 0x080;
    /// TIME stamp (not used by drivedeck, named for the classifier).
    pub const TIME: u16 = 0x100;

    /// Emergency of a node: 80h + node (1014h).
    pub const fn emcy(node: u8) -> u16 {
        0x080 + node as u16
    }

    /// TPDO `n` (1..=4) of a node: 180h/280h/380h/480h + node. `None` for other `n`: PDOs
    /// beyond 4 have no predefined COB-ID.
    pub const fn tpdo(n: u8, node: u8) -> Option<u16> {
        match n {
            1..=4 => Some(0x080 + 0x100 * n as u16 + node as u16),
            _ => None,
        }
    }

    /// RPDO `n` (1..=4) of a node: 200h/300h/400h/500h + node. `None` for other `n`.
    pub const fn rpdo(n: u8, node: u8) -> Option<u16> {
        match n {
            1..=4 => Some(0x100 + 0x100 * n as u16 + node as u16),
            _ => None,
        }
    }

    /// SDO server → client (responses): 580h + node.
    pub const fn sdo_tx(node: u8) -> u16 {
        0x580 + node as u16
    }

    /// SDO client → server (requests): 600h + node.
    pub const fn sdo_rx(node: u8) -> u16 {
        0x600 + node as u16
    }

    /// Heartbeat, boot-up and node guarding: 700h + node.
    pub const fn heartbeat(node: u8) -> u16 {
        0x700 + node as u16
    }
}

/// What a COB-ID is in the predefined connection set.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Cob {
    Nmt,
    Sync,
    Emcy {
        node: u8,
    },
    Tpdo {
        n: u8,
        node: u8,
    },
    Rpdo {
        n: u8,
        node: u8,
    },
    /// 580h + node: the server's answer.
    SdoResponse {
        node: u8,
    },
    /// 600h + node: the client's request.
    SdoRequest {
        node: u8,
    },
    Heartbeat {
        node: u8,
    },
    /// TIME, LSS, node-ID 0 or above 127, or anything outside the predefined set.
    Other,
}

/// Classify an 11-bit COB-ID by the predefined connection set (protocol notes §2.3).
/// Node-IDs outside 1..=127 give [`Cob::Other`].
pub fn classify(cob_id: u16) -> Cob {
    if cob_id == cob::NMT {
        return Cob::Nmt;
    }
    if cob_id == cob::SYNC {
        return Cob::Sync;
    }
    let function = cob_id & 0x780;
    let node = (cob_id & 0x7F) as u8;
    if node == 0 {
        return Cob::Other;
    }
    match function {
        0x080 => Cob::Emcy { node },
        0x180 => Cob::Tpdo { n: 1, node },
        0x280 => Cob::Tpdo { n: 2, node },
        0x380 => Cob::Tpdo { n: 3, node },
        0x480 => Cob::Tpdo { n: 4, node },
        0x200 => Cob::Rpdo { n: 1, node },
        0x300 => Cob::Rpdo { n: 2, node },
        0x400 => Cob::Rpdo { n: 3, node },
        0x500 => Cob::Rpdo { n: 4, node },
        0x580 => Cob::SdoResponse { node },
        0x600 => Cob::SdoRequest { node },
        0x700 => Cob::Heartbeat { node },
        _ => Cob::Other,
    }
}

/// An NMT module-control command specifier (protocol notes §2.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum NmtCommand {
    Start = 0x01,
    Stop = 0x02,
    EnterPreOperational = 0x80,
    ResetNode = 0x81,
    ResetCommunication = 0x82,
}

impl NmtCommand {
    pub const ALL: [NmtCommand; 5] = [
        NmtCommand::Start,
        NmtCommand::Stop,
        NmtCommand::EnterPreOperational,
        NmtCommand::ResetNode,
        NmtCommand::ResetCommunication,
    ];

    pub fn from_u8(cs: u8) -> Option<Self> {
        Self::ALL.into_iter().find(|c| *c as u8 == cs)
    }

    /// For the frame log: "start", "enter pre-operational", …
    pub fn name(self) -> &'static str {
        match self {
            NmtCommand::Start => "start",
            NmtCommand::Stop => "stop",
            NmtCommand::EnterPreOperational => "enter pre-operational",
            NmtCommand::ResetNode => "reset node",
            NmtCommand::ResetCommunication => "reset communication",
        }
    }
}

impl fmt::Display for NmtCommand {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The NMT state a heartbeat reports (protocol notes §2.2). Boot-up is the one-off message a node
/// sends when it enters pre-operational after a reset.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum NmtState {
    BootUp = 0x00,
    Stopped = 0x04,
    Operational = 0x05,
    PreOperational = 0x7F,
}

impl NmtState {
    pub const ALL: [NmtState; 4] = [
        NmtState::BootUp,
        NmtState::Stopped,
        NmtState::Operational,
        NmtState::PreOperational,
    ];

    /// The state of a heartbeat byte, node-guarding toggle (bit 7) ignored.
    pub fn from_u8(byte: u8) -> Option<Self> {
        let state = byte & 0x7F;
        Self::ALL.into_iter().find(|s| *s as u8 == state)
    }

    pub fn name(self) -> &'static str {
        match self {
            NmtState::BootUp => "boot-up",
            NmtState::Stopped => "stopped",
            NmtState::Operational => "operational",
            NmtState::PreOperational => "pre-operational",
        }
    }
}

impl fmt::Display for NmtState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A frame that is not the NMT message it was decoded as.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum NmtError {
    #[error("COB-ID {cob_id:03X}h is not {expected}")]
    WrongCobId { cob_id: u32, expected: &'static str },
    #[error("{what} frames carry {expected} data bytes, this one {got}")]
    Length {
        what: &'static str,
        expected: usize,
        got: usize,
    },
    #[error("a remote request on {cob_id:03X}h is a node-guarding request, not a heartbeat")]
    Remote { cob_id: u16 },
    #[error("{0:02X}h is not an NMT command specifier (01h, 02h, 80h, 81h or 82h)")]
    UnknownCommand(u8),
    #[error("{0:02X}h is not an NMT state (00h boot-up, 04h, 05h or 7Fh)")]
    UnknownState(u8),
}

/// The NMT command frame: COB-ID 000h, `[cs, node]`, node 0 addresses all nodes
/// (protocol notes §2.2).
pub fn command_frame(command: NmtCommand, node: u8) -> CanFrame {
    data_frame(cob::NMT, &[command as u8, node])
}

/// Decode an NMT command frame into (command, node); node 0 means all nodes.
pub fn decode_command(frame: &CanFrame) -> Result<(NmtCommand, u8), NmtError> {
    if frame.cob_id() != Some(cob::NMT) || frame.is_remote() {
        return Err(NmtError::WrongCobId {
            cob_id: frame.id(),
            expected: "the NMT command (000h)",
        });
    }
    let [cs, node] = frame.data() else {
        return Err(NmtError::Length {
            what: "NMT command",
            expected: 2,
            got: frame.len(),
        });
    };
    let command = NmtCommand::from_u8(*cs).ok_or(NmtError::UnknownCommand(*cs))?;
    Ok((command, *node))
}

/// A heartbeat (or, with [`NmtState::BootUp`], the boot-up message): COB-ID 700h + node,
/// one byte (protocol notes §2.2).
pub fn heartbeat_frame(node: u8, state: NmtState) -> CanFrame {
    data_frame(cob::heartbeat(node), &[state as u8])
}

/// The boot-up message: a heartbeat frame with state 00h.
pub fn boot_up_frame(node: u8) -> CanFrame {
    heartbeat_frame(node, NmtState::BootUp)
}

/// Decode a heartbeat, boot-up or node-guarding answer into (node, state). Bit 7 is the
/// node-guarding toggle; it is tolerated and stripped.
pub fn decode_heartbeat(frame: &CanFrame) -> Result<(u8, NmtState), NmtError> {
    let Some(Cob::Heartbeat { node }) = frame.cob_id().map(classify) else {
        return Err(NmtError::WrongCobId {
            cob_id: frame.id(),
            expected: "a heartbeat (701h..77Fh)",
        });
    };
    if frame.is_remote() {
        return Err(NmtError::Remote {
            cob_id: cob::heartbeat(node),
        });
    }
    let [byte] = frame.data() else {
        return Err(NmtError::Length {
            what: "heartbeat",
            expected: 1,
            got: frame.len(),
        });
    };
    let state = NmtState::from_u8(*byte).ok_or(NmtError::UnknownState(*byte & 0x7F))?;
    Ok((node, state))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn command_frames_are_cs_then_node() {
        let f = command_frame(NmtCommand::Start, 1);
        assert_eq!(f.to_string(), "000#0101");
        assert_eq!(
            command_frame(NmtCommand::ResetCommunication, 0).to_string(),
            "000#8200"
        );
        for cmd in NmtCommand::ALL {
            for node in [0, 1, 127] {
                assert_eq!(decode_command(&command_frame(cmd, node)), Ok((cmd, node)));
            }
        }
        let bad = CanFrame::new(0, &[0x03, 1]).unwrap();
        assert_eq!(decode_command(&bad), Err(NmtError::UnknownCommand(3)));
        let short = CanFrame::new(0, &[0x01]).unwrap();
        assert!(matches!(
            decode_command(&short),
            Err(NmtError::Length { got: 1, .. })
        ));
        let other = CanFrame::new(0x701, &[1, 1]).unwrap();
        assert!(matches!(
            decode_command(&other),
            Err(NmtError::WrongCobId { .. })
        ));
    }

    #[test]
    fn heartbeats_carry_the_state_and_tolerate_the_toggle() {
        assert_eq!(
            heartbeat_frame(1, NmtState::Operational).to_string(),
            "701#05"
        );
        assert_eq!(boot_up_frame(0x7F).to_string(), "77F#00");
        for state in NmtState::ALL {
            assert_eq!(decode_heartbeat(&heartbeat_frame(5, state)), Ok((5, state)));
        }
        // Node guarding answer with the toggle bit set: 85h = operational.
        let guarded = CanFrame::new(0x701, &[0x85]).unwrap();
        assert_eq!(decode_heartbeat(&guarded), Ok((1, NmtState::Operational)));
        let guarded = CanFrame::new(0x701, &[0xFF]).unwrap();
        assert_eq!(
            decode_heartbeat(&guarded),
            Ok((1, NmtState::PreOperational))
        );
        assert_eq!(
            decode_heartbeat(&CanFrame::new(0x701, &[0x01]).unwrap()),
            Err(NmtError::UnknownState(1))
        );
        assert!(matches!(
            decode_heartbeat(&CanFrame::new(0x701, &[]).unwrap()),
            Err(NmtError::Length { got: 0, .. })
        ));
        assert_eq!(
            decode_heartbeat(&CanFrame::remote(0x701, 1).unwrap()),
            Err(NmtError::Remote { cob_id: 0x701 })
        );
        assert!(decode_heartbeat(&CanFrame::new(0x700, &[0]).unwrap()).is_err());
        assert!(decode_heartbeat(&CanFrame::new(0x581, &[0]).unwrap()).is_err());
    }

    #[test]
    fn predefined_connection_set() {
        assert_eq!(cob::emcy(1), 0x081);
        assert_eq!(cob::tpdo(1, 1), Some(0x181));
        assert_eq!(cob::tpdo(2, 1), Some(0x281));
        assert_eq!(cob::tpdo(3, 1), Some(0x381));
        assert_eq!(cob::tpdo(4, 0x7F), Some(0x4FF));
        assert_eq!(cob::tpdo(5, 1), None);
        assert_eq!(cob::tpdo(0, 1), None);
        assert_eq!(cob::rpdo(1, 1), Some(0x201));
        assert_eq!(cob::rpdo(2, 1), Some(0x301));
        assert_eq!(cob::rpdo(3, 1), Some(0x401));
        assert_eq!(cob::rpdo(4, 1), Some(0x501));
        assert_eq!(cob::sdo_tx(1), 0x581);
        assert_eq!(cob::sdo_rx(1), 0x601);
        assert_eq!(cob::heartbeat(1), 0x701);

        assert_eq!(classify(0x000), Cob::Nmt);
        assert_eq!(classify(0x080), Cob::Sync);
        assert_eq!(classify(0x081), Cob::Emcy { node: 1 });
        assert_eq!(classify(0x100), Cob::Other);
        assert_eq!(classify(0x180), Cob::Other);
        assert_eq!(classify(0x1FF), Cob::Tpdo { n: 1, node: 127 });
        assert_eq!(classify(0x4A0), Cob::Tpdo { n: 4, node: 0x20 });
        assert_eq!(classify(0x305), Cob::Rpdo { n: 2, node: 5 });
        assert_eq!(classify(0x581), Cob::SdoResponse { node: 1 });
        assert_eq!(classify(0x601), Cob::SdoRequest { node: 1 });
        assert_eq!(classify(0x701), Cob::Heartbeat { node: 1 });
        assert_eq!(classify(0x7E5), Cob::Other); // LSS
        assert_eq!(classify(0x680), Cob::Other);
    }

    proptest! {
        #[test]
        fn helpers_and_classifier_agree(node in 1u8..=127, n in 1u8..=4) {
            prop_assert_eq!(classify(cob::emcy(node)), Cob::Emcy { node });
            prop_assert_eq!(classify(cob::tpdo(n, node).unwrap()), Cob::Tpdo { n, node });
            prop_assert_eq!(classify(cob::rpdo(n, node).unwrap()), Cob::Rpdo { n, node });
            prop_assert_eq!(classify(cob::sdo_tx(node)), Cob::SdoResponse { node });
            prop_assert_eq!(classify(cob::sdo_rx(node)), Cob::SdoRequest { node });
            prop_assert_eq!(classify(cob::heartbeat(node)), Cob::Heartbeat { node });
        }

        #[test]
        fn decoders_never_panic(id in 0u16..0x800, data in proptest::collection::vec(any::<u8>(), 0..=8)) {
            let frame = CanFrame::new(id, &data).unwrap();
            let _ = decode_command(&frame);
            let _ = decode_heartbeat(&frame);
            let _ = classify(id);
        }
    }
}
