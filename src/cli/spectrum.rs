//! `drivedeck spectrum FILE --signal NAME`: the amplitude spectrum of one signal of a
//! recording (all of it, or the span between --from and --to), with the strongest peaks
//! listed by frequency and amplitude, to find a resonance.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;

use crate::telemetry::spectrum::{Peak, Spectrum, Window, spectrum};
use crate::telemetry::{MAX_RECORDING_BYTES, Recording, load_recording};

#[derive(Args, Debug, Clone)]
pub struct SpectrumArgs {
    /// A recording (CSV or JSON, as `record` and the window write them).
    #[arg(value_name = "RECORDING")]
    pub file: PathBuf,
    /// The signal, by its column name in the file (e.g. velocity, position).
    #[arg(long, value_name = "NAME")]
    pub signal: String,
    /// The window applied before the transform: hann, hamming, blackman or rectangular.
    #[arg(long, default_value = "hann", value_name = "NAME")]
    pub window: Window,
    /// Only the samples from this time on (seconds of the recording).
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    pub from: Option<f64>,
    /// Only the samples up to this time (seconds of the recording).
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    pub to: Option<f64>,
    /// How many of the strongest peaks to list (1 to 50).
    #[arg(long, default_value_t = 5, value_name = "N",
          value_parser = clap::value_parser!(u8).range(1..=50))]
    pub peaks: u8,
    /// With --json: every bin's frequency and amplitude too.
    #[arg(long)]
    pub bins: bool,
}

/// What the command found.
struct Found {
    channel: String,
    unit: String,
    from: f64,
    to: f64,
    spectrum: Spectrum,
    peaks: Vec<Peak>,
}

pub fn run(args: &SpectrumArgs, json: bool) -> ExitCode {
    match compute(args) {
        Ok(found) => {
            if json {
                println!("{}", to_json(&found, args.bins));
            } else {
                print_text(&found);
            }
            ExitCode::SUCCESS
        }
        Err(why) => {
            eprintln!("drivedeck spectrum: {why}");
            ExitCode::from(2)
        }
    }
}

fn compute(args: &SpectrumArgs) -> Result<Found, String> {
    if let (Some(from), Some(to)) = (args.from, args.to)
        && from >= to
    {
        return Err(format!("--from {from} is not before --to {to}"));
    }
    let recording = load_recording(&args.file, MAX_RECORDING_BYTES)?;
    let column = find_column(&recording, &args.signal)?;
    let from = args.from.unwrap_or(f64::NEG_INFINITY);
    let to = args.to.unwrap_or(f64::INFINITY);
    let (times, values): (Vec<f64>, Vec<f64>) = recording
        .times
        .iter()
        .zip(&recording.columns[column])
        .filter(|(t, _)| **t >= from && **t <= to)
        .map(|(t, v)| (*t, *v))
        .unzip();
    let (Some(&first), Some(&last)) = (times.first(), times.last()) else {
        return Err(format!(
            "no samples between {} and {} s (the recording runs from {:.3} to {:.3} s)",
            shown_time(from),
            shown_time(to),
            recording.times.first().copied().unwrap_or(0.0),
            recording.times.last().copied().unwrap_or(0.0)
        ));
    };
    let info = &recording.channels[column];
    let spectrum = spectrum(&times, &values, args.window)
        .map_err(|e| format!("{} from {first:.3} to {last:.3} s: {e}", info.id))?;
    let peaks = spectrum.peaks(usize::from(args.peaks));
    Ok(Found {
        channel: info.id.clone(),
        unit: info.unit.clone(),
        from: first,
        to: last,
        spectrum,
        peaks,
    })
}

fn shown_time(t: f64) -> String {
    if t.is_finite() {
        format!("{t}")
    } else if t < 0.0 {
        "the start".into()
    } else {
        "the end".into()
    }
}

/// The column named `signal` (its id or its name, in any case).
fn find_column(recording: &Recording, signal: &str) -> Result<usize, String> {
    let wanted = signal.trim();
    recording
        .channels
        .iter()
        .position(|c| c.id.eq_ignore_ascii_case(wanted) || c.name.eq_ignore_ascii_case(wanted))
        .ok_or_else(|| {
            let names: Vec<&str> = recording.channels.iter().map(|c| c.id.as_str()).collect();
            format!(
                "no signal {:?} in the recording: it has {}",
                crate::text::shown(wanted),
                names.join(", ")
            )
        })
}

fn print_text(found: &Found) {
    let s = &found.spectrum;
    println!(
        "{}: {} samples from {:.3} to {:.3} s at {:.1} Hz, {} window; bins {:.3} Hz apart up to {:.1} Hz",
        found.channel,
        s.points,
        found.from,
        found.to,
        s.rate_hz,
        s.window.name(),
        s.rate_hz / s.points as f64,
        s.rate_hz / 2.0
    );
    if found.peaks.is_empty() {
        println!("no peak: the signal is constant");
        return;
    }
    println!("{:>4} {:>12} {:>14}", "peak", "frequency Hz", "amplitude");
    for (i, peak) in found.peaks.iter().enumerate() {
        println!(
            "{:>4} {:>12.3} {:>14.4} {}",
            i + 1,
            peak.frequency_hz,
            peak.amplitude,
            found.unit
        );
    }
}

fn to_json(found: &Found, bins: bool) -> serde_json::Value {
    let s = &found.spectrum;
    let mut value = serde_json::json!({
        "signal": found.channel,
        "unit": found.unit,
        "from_s": found.from,
        "to_s": found.to,
        "points": s.points,
        "rate_hz": s.rate_hz,
        "resolution_hz": s.rate_hz / s.points as f64,
        "window": s.window.name(),
        "peaks": found.peaks,
    });
    if bins {
        value["frequencies_hz"] = serde_json::json!(s.frequencies);
        value["amplitudes"] = serde_json::json!(s.amplitudes);
    }
    value
}
