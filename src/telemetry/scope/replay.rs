//! A recording opened from a file as a scope of its own: the plots draw it the way they
//! draw the live history (same decimation, lanes, markers), with no drive connected.

use super::{Builtin, Kind, Scope, SignalDef, Source};
use crate::telemetry::recording::Recording;
use crate::telemetry::ring::Ring;

impl Scope {
    /// The recording's rows as a history of their own, one signal per channel: the
    /// built-in signals by their ids (drawn as live: bit words as lanes), every other
    /// channel as a line. Rows whose times go backwards, or are not numbers, are refused
    /// with the row named (a file is data from outside, it may say anything).
    pub fn from_recording(recording: &Recording) -> Result<Scope, String> {
        let channels = recording.channels.len();
        if recording.is_empty() {
            return Err("it holds no samples".into());
        }
        if let Some(n) = recording
            .columns
            .iter()
            .position(|c| c.len() != recording.times.len())
        {
            return Err(format!(
                "channel {} has {} values for {} times",
                n + 1,
                recording.columns.get(n).map_or(0, Vec::len),
                recording.times.len()
            ));
        }
        let signals: Vec<SignalDef> = recording
            .channels
            .iter()
            .enumerate()
            .map(|(column, info)| {
                let builtin = Builtin::from_id(&info.id);
                SignalDef {
                    source: builtin.map_or(Source::Recorded, Source::Builtin),
                    info: info.clone(),
                    kind: builtin.map_or(Kind::Analog, Builtin::kind),
                    column,
                    shown: builtin.is_none_or(Builtin::shown_by_default),
                    auto: builtin.is_some(),
                }
            })
            .collect();
        let mut ring = Ring::new(recording.len(), channels);
        let mut row = vec![f64::NAN; channels];
        for (i, &t) in recording.times.iter().enumerate() {
            for (slot, column) in row.iter_mut().zip(&recording.columns) {
                *slot = column.get(i).copied().unwrap_or(f64::NAN);
            }
            ring.push(t, &row)
                .map_err(|e| format!("row {} of the samples: {e}", i + 1))?;
        }
        let mut scope = Scope {
            ring,
            signals,
            ..Scope::new(1)
        };
        scope.meta = recording.meta.clone();
        for marker in &recording.markers {
            if marker.t.is_finite() {
                scope.mark(marker.t, marker.text.clone());
            }
        }
        Ok(scope)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::telemetry::recording::{ChannelInfo, Marker, Metadata};

    fn channel(id: &str, unit: &str) -> ChannelInfo {
        ChannelInfo {
            id: id.into(),
            name: id.into(),
            unit: unit.into(),
        }
    }

    #[test]
    fn a_recording_becomes_a_history_the_plots_draw_like_the_live_one() {
        let recording = Recording {
            meta: Metadata {
                trigger_time_s: Some(0.1),
                ..Metadata::default()
            },
            channels: vec![
                channel("position", "0.1°"),
                channel("pdi_status", ""),
                channel("2031h_00h", "mA"),
                channel("return_value", ""),
            ],
            times: vec![0.0, 0.1, 0.2],
            columns: vec![
                vec![0.0, 10.0, 20.0],
                vec![1.0, 3.0, 3.0],
                vec![5.0, f64::NAN, 7.0],
                vec![0.0, 0.0, 0.0],
            ],
            markers: vec![Marker {
                t: 0.1,
                text: "Move".into(),
            }],
        };
        let scope = Scope::from_recording(&recording).expect("a scope");
        assert_eq!(scope.ring().len(), 3);
        assert_eq!(scope.ring().value(2, 0), Some(20.0));
        let status = scope.signal("pdi_status").expect("status");
        assert_eq!(status.kind, Kind::Bits);
        let object = scope.signal("2031h_00h").expect("object");
        assert_eq!(
            (object.kind, object.source),
            (Kind::Analog, Source::Recorded)
        );
        assert!(scope.is_drawn(object));
        // ReturnValue is not drawn by default, live or recorded.
        let rv = scope.signal("return_value").expect("rv");
        assert!(!rv.shown);
        assert_eq!(scope.markers().count(), 1);
        assert_eq!(scope.meta.trigger_time_s, Some(0.1));
    }

    #[test]
    fn a_recording_that_makes_no_history_is_refused_with_the_reason() {
        let mut recording = Recording {
            meta: Metadata::default(),
            channels: vec![channel("position", "")],
            times: vec![0.0, 0.2, 0.1],
            columns: vec![vec![1.0, 2.0, 3.0]],
            markers: Vec::new(),
        };
        let error = Scope::from_recording(&recording).err().unwrap_or_default();
        assert!(
            error.starts_with("row 3 of the samples: sample time 0.1 s is before"),
            "{error}"
        );
        recording.times = vec![0.0, f64::NAN, 0.3];
        let error = Scope::from_recording(&recording).err().unwrap_or_default();
        assert!(error.contains("not a finite number"), "{error}");
        recording.columns = vec![vec![1.0]];
        let error = Scope::from_recording(&recording).err().unwrap_or_default();
        assert_eq!(error, "channel 1 has 1 values for 3 times");
        recording.times.clear();
        recording.columns = vec![Vec::new()];
        assert_eq!(
            Scope::from_recording(&recording).err().as_deref(),
            Some("it holds no samples")
        );
    }
}
