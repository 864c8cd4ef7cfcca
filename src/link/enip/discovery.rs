//! Discovery: ListIdentity by UDP broadcast on the chosen interfaces, and directly to the
//! hosts the user names (UDP unicast and TCP), collected for a short while.

use std::collections::BTreeMap;
use std::net::{IpAddr, Ipv4Addr, SocketAddr, SocketAddrV4};
use std::time::Duration;

use tokio::net::UdpSocket;
use tokio::sync::mpsc;

use super::session::Session;
use crate::link::{Error, FoundDevice};
use crate::proto::enip::encap::{Command, Packet, TCP_PORT};
use crate::proto::enip::identity::{Identity, decode_list_identity_reply, state_text};

pub use crate::link::NetworkInterface as Interface;

/// The IPv4 interfaces, loopback last.
pub fn interfaces() -> Vec<Interface> {
    let mut out: Vec<Interface> = if_addrs::get_if_addrs()
        .unwrap_or_default()
        .into_iter()
        .filter_map(|i| match i.addr {
            if_addrs::IfAddr::V4(v4) => Some(Interface {
                name: i.name,
                ip: v4.ip,
                broadcast: v4.broadcast,
            }),
            if_addrs::IfAddr::V6(_) => None,
        })
        .collect();
    out.sort_by_key(|i| (i.ip.is_loopback(), i.name.clone()));
    out
}

/// What to ask and for how long.
#[derive(Clone, Debug)]
pub struct Discovery {
    /// The adapters' EtherNet/IP port (44818).
    pub port: u16,
    /// Broadcast on this interface only (its name or IPv4 address); `None`: on every
    /// interface that has a broadcast address.
    pub interface: Option<String>,
    /// Broadcast at all.
    pub broadcast: bool,
    /// Hosts asked directly, by UDP and over TCP.
    pub unicast: Vec<String>,
    /// How long replies are collected.
    pub wait: Duration,
}

impl Default for Discovery {
    fn default() -> Self {
        Discovery {
            port: TCP_PORT,
            interface: None,
            broadcast: true,
            unicast: vec![],
            wait: Duration::from_millis(1000),
        }
    }
}

fn list_identity_request() -> Vec<u8> {
    Packet::new(Command::LIST_IDENTITY, 0, *b"ddscan\0\0", vec![]).encode()
}

fn found(identity: &Identity, from: SocketAddr) -> (SocketAddrV4, FoundDevice) {
    let from_ip = match from.ip() {
        IpAddr::V4(ip) => Some(ip),
        IpAddr::V6(_) => None,
    };
    let mut address = identity.address(from_ip);
    if address.port() == 0 {
        address.set_port(from.port());
    }
    let device = FoundDevice {
        address: address.to_string(),
        node: None,
        vendor: Some(u32::from(identity.vendor)),
        product: Some(u32::from(identity.product_code)),
        revision: Some(u32::from(identity.revision.0) << 16 | u32::from(identity.revision.1)),
        serial: Some(identity.serial),
        name: Some(identity.product_name.clone()),
        state: Some(state_text(identity.state).to_owned()),
        refused: None,
    };
    (address, device)
}

/// An identity and where its reply came from.
type Heard = (SocketAddr, Identity);

/// Ask, collect for `wait`, and list each adapter once, by address.
pub async fn discover(discovery: &Discovery) -> Result<Vec<FoundDevice>, Error> {
    let (tx, mut rx) = mpsc::unbounded_channel::<Heard>();
    let mut problems = vec![];
    let mut sockets = if discovery.broadcast {
        broadcast(discovery, &mut problems).await?
    } else {
        vec![]
    };
    let mut tcp = tokio::task::JoinSet::new();
    if !discovery.unicast.is_empty() {
        sockets.push(unicast(discovery, &tx, &mut tcp, &mut problems).await?);
    }
    for socket in sockets {
        let tx = tx.clone();
        tcp.spawn(async move {
            let mut buffer = vec![0u8; 1500];
            while let Ok((n, from)) = socket.recv_from(&mut buffer).await {
                for identity in decode_list_identity_reply(&buffer[..n]) {
                    let _ = tx.send((from, identity));
                }
            }
        });
    }
    drop(tx);
    let mut devices: BTreeMap<SocketAddrV4, FoundDevice> = BTreeMap::new();
    let deadline = tokio::time::Instant::now() + discovery.wait;
    while let Ok(Some((from, identity))) = tokio::time::timeout_at(deadline, rx.recv()).await {
        let (address, device) = found(&identity, from);
        devices.entry(address).or_insert(device);
    }
    tcp.abort_all();
    if devices.is_empty() && !problems.is_empty() {
        return Err(Error::Unsupported(format!(
            "discovery found nothing: {}",
            problems.join("; ")
        )));
    }
    Ok(devices.into_values().collect())
}

