//! The pieces of the grammar: the ranges every field is checked against, numbers and
//! hosts as they are written, the query's parameters.

use std::fmt;
use std::ops::RangeInclusive;

use super::WordOrder;

/// The CAN bit rates slcan adapters support (S0..S8).
pub const CAN_BITRATES: [u32; 9] = [
    10_000, 20_000, 50_000, 100_000, 125_000, 250_000, 500_000, 800_000, 1_000_000,
];

/// The TCP ports a host can be reached at.
pub const PORTS: RangeInclusive<u16> = 1..=65535;
/// Modbus TCP unit ids.
pub const UNITS: RangeInclusive<u8> = 0..=255;
/// Modbus RTU baud rates.
pub const BAUDS: RangeInclusive<u32> = 1_200..=4_000_000;
/// Modbus RTU stop bits.
pub const STOP_BITS: RangeInclusive<u8> = 1..=2;
/// Modbus RTU slave addresses (0 is the broadcast, which nothing answers).
pub const SLAVES: RangeInclusive<u8> = 1..=247;
/// CANopen node ids.
pub const NODES: RangeInclusive<u8> = 1..=127;
/// The RPDO/TPDO pair that carries the PDI.
pub const PDOS: RangeInclusive<u8> = 1..=4;
/// EtherNet/IP requested packet intervals, ms.
pub const RPI_MS: RangeInclusive<u32> = 1..=10_000;

/// Why a number given for a connection was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BadNumber {
    /// Not an integer (decimal, or hex as `0x1F` or `1Fh`).
    NotANumber,
    /// An integer outside the range.
    OutOfRange(i64),
}

/// A number as connection strings take them (decimal, or hex as `0x1F` or `1Fh`; `_`
/// between digits), within `range`.
pub fn number<T>(text: &str, range: &RangeInclusive<T>) -> Result<T, BadNumber>
where
    T: Copy + PartialOrd + TryFrom<i64>,
{
    let value = crate::number::parse_integer(text, false)
        .and_then(|v| i64::try_from(v).ok())
        .ok_or(BadNumber::NotANumber)?;
    T::try_from(value)
        .ok()
        .filter(|v| range.contains(v))
        .ok_or(BadNumber::OutOfRange(value))
}

/// A host given alone, as connection strings carry it: a name, an IPv4 address or an
/// IPv6 address (in brackets or not).
pub fn parse_host(text: &str) -> Result<String, String> {
    let text = text.trim();
    let host = match text.strip_prefix('[') {
        Some(rest) => rest
            .strip_suffix(']')
            .ok_or("an IPv6 host needs a closing ']'")?,
        None => text,
    };
    check_host(host)
}

pub(super) fn check_host(host: &str) -> Result<String, String> {
    if host.is_empty() {
        return Err("the host is missing".into());
    }
    if host.contains(['/', ' ', '?', '#']) {
        return Err(format!("'{host}' is not a host name"));
    }
    Ok(host.to_owned())
}

/// One query parameter of a spec, as its string writes it.
pub(super) struct Param {
    pub(super) key: &'static str,
    pub(super) value: String,
    /// Written even at its default (the usual strings stay short without the others).
    pub(super) always: bool,
}

impl Param {
    pub(super) fn always(key: &'static str, value: impl fmt::Display) -> Self {
        Self {
            key,
            value: value.to_string(),
            always: true,
        }
    }

    pub(super) fn when_set(key: &'static str, value: impl fmt::Display) -> Self {
        Self {
            key,
            value: value.to_string(),
            always: false,
        }
    }
}

pub(super) fn host_text(host: &str) -> String {
    if host.contains(':') {
        format!("[{host}]")
    } else {
        host.to_owned()
    }
}

/// Query parameters, each used at most once; leftovers are an error.
pub(super) struct Query {
    pub(super) pairs: Vec<(String, String)>,
}

impl Query {
    pub(super) fn parse(text: &str) -> Result<Self, String> {
        let mut pairs: Vec<(String, String)> = vec![];
        for part in text.split('&').filter(|p| !p.is_empty()) {
            let (key, value) = part
                .split_once('=')
                .ok_or_else(|| format!("parameter '{part}' has no value (write key=value)"))?;
            let key = key.trim().to_ascii_lowercase();
            if pairs.iter().any(|(k, _)| *k == key) {
                return Err(format!("parameter '{key}' is given twice"));
            }
            pairs.push((key, value.trim().to_owned()));
        }
        Ok(Self { pairs })
    }

    pub(super) fn take(&mut self, key: &str) -> Option<String> {
        let at = self.pairs.iter().position(|(k, _)| k == key)?;
        Some(self.pairs.remove(at).1)
    }

    /// A numeric parameter within `range`; `current` when it is not given.
    pub(super) fn number<T>(
        &mut self,
        key: &str,
        current: T,
        range: RangeInclusive<T>,
    ) -> Result<T, String>
    where
        T: Copy + PartialOrd + TryFrom<i64> + fmt::Display,
    {
        match self.take(key) {
            None => Ok(current),
            Some(text) => number(&text, &range).map_err(|bad| match bad {
                BadNumber::NotANumber => format!("{key}='{text}' is not a number"),
                BadNumber::OutOfRange(value) => format!(
                    "{key}={value} is out of range {}",
                    crate::number::range_text(range.start(), range.end())
                ),
            }),
        }
    }

    pub(super) fn words(&mut self, current: WordOrder) -> Result<WordOrder, String> {
        match self.take("words").as_deref() {
            None => Ok(current),
            Some("high") | Some("hi") => Ok(WordOrder::High),
            Some("low") | Some("lo") => Ok(WordOrder::Low),
            Some(other) => Err(format!(
                "words='{other}': use high (high word first, Nanotec) or low"
            )),
        }
    }

    pub(super) fn finish(&self, allowed: &[&str]) -> Result<(), String> {
        match self.pairs.first() {
            None => Ok(()),
            Some((key, _)) => Err(format!(
                "unknown parameter '{key}' (this bus takes {})",
                if allowed.is_empty() {
                    "no parameters".to_owned()
                } else {
                    allowed.join(", ")
                }
            )),
        }
    }
}

/// `HOST[:PORT]`, with IPv6 hosts in brackets.
pub(super) fn host_port(text: &str, default_port: u16) -> Result<(String, u16), String> {
    if text.is_empty() {
        return Err("the host is missing".into());
    }
    let (host, port) = if let Some(rest) = text.strip_prefix('[') {
        let (host, after) = rest
            .split_once(']')
            .ok_or("an IPv6 host needs a closing ']'")?;
        match after.strip_prefix(':') {
            Some(port) => (host, Some(port)),
            None if after.is_empty() => (host, None),
            None => return Err(format!("unexpected '{after}' after the host")),
        }
    } else {
        match text.rsplit_once(':') {
            Some((host, port)) if !host.contains(':') => (host, Some(port)),
            Some(_) => return Err("write an IPv6 host in brackets, e.g. [::1]:502".into()),
            None => (text, None),
        }
    };
    let host = check_host(host)?;
    let port = match port {
        None => default_port,
        Some(p) => p
            .parse::<u16>()
            .ok()
            .filter(|p| PORTS.contains(p))
            .ok_or_else(|| format!("port '{p}' is not a number from 1 to 65535"))?,
    };
    Ok((host, port))
}
