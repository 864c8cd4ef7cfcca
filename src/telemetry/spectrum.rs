//! The amplitude spectrum of a recorded signal, to find a resonance: the samples (taken by
//! a worker whose cycle jitters, with gaps where the link was out) are put on an even grid
//! at their median interval by linear interpolation, their mean is taken off, a window is
//! applied, and a real FFT (`realfft`) gives the single-sided amplitude spectrum, scaled so
//! that a sine of amplitude A reads A at its frequency (the window's coherent gain taken
//! out). The strongest peaks are listed with their frequency refined between bins.

use realfft::RealFftPlanner;

/// The window applied before the FFT.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Window {
    /// No window: exact for a sine on a bin, wide leakage otherwise.
    Rectangular,
    /// The usual choice: low leakage, amplitude within ~15 % between bins.
    #[default]
    Hann,
    Hamming,
    /// Very low leakage, wider peaks: a weak resonance beside a strong one.
    Blackman,
}

impl Window {
    pub const ALL: [Window; 4] = [
        Window::Rectangular,
        Window::Hann,
        Window::Hamming,
        Window::Blackman,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Window::Rectangular => "rectangular",
            Window::Hann => "hann",
            Window::Hamming => "hamming",
            Window::Blackman => "blackman",
        }
    }

    /// The window's weight at sample `i` of `n`.
    fn weight(self, i: usize, n: usize) -> f64 {
        if n < 2 {
            return 1.0;
        }
        let x = 2.0 * std::f64::consts::PI * i as f64 / (n - 1) as f64;
        match self {
            Window::Rectangular => 1.0,
            Window::Hann => 0.5 - 0.5 * x.cos(),
            Window::Hamming => 0.54 - 0.46 * x.cos(),
            Window::Blackman => 0.42 - 0.5 * x.cos() + 0.08 * (2.0 * x).cos(),
        }
    }
}

impl std::str::FromStr for Window {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, Self::Err> {
        Window::ALL
            .into_iter()
            .find(|w| w.name().eq_ignore_ascii_case(text.trim()))
            .ok_or_else(|| {
                let names: Vec<&str> = Window::ALL.iter().map(|w| w.name()).collect();
                format!("no window {text:?}: choose {}", names.join(", "))
            })
    }
}

/// Why a spectrum cannot be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SpectrumError {
    #[error("{0} samples with a value: a spectrum needs at least {MIN_SAMPLES}")]
    TooFew(usize),
    #[error("the samples' times do not increase: no sampling rate to take")]
    NoRate,
    #[error(
        "{missing} of {total} samples have no value: too many gaps for a spectrum (choose a span without the outage)"
    )]
    Gaps { missing: usize, total: usize },
}

/// Fewest samples a spectrum is computed from.
pub const MIN_SAMPLES: usize = 16;
/// The most of the span that may be gaps (interpolated over) before a spectrum is refused.
const MAX_GAP_SHARE: f64 = 0.2;
/// Most points of the even grid (a long recording is cut to its last ones).
const MAX_POINTS: usize = 1 << 20;

/// A single-sided amplitude spectrum.
#[derive(Clone, Debug, PartialEq)]
pub struct Spectrum {
    /// Frequencies of the bins, Hz, from 0 to the Nyquist frequency.
    pub frequencies: Vec<f64>,
    /// Amplitudes in the signal's unit (a sine of amplitude A reads A).
    pub amplitudes: Vec<f64>,
    /// The even rate the samples were put on, Hz.
    pub rate_hz: f64,
    /// Samples on the even grid.
    pub points: usize,
    pub window: Window,
}

/// A peak of a spectrum.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Peak {
    pub frequency_hz: f64,
    pub amplitude: f64,
}

