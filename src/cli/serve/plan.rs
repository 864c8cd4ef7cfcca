//! Which simulated drive `drivedeck sim` serves where: the n-th `--node`, `--slave`,
//! `--modbus-tcp` and `--enip` are all the n-th drive. One of each is one drive seen on
//! every bus, as before; `--node 5 --node 6` are two drives on one CAN bus, `--slave 5
//! --slave 6` two on one RTU line, two `--modbus-tcp` (or `--enip`) two drives each on its
//! own port (adapter).

use std::net::SocketAddr;

use crate::cli::SimArgs;

/// One drive and its addresses on the buses served.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Planned {
    pub node: Option<u8>,
    pub slave: Option<u8>,
    pub modbus_tcp: Option<SocketAddr>,
    pub enip: Option<SocketAddr>,
}

/// The drives, in order (at least one when anything is served).
pub fn plan(args: &SimArgs) -> Result<Vec<Planned>, String> {
    let on_can = args.can.is_some() || args.slcan.is_some();
    let on_rtu = args.modbus_rtu.is_some();
    let nodes: &[u8] = if on_can { &args.node } else { &[] };
    let slaves: &[u8] = if on_rtu { &args.slave } else { &[] };
    once_each("--node", "CANopen node", nodes)?;
    once_each("--slave", "RTU slave", slaves)?;
    let count = [
        nodes.len(),
        slaves.len(),
        args.modbus_tcp.len(),
        args.enip.len(),
    ]
    .into_iter()
    .max()
    .unwrap_or(0);
    Ok((0..count)
        .map(|n| Planned {
            node: nodes.get(n).copied(),
            slave: slaves.get(n).copied(),
            modbus_tcp: args.modbus_tcp.get(n).copied(),
            enip: args.enip.get(n).copied(),
        })
        .collect())
}

/// Two drives cannot share a node id on one bus, nor a slave address on one line.
fn once_each(flag: &str, what: &str, ids: &[u8]) -> Result<(), String> {
    for (n, id) in ids.iter().enumerate() {
        if ids[..n].contains(id) {
            return Err(format!(
                "{flag} {id} is given twice: two drives cannot both be {what} {id}"
            ));
        }
    }
    Ok(())
}

/// "5, 6" (a list of ids for a message).
pub fn listed(ids: &[u8]) -> String {
    ids.iter().map(u8::to_string).collect::<Vec<_>>().join(", ")
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    use super::*;
    use crate::cli::{Cli, Command};

    fn args(line: &str) -> SimArgs {
        let words = std::iter::once("drivedeck").chain(line.split_whitespace());
        match Cli::try_parse_from(words).map(|cli| cli.command) {
            Ok(Some(Command::Sim(args))) => args,
            other => panic!("{line}: {other:?}"),
        }
    }

    #[test]
    fn one_of_each_is_one_drive_on_every_bus() {
        let drives = plan(&args(
            "sim --modbus-tcp 127.0.0.1:1502 --modbus-rtu /dev/ttyX --slcan /dev/ttyY --enip 127.0.0.1:44818",
        ));
        assert_eq!(
            drives,
            Ok(vec![Planned {
                node: Some(1),
                slave: Some(5),
                modbus_tcp: "127.0.0.1:1502".parse().ok(),
                enip: "127.0.0.1:44818".parse().ok(),
            }])
        );
    }

    #[test]
    fn the_nth_address_of_every_kind_is_the_nth_drive() {
        let drives = plan(&args(
            "sim --slcan /dev/ttyY --node 5 --node 6 --node 7 --modbus-tcp 127.0.0.1:0 --modbus-rtu /dev/ttyX --slave 9 --slave 8",
        ))
        .expect("plan");
        let nodes: Vec<_> = drives.iter().map(|d| d.node).collect();
        let slaves: Vec<_> = drives.iter().map(|d| d.slave).collect();
        let tcp: Vec<_> = drives.iter().map(|d| d.modbus_tcp.is_some()).collect();
        assert_eq!(nodes, [Some(5), Some(6), Some(7)]);
        assert_eq!(slaves, [Some(9), Some(8), None]);
        assert_eq!(tcp, [true, false, false]);
        // Node ids without a CAN bus serve nothing, and make no drives.
        let drives = plan(&args("sim --enip 127.0.0.1:0 --node 5 --node 6")).expect("plan");
        assert_eq!(drives.len(), 1);
        assert_eq!(drives[0].node, None);
        let two_ports = plan(&args(
            "sim --modbus-tcp 127.0.0.1:0 --modbus-tcp 127.0.0.1:0",
        ));
        assert_eq!(two_ports.map(|d| d.len()), Ok(2));
    }

    #[test]
    fn an_id_given_twice_is_refused() {
        let error = plan(&args("sim --can vcan0 --node 5 --node 5")).expect_err("twice");
        assert!(error.contains("--node 5 is given twice"), "{error}");
        let error =
            plan(&args("sim --modbus-rtu /dev/ttyX --slave 6 --slave 6")).expect_err("twice");
        assert!(error.contains("RTU slave 6"), "{error}");
        assert!(plan(&args("sim --slcan /dev/ttyY")).is_ok());
    }
}