/// The interfaces to broadcast on: the one picked, or every one with a broadcast address.
fn chosen_interfaces(discovery: &Discovery) -> Result<Vec<Interface>, Error> {
    let chosen: Vec<Interface> = interfaces()
        .into_iter()
        .filter(|i| match &discovery.interface {
            Some(pick) => i.name == *pick || i.ip.to_string() == *pick,
            None => i.broadcast.is_some(),
        })
        .collect();
    if let Some(pick) = &discovery.interface
        && chosen.is_empty()
    {
        return Err(Error::Unsupported(format!(
            "no IPv4 interface '{pick}' here; the interfaces are: {}",
            interfaces()
                .iter()
                .map(Interface::label)
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }
    Ok(chosen)
}

/// Broadcast ListIdentity on the chosen interfaces: the sockets the replies come to.
async fn broadcast(
    discovery: &Discovery,
    problems: &mut Vec<String>,
) -> Result<Vec<UdpSocket>, Error> {
    let mut sockets = vec![];
    for interface in chosen_interfaces(discovery)? {
        let target = interface.broadcast.unwrap_or(Ipv4Addr::BROADCAST);
        match UdpSocket::bind((interface.ip, 0)).await {
            Ok(socket) => {
                let _ = socket.set_broadcast(true);
                match socket
                    .send_to(&list_identity_request(), (target, discovery.port))
                    .await
                {
                    Ok(_) => sockets.push(socket),
                    Err(e) => problems.push(format!("broadcast on {}: {e}", interface.label())),
                }
            }
            Err(e) => problems.push(format!("{}: {e}", interface.label())),
        }
    }
    Ok(sockets)
}

/// Ask each named host directly: ListIdentity by UDP from the socket returned, and over
/// TCP in a task of `tcp` that sends what it hears to `tx`.
async fn unicast(
    discovery: &Discovery,
    tx: &mpsc::UnboundedSender<Heard>,
    tcp: &mut tokio::task::JoinSet<()>,
    problems: &mut Vec<String>,
) -> Result<UdpSocket, Error> {
    let socket = UdpSocket::bind((Ipv4Addr::UNSPECIFIED, 0))
        .await
        .map_err(|e| Error::Io {
            context: "binding a UDP socket for discovery".into(),
            source: e,
        })?;
    for host in &discovery.unicast {
        match tokio::net::lookup_host((host.as_str(), discovery.port)).await {
            Ok(addresses) => {
                for address in addresses.filter(SocketAddr::is_ipv4) {
                    let _ = socket.send_to(&list_identity_request(), address).await;
                }
            }
            Err(e) => problems.push(format!("{host}: {e}")),
        }
        let (host, port, wait, tx) = (host.clone(), discovery.port, discovery.wait, tx.clone());
        tcp.spawn(async move {
            if let Ok(mut session) = Session::open(&host, port, wait).await
                && let Ok(identity) = session.list_identity().await
                && let (_, Some(peer)) = session.addresses()
            {
                let _ = tx.send((peer, identity));
                session.close().await;
            }
        });
    }
    Ok(socket)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_found_adapter_is_reported_at_the_address_it_answered_from() {
        let identity = crate::proto::enip::identity::unaddressed_sample();
        let (address, device) = found(&identity, "10.1.2.3:44818".parse().unwrap());
        assert_eq!(address.to_string(), "10.1.2.3:44818");
        assert_eq!(device.vendor_name(), "Nanotec (ODVA 558h)");
        assert_eq!(device.revision, Some(0x0002_0005));
        assert_eq!(device.state.as_deref(), Some("operational"));
    }

    #[test]
    fn interfaces_are_listed_loopback_last() {
        let all = interfaces();
        if let (Some(first), Some(last)) = (all.first(), all.last())
            && all.len() > 1
        {
            assert!(!first.ip.is_loopback() || last.ip.is_loopback());
        }
    }
}
