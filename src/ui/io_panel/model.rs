//! The I/O tab's model: the digital inputs by name with their special function and
//! inversion (60FDh, 3240h:01/:02), the digital outputs with their force mask (60FEh:01,
//! :02) read live, a force asked for and confirmed before it is written, and the analog
//! input. Every force is a write the Changes tab lists, so "Restore what I changed" gives
//! the outputs back; and whatever the user answers when leaving (Disconnect, closing the
//! window), the outputs this window forced are released first
//! ([`PanelModel::let_go`]), as the CLI's `output` releases its output on exit.
//!
//! A model: no egui here.

use crate::od::{Address, DataType, Value};
use crate::ui::panel::{Cadence, PanelModel};
use crate::worker::{Event, ObjectPath, Request};

const LIVE: u64 = 1;
const WRITE: u64 = 2;

/// How often the values are read, seconds of the worker's clock.
pub const EVERY_S: f64 = 0.25;
pub use crate::od::io::PHYSICAL;
use crate::od::io::{InputLine, InputWords, input_lines, output_bit};

/// A force waiting for the user's yes: output n, on (true) or off, or released (None).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Force {
    pub output: u8,
    pub on: Option<bool>,
}

/// The I/O tab of one drive.
#[derive(Debug, Default)]
pub struct IoPanel {
    /// 60FDh and 3240h:01, :02, :03, :05.
    pub words: InputWords,
    pub outputs: Option<u32>,
    pub mask: Option<u32>,
    pub analog: Option<i64>,
    pub asking: Option<Force>,
    pub message: Option<Result<String, String>>,
    connected: bool,
    /// Outputs' bits (60FEh) this window forced and has not given back yet; kept across
    /// a lost link (the drive still holds the force).
    forced: u32,
    /// Writes to 60FEh sent and not answered yet.
    writing: usize,
    cadence: Cadence,
    requests: Vec<(u64, Request)>,
}

impl PanelModel for IoPanel {
    fn on_event(&mut self, event: &Event) {
        match event {
            Event::Connected(_) => {
                self.connected = true;
                self.cadence.reading = false;
                self.read();
            }
            Event::Disconnected { .. } | Event::ConnectFailed { .. } => {
                self.connected = false;
                self.cadence.reading = false;
                self.asking = None;
            }
            Event::Samples(samples) if self.connected && self.cadence.due(samples, EVERY_S) => {
                self.read();
            }
            _ => {}
        }
    }

    fn on_reply(&mut self, tag: u64, event: &Event) -> bool {
        match (tag, event) {
            (
                LIVE,
                Event::ObjectRead {
                    address, result, ..
                },
            ) => {
                let value = result.as_ref().ok().and_then(Value::as_i128);
                let word = value.map(|v| v as u32);
                match (address.index, address.sub) {
                    (0x60FD, 0) => self.words.inputs = word,
                    (0x3240, 1) => self.words.special = word,
                    (0x3240, 2) => self.words.inverted = word,
                    (0x3240, 3) => self.words.forced = word,
                    (0x3240, 5) => self.words.raw = word,
                    (0x60FE, 1) => self.outputs = word,
                    (0x60FE, 2) => {
                        self.mask = word;
                        // A force given back elsewhere (Restore what I changed, the CLI):
                        // no longer ours. Not while a write is under way, which this
                        // reading may predate.
                        if let Some(mask) = word
                            && self.writing == 0
                        {
                            self.forced &= mask;
                        }
                    }
                    (0x3220, 1) => self.analog = value.map(|v| v as i64),
                    _ => {}
                }
                let done = address.index == 0x3220;
                if done {
                    self.cadence.reading = false;
                }
                done
            }
            (
                WRITE,
                Event::ObjectWritten {
                    address, result, ..
                },
            ) => {
                self.writing = self.writing.saturating_sub(1);
                if let Err(e) = result {
                    self.message = Some(Err(format!("{address}: the drive refused it: {e}")));
                }
                true
            }
            (_, Event::Rejected { reason, .. }) => {
                if tag == WRITE {
                    self.writing = self.writing.saturating_sub(1);
                    self.message = Some(Err(format!("not written: {reason}")));
                } else {
                    self.cadence.reading = false;
                }
                true
            }
            (_, Event::Cancelled { .. }) => {
                if tag == WRITE {
                    self.writing = self.writing.saturating_sub(1);
                } else {
                    self.cadence.reading = false;
                }
                true
            }
            _ => false,
        }
    }

    fn take_requests(&mut self) -> Vec<(u64, Request)> {
        std::mem::take(&mut self.requests)
    }

