//! The NanoJ tab's model: the drive's NanoJ program — its state and error in words, the
//! programs on the drive, the objects mapped into it, NanoJ inputs 2400h:01–04 (editable)
//! and outputs 2500h:01–04 (read live), the uptime — and Start and Stop, which say when
//! the program runs, stopped, or stopped with its error.
//!
//! A model: no egui here.

use crate::od::nanoj::{error_text, mapping, program_names, status_text};
use crate::od::{Address, DataType, Value};
use crate::ui::panel::{Cadence, PanelModel};
use crate::worker::{Event, ObjectPath, Request};

/// The tag of the reading of the names and the mapping (once on connecting).
const LAYOUT: u64 = 1;
/// The tag of the live reading.
const LIVE: u64 = 2;
/// The tag of a write (2300h, or a NanoJ input).
const WRITE: u64 = 3;

/// How often the live values are read, seconds of the worker's clock.
pub const EVERY_S: f64 = 0.5;
/// NanoJ inputs and outputs shown.
pub const SHOWN: u8 = 4;

/// The NanoJ tab of one drive.
#[derive(Debug, Default)]
pub struct NanojPanel {
    /// 2301h and 2302h as last read.
    pub status: Option<u32>,
    pub error: Option<u32>,
    pub programs: Vec<String>,
    /// The objects mapped into the program (2310h) and out of it (2320h): address, bits.
    pub inputs_mapped: Vec<(Address, u8)>,
    pub outputs_mapped: Vec<(Address, u8)>,
    /// 2400h:01–04 and 2500h:01–04.
    pub inputs: [Option<i64>; SHOWN as usize],
    pub outputs: [Option<i64>; SHOWN as usize],
    pub uptime_s: Option<u32>,
    /// The NanoJ input being edited: its number and the text typed.
    pub edit: Option<(u8, String)>,
    pub message: Option<Result<String, String>>,
    /// Start (true) or Stop asked and not yet seen in 2301h.
    pub asked: Option<bool>,
    connected: bool,
    cadence: Cadence,
    /// 2304h, 2310h, 2320h words as they come.
    layout: Vec<(Address, i64)>,
    requests: Vec<(u64, Request)>,
}

fn objects(list: &[(u16, u8)]) -> Vec<(Address, DataType)> {
    list.iter()
        .map(|&(index, sub)| {
            let address = Address::new(index, sub);
            let dtype = crate::od::builtin()
                .get(address)
                .map_or(DataType::Unsigned32, |e| e.dtype);
            (address, dtype)
        })
        .collect()
}

impl PanelModel for NanojPanel {
    fn on_event(&mut self, event: &Event) {
        match event {
            Event::Connected(_) => {
                self.connected = true;
                self.cadence.reading = false;
                self.layout.clear();
                let mut list: Vec<(u16, u8)> = (0..=6).map(|s| (0x2304, s)).collect();
                list.extend((0..=8).map(|s| (0x2310, s)));
                list.extend((0..=8).map(|s| (0x2320, s)));
                self.requests.push((
                    LAYOUT,
                    Request::ReadMany {
                        objects: objects(&list),
                        path: ObjectPath::Auto,
                    },
                ));
                self.read_live();
            }
            Event::Disconnected { .. } | Event::ConnectFailed { .. } => {
                self.connected = false;
                self.cadence.reading = false;
            }
            Event::Samples(samples) if self.connected && self.cadence.due(samples, EVERY_S) => {
                self.read_live();
            }
            _ => {}
        }
    }

    fn on_reply(&mut self, tag: u64, event: &Event) -> bool {
        match (tag, event) {
            (
                LAYOUT,
                Event::ObjectRead {
                    address, result, ..
                },
            ) => {
                if let Ok(value) = result
                    && let Some(v) = value.as_i128()
                {
                    self.layout.push((*address, v as i64));
                }
                let done = address.index == 0x2320 && address.sub == 8;
                if done {
                    self.take_layout();
                }
                done
            }
            (
                LIVE,
                Event::ObjectRead {
                    address, result, ..
                },
            ) => {
                let value = result
                    .as_ref()
                    .ok()
                    .and_then(Value::as_i128)
                    .map(|v| v as i64);
                match (address.index, address.sub) {
                    (0x2301, 0) => self.status = value.map(|v| v as u32),
                    (0x2302, 0) => self.error = value.map(|v| v as u32),
                    (0x230F, 0) => self.uptime_s = value.map(|v| v as u32),
                    (0x2400, n @ 1..=SHOWN) => self.inputs[usize::from(n - 1)] = value,
                    (0x2500, n @ 1..=SHOWN) => {
                        self.outputs[usize::from(n - 1)] = value.map(|v| i64::from(v as i32));
                    }
                    _ => {}
                }
                let done = address.index == 0x2500 && address.sub == SHOWN;
                if done {
                    self.cadence.reading = false;
                    self.seen();
                }
                done
            }
            (
                WRITE,
                Event::ObjectWritten {
                    address, result, ..
                },
            ) => {
                if let Err(e) = result {
                    self.asked = None;
                    self.message = Some(Err(format!("{address}: the drive refused it: {e}")));
                }
                true
            }
            (_, Event::Rejected { reason, .. }) => {
                if tag == WRITE {
                    self.asked = None;
                    self.message = Some(Err(format!("not sent: {reason}")));
                } else {
                    self.cadence.reading = false;
                }
                true
            }
            (_, Event::Cancelled { .. }) => {
                self.cadence.reading = false;
                true
            }
            _ => false,
        }
    }

