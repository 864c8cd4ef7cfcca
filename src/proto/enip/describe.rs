//! One line for the frame log per encapsulation message: the command, and the CIP
//! service or reply inside, with the Nanotec object it names.

use super::cip::{self, Reply, Request};
use super::encap::{Command, Packet, RrData, Status};
use super::wire::hex;

/// One line for the frame log: the command, and the CIP service or reply inside.
pub fn describe(packet: &Packet) -> String {
    let mut text = packet.command.name().to_owned();
    if packet.status != Status::SUCCESS {
        text.push_str(&format!(": {}", packet.status));
        return text;
    }
    if packet.command == Command::SEND_RR_DATA
        && let Ok(data) = RrData::decode(&packet.data)
        && let Some(router) = data.unconnected()
    {
        match router.first() {
            Some(s) if s & cip::service::REPLY != 0 => {
                if let Ok(reply) = Reply::decode(router) {
                    text.push_str(&format!(
                        " reply {}: {}",
                        cip::service::name(reply.service),
                        reply.status_text()
                    ));
                    if !reply.data.is_empty() {
                        text.push_str(&format!(", data {}", hex(&reply.data)));
                    }
                }
            }
            Some(_) => {
                if let Ok(request) = Request::decode(router) {
                    text.push_str(&format!(
                        " {} ({:02X}h)",
                        cip::service::name(request.service),
                        request.service
                    ));
                    if let Ok(path) = request.path() {
                        text.push_str(&format!(" to {path}"));
                    }
                    if let (0x64, Ok((address, value))) = (
                        request.path().ok().and_then(|p| p.class()).unwrap_or(0),
                        crate::proto::enip::nanotec::decode_request_data(&request.data),
                    ) {
                        text.push_str(&format!(" {address}"));
                        if !value.is_empty() {
                            text.push_str(&format!(" = {}", hex(value)));
                        }
                    }
                }
            }
            None => {}
        }
    }
    text
}