    fn holding(&self) -> Vec<String> {
        let mut held: Vec<String> = (1..=PHYSICAL)
            .filter(|&n| self.forced & output_bit(n) != 0)
            .map(|n| {
                let state = match self.output(n).0 {
                    Some(true) => " on",
                    Some(false) => " off",
                    None => "",
                };
                format!("Output {n} is forced{state} by this window")
            })
            .collect();
        if held.is_empty() && self.writing > 0 {
            held.push("The outputs are being given back to the drive".to_owned());
        }
        held
    }

    fn let_go(&mut self) {
        let forced = self.forced;
        if forced == 0 {
            return;
        }
        self.asking = None;
        if !self.connected {
            self.message = Some(Err(
                "the link is down: the forced outputs could not be given back".into(),
            ));
            return;
        }
        let (Some(value), Some(mask)) = (self.outputs, self.mask) else {
            return;
        };
        self.release(forced, value, mask);
        self.message = Some(Ok("the forced outputs were given back to the drive".into()));
    }
}

/// A write of 60FEh:`sub`.
fn write_outputs(sub: u8, v: u32) -> Request {
    Request::WriteObject {
        address: Address::new(0x60FE, sub),
        dtype: DataType::Unsigned32,
        value: Value::Uint(u64::from(v)),
        path: ObjectPath::Auto,
    }
}

fn object(index: u16, sub: u8) -> (Address, DataType) {
    let address = Address::new(index, sub);
    let dtype = crate::od::builtin()
        .get(address)
        .map_or(DataType::Unsigned32, |e| e.dtype);
    (address, dtype)
}

impl IoPanel {
    pub fn is_connected(&self) -> bool {
        self.connected
    }

    fn read(&mut self) {
        self.cadence.reading = true;
        self.requests.push((
            LIVE,
            Request::ReadMany {
                objects: vec![
                    object(0x60FD, 0),
                    object(0x3240, 1),
                    object(0x3240, 2),
                    object(0x3240, 3),
                    object(0x3240, 5),
                    object(0x60FE, 1),
                    object(0x60FE, 2),
                    object(0x3220, 1),
                ],
                path: ObjectPath::Auto,
            },
        ));
    }

    /// Whether 60FDh's `bit` is set.
    pub fn input(&self, bit: u8) -> Option<bool> {
        self.words.inputs.map(|v| v & (1 << bit) != 0)
    }

    /// The inputs, line by line, with what 3240h does to each.
    pub fn input_lines(&self) -> Vec<InputLine> {
        input_lines(&self.words)
    }

    /// Output n (1–8): on, and forced.
    pub fn output(&self, n: u8) -> (Option<bool>, Option<bool>) {
        let bit = output_bit(n);
        (
            self.outputs.map(|v| v & bit != 0),
            self.mask.map(|m| m & bit != 0),
        )
    }

    /// Ask before forcing (or releasing) output n.
    pub fn ask(&mut self, force: Force) {
        self.asking = Some(force);
    }

    pub fn decline(&mut self) {
        self.asking = None;
    }

    /// The question asked, in words.
    pub fn question(force: Force) -> String {
        match force.on {
            Some(on) => format!(
                "Force output {} {}? Whatever it drives (a brake, a valve) follows at once; \
                 the Changes tab can give it back.",
                force.output,
                if on { "on" } else { "off" }
            ),
            None => format!(
                "Give output {} back to the drive (release its force)?",
                force.output
            ),
        }
    }

    /// The user said yes: the value, then the mask (forcing) or the mask, then the value
    /// (releasing).
    pub fn agree(&mut self) {
        let Some(force) = self.asking.take() else {
            return;
        };
        let (Some(value), Some(mask)) = (self.outputs, self.mask) else {
            self.message = Some(Err("60FEh not read yet: nothing written".into()));
            return;
        };
        if !self.connected {
            self.message = Some(Err("not connected: nothing written".into()));
            return;
        }
        let bit = output_bit(force.output);
        match force.on {
            Some(on) => {
                let v = if on { value | bit } else { value & !bit };
                self.requests.push((WRITE, write_outputs(1, v)));
                self.requests.push((WRITE, write_outputs(2, mask | bit)));
                self.writing += 2;
                self.forced |= bit;
                self.message = Some(Ok(format!(
                    "output {} forced {}",
                    force.output,
                    if on { "on" } else { "off" }
                )));
            }
            None => {
                self.release(bit, value, mask);
                self.message = Some(Ok(format!("output {} released", force.output)));
            }
        }
        // Seen at the next reading.
        self.cadence.soon();
    }

    /// Give the outputs in `bits` back to the drive: the mask first, then the value.
    fn release(&mut self, bits: u32, value: u32, mask: u32) {
        self.requests.push((WRITE, write_outputs(2, mask & !bits)));
        self.requests.push((WRITE, write_outputs(1, value & !bits)));
        self.writing += 2;
        self.forced &= !bits;
        self.cadence.soon();
    }
}
