//! `drivedeck io` and `drivedeck output N on|off|release`: the drive's digital inputs by
//! name (60FDh: limit and home switches, interlock, the physical inputs from bit 16, with
//! their special function and inversion from 3240h), its digital outputs (60FEh:01 and
//! the enable mask :02) and its analog input; an output forced on or off is held while
//! the command runs (`--hold`, or until Ctrl-C) and released on the way out, whatever
//! ends it.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::{Args, ValueEnum};
use serde::Serialize;

use super::context::Context;
use super::failure::{Failure, failed, usage};
use super::report;
use super::session::Session;
use crate::link::LinkSpec;
use crate::od::io::{InputLine, InputWords, PHYSICAL, input_lines, output_bit};
use crate::od::{Address, DataType, Value};
use crate::worker::ObjectPath;

#[derive(Args, Debug, Clone)]
pub struct OutputArgs {
    /// The output, 1 to 8 (60FEh:01 bit 15 + N).
    #[arg(value_parser = clap::value_parser!(u8).range(1..=8))]
    pub output: u8,
    /// on or off: force it, held until --hold ends or Ctrl-C, then released; release:
    /// give an output forced by anything back to the drive.
    pub state: OutputState,
    /// How long to hold a forced output, in seconds (without: until Ctrl-C).
    #[arg(long, value_name = "SECONDS")]
    pub hold: Option<f64>,
}

#[derive(ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputState {
    On,
    Off,
    Release,
}

#[derive(Serialize, Debug)]
struct Input {
    bit: u8,
    name: String,
    on: bool,
    /// The special function the input serves (3240h:01).
    #[serde(skip_serializing_if = "Option::is_none")]
    special_function: Option<&'static str>,
    #[serde(skip_serializing_if = "Option::is_none")]
    inverted: Option<bool>,
    /// Forced by 3240h:03.
    #[serde(skip_serializing_if = "Option::is_none")]
    forced: Option<bool>,
    /// The level at the terminal, 3240h:05.
    #[serde(skip_serializing_if = "Option::is_none")]
    terminal_high: Option<bool>,
    /// "input 1 (negative limit switch, inverted)".
    label: String,
}

impl From<InputLine> for Input {
    fn from(line: InputLine) -> Self {
        Input {
            bit: line.bit,
            label: line.label(),
            on: line.on.unwrap_or(false),
            special_function: line.function,
            inverted: line.inverted,
            forced: line.forced,
            terminal_high: line.raw,
            name: line.name,
        }
    }
}

#[derive(Serialize, Debug)]
struct Output {
    number: u8,
    on: bool,
    forced: bool,
}

#[derive(Serialize, Debug)]
struct IoReport {
    link: String,
    inputs_60fd: Option<u32>,
    inputs: Vec<Input>,
    outputs_60fe: Option<u32>,
    mask_60fe: Option<u32>,
    outputs: Vec<Output>,
    analog_input_3220: Option<i64>,
}

/// An object read in its catalog type (`None`: refused or not answered).
fn read(session: &mut Session, index: u16, sub: u8, timeout: Duration) -> Option<i64> {
    session.read_int(index, sub, timeout).map(|v| v as i64)
}

fn write(
    session: &mut Session,
    index: u16,
    sub: u8,
    value: u32,
    timeout: Duration,
) -> Result<(), Failure> {
    session.write(
        Address::new(index, sub),
        DataType::Unsigned32,
        Value::Uint(u64::from(value)),
        ObjectPath::Auto,
        timeout,
    )
}

fn io_report(session: &mut Session, link: &LinkSpec, timeout: Duration) -> IoReport {
    let mut word = |index: u16, sub: u8| read(session, index, sub, timeout).map(|v| v as u32);
    let words = InputWords {
        inputs: word(0x60FD, 0),
        special: word(0x3240, 1),
        inverted: word(0x3240, 2),
        forced: word(0x3240, 3),
        raw: word(0x3240, 5),
    };
    let inputs = words.inputs;
    let list = input_lines(&words).into_iter().map(Input::from).collect();
    let outputs = read(session, 0x60FE, 1, timeout).map(|v| v as u32);
    let mask = read(session, 0x60FE, 2, timeout).map(|v| v as u32);
    IoReport {
        link: link.to_string(),
        inputs_60fd: inputs,
        inputs: list,
        outputs_60fe: outputs,
        mask_60fe: mask,
        outputs: (1..=PHYSICAL)
            .map(|n| Output {
                number: n,
                on: outputs.is_some_and(|v| v & output_bit(n) != 0),
                forced: mask.is_some_and(|v| v & output_bit(n) != 0),
            })
            .collect(),
        analog_input_3220: read(session, 0x3220, 1, timeout),
    }
}