/// The spectrum of `values` sampled at `times` (seconds, non-decreasing; NaN is a gap).
pub fn spectrum(times: &[f64], values: &[f64], window: Window) -> Result<Spectrum, SpectrumError> {
    let samples: Vec<(f64, f64)> = times
        .iter()
        .zip(values)
        .filter(|(t, v)| t.is_finite() && v.is_finite())
        .map(|(t, v)| (*t, *v))
        .collect();
    if samples.len() < MIN_SAMPLES {
        return Err(SpectrumError::TooFew(samples.len()));
    }
    let total = times.len().min(values.len());
    let missing = total - samples.len();
    if missing as f64 > MAX_GAP_SHARE * total as f64 {
        return Err(SpectrumError::Gaps { missing, total });
    }
    let mut steps: Vec<f64> = samples
        .windows(2)
        .map(|w| w[1].0 - w[0].0)
        .filter(|d| *d > 0.0)
        .collect();
    if steps.is_empty() {
        return Err(SpectrumError::NoRate);
    }
    steps.sort_by(f64::total_cmp);
    let dt = steps[steps.len() / 2];
    let (first, last) = (samples[0].0, samples[samples.len() - 1].0);
    // (A span of 3.99 s at 10 ms is 400 points, not 399 for a rounding error.)
    let mut points = (((last - first) / dt + 1e-6).floor() as usize + 1).min(MAX_POINTS);
    if points < MIN_SAMPLES {
        return Err(SpectrumError::TooFew(points));
    }
    // An even length keeps the Nyquist bin.
    points -= points % 2;
    let start = last - (points - 1) as f64 * dt;
    let even = resample(&samples, start, dt, points);
    let mean = even.iter().sum::<f64>() / points as f64;
    let weights: Vec<f64> = (0..points).map(|i| window.weight(i, points)).collect();
    let gain: f64 = weights.iter().sum();
    let mut input: Vec<f64> = even
        .iter()
        .zip(&weights)
        .map(|(v, w)| (v - mean) * w)
        .collect();
    let mut planner = RealFftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(points);
    let mut output = fft.make_output_vec();
    // The lengths come from the plan itself: the transform cannot refuse them.
    if fft.process(&mut input, &mut output).is_err() {
        return Err(SpectrumError::NoRate);
    }
    let bins = output.len();
    let amplitudes = output
        .iter()
        .enumerate()
        .map(|(k, c)| {
            let one_sided = if k == 0 || (k == bins - 1) { 1.0 } else { 2.0 };
            one_sided * c.norm() / gain
        })
        .collect();
    let rate_hz = 1.0 / dt;
    let frequencies = (0..bins)
        .map(|k| k as f64 * rate_hz / points as f64)
        .collect();
    Ok(Spectrum {
        frequencies,
        amplitudes,
        rate_hz,
        points,
        window,
    })
}

/// `samples` (time-ordered) linearly interpolated at `start + i·dt`, `points` of them.
fn resample(samples: &[(f64, f64)], start: f64, dt: f64, points: usize) -> Vec<f64> {
    let mut out = Vec::with_capacity(points);
    let mut j = 0;
    for i in 0..points {
        let t = start + i as f64 * dt;
        while j + 1 < samples.len() && samples[j + 1].0 < t {
            j += 1;
        }
        let (t0, v0) = samples[j];
        let value = match samples.get(j + 1) {
            Some(&(t1, v1)) if t1 > t0 && t >= t0 => {
                v0 + (v1 - v0) * ((t - t0) / (t1 - t0)).min(1.0)
            }
            _ => v0,
        };
        out.push(value);
    }
    out
}