    fn take_requests(&mut self) -> Vec<(u64, Request)> {
        std::mem::take(&mut self.requests)
    }
}

impl NanojPanel {
    pub fn is_connected(&self) -> bool {
        self.connected
    }

    /// The program's state in words ("not read yet" before the first reading).
    pub fn state(&self) -> String {
        match self.status {
            Some(s) => status_text(s).to_owned(),
            None => "not read yet".into(),
        }
    }

    /// The error in words, when there is one.
    pub fn error_words(&self) -> Option<String> {
        self.error
            .filter(|c| *c != 0)
            .map(|c| format!("{c:X}h: {}", error_text(c)))
    }

    fn read_live(&mut self) {
        let mut list = vec![(0x2301, 0), (0x2302, 0), (0x230F, 0)];
        list.extend((1..=SHOWN).map(|s| (0x2400, s)));
        list.extend((1..=SHOWN).map(|s| (0x2500, s)));
        self.cadence.reading = true;
        self.requests.push((
            LIVE,
            Request::ReadMany {
                objects: objects(&list),
                path: ObjectPath::Auto,
            },
        ));
    }

    fn take_layout(&mut self) {
        let words = |index: u16| -> Vec<(u8, i64)> {
            self.layout
                .iter()
                .filter(|(a, _)| a.index == index)
                .map(|(a, v)| (a.sub, *v))
                .collect()
        };
        let count = |list: &[(u8, i64)]| {
            list.iter()
                .find(|(s, _)| *s == 0)
                .map_or(0, |(_, v)| *v as u8)
        };
        let names = words(0x2304);
        let n = count(&names);
        let name_words: Vec<u32> = names
            .iter()
            .filter(|(s, _)| *s >= 1 && *s <= n)
            .map(|(_, v)| *v as u32)
            .collect();
        self.programs = program_names(&name_words);
        let mapped = |list: Vec<(u8, i64)>| -> Vec<(Address, u8)> {
            let n = count(&list);
            list.iter()
                .filter(|(s, v)| *s >= 1 && *s <= n && *v != 0)
                .map(|(_, v)| {
                    let (index, sub, bits) = mapping(*v as u32);
                    (Address::new(index, sub), bits)
                })
                .collect()
        };
        self.inputs_mapped = mapped(words(0x2310));
        self.outputs_mapped = mapped(words(0x2320));
    }

    /// Start or Stop asked: say so when 2301h shows it.
    fn seen(&mut self) {
        let Some(start) = self.asked else {
            return;
        };
        match (start, self.status) {
            (true, Some(1)) => {
                self.asked = None;
                self.message = Some(Ok("the program runs".into()));
            }
            (_, Some(s)) if s >= 2 => {
                self.asked = None;
                self.message = Some(Err(format!(
                    "the program stopped with an error: {}",
                    self.error_words().unwrap_or_else(|| "no code".into())
                )));
            }
            (false, Some(0)) => {
                self.asked = None;
                self.message = Some(Ok("the program stopped".into()));
            }
            _ => {}
        }
    }

    /// Start (true) or stop the program (2300h bit 0).
    pub fn start_stop(&mut self, start: bool) {
        if !self.connected {
            self.message = Some(Err("not connected".into()));
            return;
        }
        self.asked = Some(start);
        self.message = Some(Ok(if start { "starting…" } else { "stopping…" }.into()));
        self.requests.push((
            WRITE,
            Request::WriteObject {
                address: Address::new(0x2300, 0),
                dtype: DataType::Unsigned32,
                value: Value::Uint(u64::from(start)),
                path: ObjectPath::Auto,
            },
        ));
    }

    /// Edit NanoJ input `n` (1–4), the box starting with its value.
    pub fn edit_input(&mut self, n: u8) {
        let text = self.inputs[usize::from(n - 1)].map_or_else(String::new, |v| v.to_string());
        self.edit = Some((n, text));
    }

    /// Write the input being edited; a text that is not an i32 is said, nothing written.
    pub fn write_input(&mut self) {
        let Some((n, text)) = self.edit.take() else {
            return;
        };
        let Some(value) =
            crate::number::parse_integer(text.trim(), false).and_then(|v| i32::try_from(v).ok())
        else {
            self.message = Some(Err(format!(
                "NanoJ input {n}: {:?} is not a whole number from -2147483648 to 2147483647",
                text.trim()
            )));
            self.edit = Some((n, text));
            return;
        };
        self.requests.push((
            WRITE,
            Request::WriteObject {
                address: Address::new(0x2400, n),
                dtype: DataType::Integer32,
                value: Value::Int(i64::from(value)),
                path: ObjectPath::Auto,
            },
        ));
        self.inputs[usize::from(n - 1)] = Some(i64::from(value));
        self.message = Some(Ok(format!("NanoJ input {n} = {value} written")));
    }
}