fn print(r: &IoReport) {
    match r.inputs_60fd {
        Some(v) => println!("digital inputs 60FDh = {v:08X}h"),
        None => println!("digital inputs 60FDh: not read"),
    }
    for i in &r.inputs {
        println!("  [{}] {}", if i.on { "x" } else { " " }, i.label);
    }
    match (r.outputs_60fe, r.mask_60fe) {
        (Some(v), Some(m)) => println!("digital outputs 60FEh:01 = {v:08X}h, mask :02 = {m:08X}h"),
        _ => println!("digital outputs 60FEh: not read"),
    }
    for o in &r.outputs {
        println!(
            "  [{}] output {}{}",
            if o.on { "x" } else { " " },
            o.number,
            if o.forced { " (forced)" } else { "" }
        );
    }
    if let Some(a) = r.analog_input_3220 {
        println!("analog input 3220h:01 = {a}");
    }
}

pub fn run_io(
    link: &LinkSpec,
    json: bool,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> ExitCode {
    match Session::open(link, timeout, trace, context) {
        Ok(mut session) => {
            let r = io_report(&mut session, link, timeout);
            if json {
                report::print_json(&r, "I/O report");
            } else {
                print(&r);
            }
            ExitCode::SUCCESS
        }
        Err(f) => {
            report::print_error(&f.message, json);
            ExitCode::from(f.code)
        }
    }
}

pub fn run_output(
    link: &LinkSpec,
    args: &OutputArgs,
    json: bool,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> ExitCode {
    match output(link, args, json, timeout, trace, context) {
        Ok(said) => {
            if json {
                println!(
                    "{}",
                    serde_json::json!({ "output": args.output, "said": said })
                );
            } else {
                for line in &said {
                    println!("{line}");
                }
            }
            ExitCode::SUCCESS
        }
        Err(f) => {
            report::print_error(&f.message, json);
            ExitCode::from(f.code)
        }
    }
}

fn output(
    link: &LinkSpec,
    args: &OutputArgs,
    json: bool,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> Result<Vec<String>, Failure> {
    if let Some(hold) = args.hold
        && !(hold.is_finite() && (0.0..=86_400.0).contains(&hold))
    {
        return Err(usage(format!(
            "--hold {hold} is out of range: give 0 to 86400 seconds"
        )));
    }
    let mut session = Session::open(link, timeout, trace, context)?;
    let bit = 1u32 << (15 + args.output);
    let value = read(&mut session, 0x60FE, 1, timeout)
        .ok_or_else(|| failed("the drive did not give 60FEh:01 (digital outputs)"))?
        as u32;
    let mask = read(&mut session, 0x60FE, 2, timeout)
        .ok_or_else(|| failed("the drive did not give 60FEh:02 (output mask)"))?
        as u32;
    let n = args.output;
    if args.state == OutputState::Release {
        write(&mut session, 0x60FE, 2, mask & !bit, timeout)?;
        write(&mut session, 0x60FE, 1, value & !bit, timeout)?;
        return Ok(vec![format!(
            "output {n} released (60FEh:02 bit {} cleared)",
            15 + n
        )]);
    }
    if let Err(e) = session.catch_signals() {
        session.warnings.push(format!(
            "{e}: Ctrl-C will end drivedeck without releasing the output"
        ));
    }
    let on = args.state == OutputState::On;
    let forced_value = if on { value | bit } else { value & !bit };
    write(&mut session, 0x60FE, 2, mask | bit, timeout)?;
    write(&mut session, 0x60FE, 1, forced_value, timeout)?;
    let forced = format!(
        "output {n} forced {}{}",
        if on { "on" } else { "off" },
        match args.hold {
            Some(s) => format!(" for {s} s"),
            None => " until Ctrl-C".into(),
        }
    );
    // Said at once: whoever waits for it (a script, a test) knows it holds now.
    let mut said = vec![];
    if json {
        said.push(forced);
    } else {
        println!("{forced}");
        use std::io::Write;
        let _ = std::io::stdout().flush();
    }
    // Held until the time is up or a signal comes; released whatever ends it.
    let end = args
        .hold
        .map(|s| Instant::now() + Duration::from_secs_f64(s));
    let why = loop {
        let deadline = end.unwrap_or_else(|| Instant::now() + Duration::from_secs(3600));
        match session.next_event(deadline) {
            Ok(_) => {}
            Err(f) if f.signal.is_some() => break Some(f),
            Err(_) if end.is_some_and(|e| Instant::now() >= e) => break None,
            Err(f) => break Some(f),
        }
    };
    // The mask and the output's bit back as they were before.
    let back = (forced_value & !bit) | (value & bit);
    let released = write(&mut session, 0x60FE, 1, back, timeout)
        .and_then(|()| write(&mut session, 0x60FE, 2, mask, timeout));
    match released {
        Ok(()) => said.push(format!("output {n} released")),
        Err(f) => said.push(format!("output {n} NOT released: {}", f.message)),
    }
    match why {
        Some(f) => Err(Failure {
            message: format!("{}; output {n} was forced; {}", f.message, said.join("; ")),
            ..f
        }),
        None => Ok(said),
    }
}