impl Spectrum {
    /// The `most` strongest local maxima above the DC bin, strongest first, each frequency
    /// refined by a parabola through its bin and the two beside it.
    pub fn peaks(&self, most: usize) -> Vec<Peak> {
        let a = &self.amplitudes;
        let bin = self.rate_hz / self.points as f64;
        let mut peaks: Vec<Peak> = (1..a.len().saturating_sub(1))
            .filter(|&k| a[k] > a[k - 1] && a[k] >= a[k + 1] && a[k] > 0.0)
            .map(|k| {
                let (l, c, r) = (a[k - 1], a[k], a[k + 1]);
                let denominator = l - 2.0 * c + r;
                let shift = if denominator.abs() > f64::EPSILON {
                    (0.5 * (l - r) / denominator).clamp(-0.5, 0.5)
                } else {
                    0.0
                };
                Peak {
                    frequency_hz: (k as f64 + shift) * bin,
                    amplitude: c - 0.25 * (l - r) * shift,
                }
            })
            .collect();
        peaks.sort_by(|x, y| y.amplitude.total_cmp(&x.amplitude));
        peaks.truncate(most);
        peaks
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two sines sampled at about 200 Hz with the worker's jitter, and a DC offset.
    fn two_sines(seconds: f64) -> (Vec<f64>, Vec<f64>) {
        let mut times = Vec::new();
        let mut t = 0.0;
        let mut i = 0u64;
        while t < seconds {
            times.push(t);
            // ±1 ms of jitter, deterministic.
            i = i
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            t += 0.005 + ((i >> 33) as f64 / (1u64 << 31) as f64 - 0.5) * 0.002;
        }
        let values = times
            .iter()
            .map(|t| {
                100.0
                    + 3.0 * (2.0 * std::f64::consts::PI * 12.5 * t).sin()
                    + 1.0 * (2.0 * std::f64::consts::PI * 40.0 * t).sin()
            })
            .collect();
        (times, values)
    }

    #[test]
    fn two_sines_are_found_at_their_frequencies_with_their_amplitudes() {
        let (times, values) = two_sines(8.0);
        for window in [Window::Hann, Window::Blackman, Window::Hamming] {
            let s = spectrum(&times, &values, window).unwrap();
            assert!((s.rate_hz - 200.0).abs() < 5.0, "{}", s.rate_hz);
            let peaks = s.peaks(2);
            assert_eq!(peaks.len(), 2, "{window:?}");
            assert!(
                (peaks[0].frequency_hz - 12.5).abs() < 0.1,
                "{window:?}: {peaks:?}"
            );
            assert!(
                (peaks[1].frequency_hz - 40.0).abs() < 0.2,
                "{window:?}: {peaks:?}"
            );
            // Within the window's scalloping loss (Hann: up to 15 %).
            assert!(
                (peaks[0].amplitude - 3.0).abs() < 0.45,
                "{window:?}: {peaks:?}"
            );
            assert!(
                (peaks[1].amplitude - 1.0).abs() < 0.2,
                "{window:?}: {peaks:?}"
            );
            // The DC offset is taken off.
            assert!(s.amplitudes[0] < 0.05, "{window:?}: {}", s.amplitudes[0]);
        }
    }

    #[test]
    fn a_sine_on_a_bin_reads_its_exact_amplitude_without_a_window() {
        let n = 400;
        let times: Vec<f64> = (0..n).map(|i| i as f64 * 0.01).collect();
        // 10 Hz on 100 Hz sampling over 4 s: bin 40 exactly.
        let values: Vec<f64> = times
            .iter()
            .map(|t| 2.0 * (2.0 * std::f64::consts::PI * 10.0 * t).cos())
            .collect();
        let s = spectrum(&times, &values, Window::Rectangular).unwrap();
        let peak = s.peaks(1)[0];
        assert!((peak.frequency_hz - 10.0).abs() < 1e-9, "{peak:?}");
        assert!((peak.amplitude - 2.0).abs() < 1e-9, "{peak:?}");
    }

    #[test]
    fn gaps_are_bridged_when_few_and_refused_when_many_and_too_little_is_said() {
        let (times, mut values) = two_sines(4.0);
        for v in values.iter_mut().step_by(20) {
            *v = f64::NAN;
        }
        assert!(spectrum(&times, &values, Window::Hann).is_ok());
        for v in values.iter_mut().take(400) {
            *v = f64::NAN;
        }
        assert!(matches!(
            spectrum(&times, &values, Window::Hann),
            Err(SpectrumError::Gaps { .. })
        ));
        assert_eq!(
            spectrum(&[0.0, 1.0], &[1.0, 2.0], Window::Hann),
            Err(SpectrumError::TooFew(2))
        );
        assert_eq!(
            spectrum(&[0.0; 20], &[1.0; 20], Window::Hann),
            Err(SpectrumError::NoRate)
        );
        assert_eq!("HANN".parse::<Window>(), Ok(Window::Hann));
        assert!("kaiser".parse::<Window>().is_err());
    }

    proptest::proptest! {
        #[test]
        fn any_samples_give_a_spectrum_or_a_reason_never_a_panic(
            values in proptest::collection::vec(proptest::num::f64::ANY, 0..300),
            step in 1e-4f64..1.0,
        ) {
            let times: Vec<f64> = (0..values.len()).map(|i| i as f64 * step).collect();
            if let Ok(s) = spectrum(&times, &values, Window::Hann) {
                proptest::prop_assert_eq!(s.frequencies.len(), s.amplitudes.len());
                let _ = s.peaks(5);
            }
        }
    }
}
