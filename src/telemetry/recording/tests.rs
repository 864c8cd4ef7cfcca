use super::*;
use proptest::prelude::*;

fn same_f64(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

fn same_opt(a: Option<f64>, b: Option<f64>) -> bool {
    match (a, b) {
        (Some(a), Some(b)) => same_f64(a, b),
        (a, b) => a.is_none() && b.is_none(),
    }
}

/// Equal, bit for bit, with NaN equal to NaN.
fn assert_same(a: &Recording, b: &Recording) {
    let (ma, mb) = (&a.meta, &b.meta);
    assert_eq!(ma.text_fields(), mb.text_fields());
    assert!(
        same_opt(ma.trigger_time_s, mb.trigger_time_s),
        "{ma:?} {mb:?}"
    );
    assert!(same_opt(ma.rate_hz, mb.rate_hz), "{ma:?} {mb:?}");
    assert_eq!(a.channels, b.channels);
    assert_eq!(a.markers.len(), b.markers.len());
    for (x, y) in a.markers.iter().zip(&b.markers) {
        assert!(same_f64(x.t, y.t) && x.text == y.text, "{x:?} {y:?}");
    }
    assert_eq!(a.times.len(), b.times.len());
    for (x, y) in a.times.iter().zip(&b.times) {
        assert!(same_f64(*x, *y), "time {x} != {y}");
    }
    assert_eq!(a.columns.len(), b.columns.len());
    for (ca, cb) in a.columns.iter().zip(&b.columns) {
        assert_eq!(ca.len(), cb.len());
        for (x, y) in ca.iter().zip(cb) {
            assert!(same_f64(*x, *y), "value {x} != {y}");
        }
    }
}

fn sample() -> Recording {
    Recording {
        meta: Metadata {
            vendor: Some("Nanotec".into()),
            product: Some("PD4-E601L42-E-65-2".into()),
            revision: Some("FIR-v2213".into()),
            serial: Some("1234, \"5678\"".into()),
            device_name: Some("axis | left\nline two".into()),
            link: Some("Modbus TCP 192.168.2.10:502".into()),
            started: Some("2025-01-31 14:03:07".into()),
            trigger: Some("position rises through 1000".into()),
            trigger_time_s: Some(12.5),
            rate_hz: Some(1000.0),
            rate_asked_hz: Some(2000.0),
            note: Some(" back\\slash ".into()),
            ended_early: Some("the link was lost: no answer | at t = 3.5 s".into()),
            cut: None,
            gaps: None,
        },
        channels: vec![
            ChannelInfo {
                id: "position".into(),
                name: "Position 6064h".into(),
                unit: "0.1°".into(),
            },
            ChannelInfo {
                id: "torque".into(),
                name: "Torque 6077h".into(),
                unit: "‰".into(),
            },
            ChannelInfo {
                id: "status".into(),
                name: "Status word 6041h".into(),
                unit: String::new(),
            },
            ChannelInfo {
                id: "odd, \"one\"".into(),
                name: "a | b".into(),
                unit: "m/s [x]".into(),
            },
        ],
        times: vec![12.2, 12.201, 12.201, 12.2 + 0.1, 1e6],
        columns: vec![
            vec![998.0, 999.0, f64::NAN, -0.0, 1e300],
            vec![0.1, f64::NAN, 5e-324, -12.75, 0.0],
            vec![4663.0, 4663.0, 1591.0, f64::NAN, f64::NAN],
            vec![f64::NAN; 5],
        ],
        markers: vec![
            Marker {
                t: 12.5,
                text: "trigger".into(),
            },
            Marker {
                t: 12.3,
                text: "a | marker\r\nwith, everything \"\\\"".into(),
            },
        ],
    }
}

#[test]
fn csv_round_trip_is_exact() {
    let recording = sample();
    let text = recording.to_csv();
    assert!(text.starts_with("# drivedeck recording\n# vendor: Nanotec\n"));
    assert!(text.contains("# channel: position | Position 6064h | 0.1°\n"));
    assert!(text.contains("# channel: status | Status word 6041h | \n"));
    assert!(text.contains("# device_name: axis \\| left\\nline two\n"));
    assert!(
        text.contains("t [s],position [0.1°],torque [‰],status,\"odd, \"\"one\"\" [m/s [x]]\"\n")
    );
    assert!(text.contains("\n12.2,998,0.1,4663,\n"));
    assert!(text.contains("\n12.201,999,,4663,\n"));
    assert_same(&Recording::from_csv(&text).unwrap(), &recording);
    // Windows line ends and a byte-order mark.
    let crlf = format!("\u{feff}{}", text.replace('\n', "\r\n"));
    assert_same(&Recording::from_csv(&crlf).unwrap(), &recording);
}

#[test]
fn json_round_trip_is_exact() {
    let recording = sample();
    let text = recording.to_json();
    assert!(text.contains("\"t\":[12.2,12.201,"));
    assert!(text.contains("[998.0,999.0,null,-0.0,"));
    assert_same(&Recording::from_json(&text).unwrap(), &recording);
}

#[test]
fn empty_recordings_round_trip() {
    let empty = Recording {
        meta: Metadata::default(),
        channels: Vec::new(),
        times: Vec::new(),
        columns: Vec::new(),
        markers: Vec::new(),
    };
    assert_eq!(empty.to_csv(), "# drivedeck recording\nt [s]\n");
    assert_same(&Recording::from_csv(&empty.to_csv()).unwrap(), &empty);
    assert_same(&Recording::from_json(&empty.to_json()).unwrap(), &empty);
    assert!(empty.is_empty());
    assert_eq!(empty.duration(), 0.0);
    let mut one = empty.clone();
    one.times = vec![1.0, 2.0];
    assert_same(&Recording::from_csv(&one.to_csv()).unwrap(), &one);
    assert_eq!(one.len(), 2);
    assert_eq!(one.duration(), 1.0);
}

#[test]
fn plain_csv_names_channels_from_the_header() {
    let text = "time,position [0.1°], torque [‰] ,status\n0,1,2,3\n0.5,,,\n1,4,5,6";
    let r = Recording::from_csv(text).unwrap();
    let ids: Vec<_> = r.channels.iter().map(|c| c.id.as_str()).collect();
    let units: Vec<_> = r.channels.iter().map(|c| c.unit.as_str()).collect();
    assert_eq!(ids, ["position", "torque", "status"]);
    assert_eq!(units, ["0.1°", "‰", ""]);
    assert_eq!(r.channels[0].name, "position");
    assert_eq!(r.times, [0.0, 0.5, 1.0]);
    assert_eq!(r.columns[2][2], 6.0);
    assert!(r.columns[0][1].is_nan());
    assert_eq!(r.meta, Metadata::default());
}

#[test]
fn values_that_are_not_finite_are_gaps_and_said_so() {
    let text = "time,position,velocity\n0,1,2\n0.5,inf,3\n1,-inf,INF\n1.5,4,5";
    let r = Recording::from_csv(text).unwrap();
    assert!(r.columns[0][1].is_nan() && r.columns[0][2].is_nan() && r.columns[1][2].is_nan());
    assert_eq!(r.columns[0][3], 4.0);
    let gaps = r.meta.gaps.as_deref().unwrap_or_default();
    assert!(
        gaps.contains("drawn as gaps: position 2, velocity 1"),
        "{gaps}"
    );
    // A file with none says nothing.
    assert_eq!(Recording::from_csv("time,a\n0,1").unwrap().meta.gaps, None);
}

fn error_line(text: &str) -> (usize, String) {
    match Recording::from_csv(text) {
        Err(RecordingError::Csv { line, what }) => (line, what),
        other => panic!("expected a CSV error, got {other:?}"),
    }
}

#[test]
fn malformed_csv_names_the_line() {
    let head = "# drivedeck recording\n# channel: a | A | m\n# channel: b | B |\nt [s],a [m],b\n";
    // A bad number.
    let (line, what) = error_line(&format!("{head}0,1,2\n1,x,2\n"));
    assert_eq!((line, what.as_str()), (6, "bad number \"x\""));
    // Wrong cell counts.
    assert_eq!(
        error_line(&format!("{head}0,1,2\n1,2\n")),
        (6, "2 cells, expected 3".into())
    );
    assert_eq!(error_line(&format!("{head}0,1,2,3\n")).0, 5);
    // Missing and backwards times.
    assert_eq!(error_line(&format!("{head}0,1,2\n,1,2\n")).0, 6);
    assert_eq!(error_line(&format!("{head}1,1,2\n\n0.5,1,2\n")).0, 7);
    // The header does not match the channel lines.
    assert_eq!(error_line("# channel: a | A | m\nt [s],a,b\n0,1,2\n").0, 2);
    // No header: numbers first, or nothing but comments.
    assert_eq!(error_line("0,1\n1,2\n").0, 1);
    assert_eq!(error_line("# drivedeck recording\n\n0,1\n").0, 3);
    assert_eq!(
        error_line("# drivedeck recording\n# vendor: x\n"),
        (3, "no header row".into())
    );
    assert_eq!(error_line("").0, 1);
    // Bad metadata and marker lines.
    assert_eq!(
        error_line("# drivedeck recording\n# rate_hz: fast\nt [s]\n").0,
        2
    );
    assert_eq!(error_line("# marker: soon | go\nt [s]\n").0, 1);
    assert_eq!(error_line("# channel: a | b | c | d\nt [s],a\n").0, 1);
    assert_eq!(error_line("t [s],a\n# channel: a | b | c\n").0, 2);
    // Quoting: an unclosed quote names the record's line; a quoted line break counts.
    assert_eq!(error_line("t [s],\"a\n0,1\n").0, 1);
    assert_eq!(error_line("t [s],\"a\"x\n").0, 1);
    assert_eq!(error_line("t [s],\"a\nb\"\n0,1\n1,?\n").0, 4);
}

#[test]
fn errors_read_well() {
    let e = Recording::from_csv("t [s],a\n0,1,2\n").unwrap_err();
    assert_eq!(e.to_string(), "line 2: 3 cells, expected 2");
    assert!(matches!(
        Recording::from_json("{"),
        Err(RecordingError::Json(_))
    ));
    let bad = r#"{"channels":[{"id":"a"}],"t":[0,1],"columns":[[1]]}"#;
    assert!(matches!(
        Recording::from_json(bad),
        Err(RecordingError::Invalid(_))
    ));
    let bad = r#"{"channels":[],"t":[1,0],"columns":[]}"#;
    assert!(matches!(
        Recording::from_json(bad),
        Err(RecordingError::Invalid(_))
    ));
    let bad = r#"{"channels":[],"t":[0,null],"columns":[]}"#;
    assert!(matches!(
        Recording::from_json(bad),
        Err(RecordingError::Invalid(_))
    ));
    // meta and markers may be left out; a channel needs only its id.
    let ok = r#"{"channels":[{"id":"a"}],"t":[0,1],"columns":[[1,null]]}"#;
    let r = Recording::from_json(ok).unwrap();
    assert_eq!(r.channels[0].unit, "");
    assert!(r.columns[0][1].is_nan());
}

fn odd_text() -> impl Strategy<Value = String> {
    prop_oneof![any::<String>(), "[ a-z0-9,;\"|\\\\\n\r\t#:\\[\\]°‰µ]{0,12}",]
}

fn value() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(f64::NAN),
        Just(0.0),
        Just(-0.0),
        prop::num::f64::NORMAL | prop::num::f64::SUBNORMAL | prop::num::f64::ZERO,
        (-1e6..1e6f64),
    ]
}

fn finite() -> impl Strategy<Value = f64> {
    prop::num::f64::NORMAL | prop::num::f64::SUBNORMAL | prop::num::f64::ZERO
}

fn recording() -> impl Strategy<Value = Recording> {
    let meta = (
        prop::collection::vec(prop::option::of(odd_text()), 10),
        prop::option::of(finite()),
        prop::option::of(finite()),
        prop::option::of(finite()),
    )
        .prop_map(|(text, trigger_time_s, rate_hz, rate_asked_hz)| {
            let mut meta = Metadata {
                trigger_time_s,
                rate_hz,
                rate_asked_hz,
                ..Metadata::default()
            };
            let fields = [
                &mut meta.vendor,
                &mut meta.product,
                &mut meta.revision,
                &mut meta.serial,
                &mut meta.device_name,
                &mut meta.link,
                &mut meta.started,
                &mut meta.trigger,
                &mut meta.note,
                &mut meta.ended_early,
            ];
            for (field, value) in fields.into_iter().zip(text) {
                *field = value;
            }
            meta
        });
    let channel = (odd_text(), odd_text(), odd_text()).prop_map(|(id, name, unit)| ChannelInfo {
        id,
        name,
        unit,
    });
    let marker = (finite(), odd_text()).prop_map(|(t, text)| Marker { t, text });
    (
        meta,
        prop::collection::vec(channel, 0..4),
        prop::collection::vec(marker, 0..3),
        0usize..12,
    )
        .prop_flat_map(|(meta, channels, markers, rows)| {
            let n = channels.len();
            (
                Just(meta),
                Just(channels),
                Just(markers),
                prop::collection::vec(finite(), rows),
                prop::collection::vec(prop::collection::vec(value(), rows), n),
            )
        })
        .prop_map(|(meta, channels, markers, mut times, columns)| {
            times.sort_by(f64::total_cmp);
            Recording {
                meta,
                channels,
                times,
                columns,
                markers,
            }
        })
}

proptest! {
    #[test]
    fn round_trips_are_exact(recording in recording()) {
        assert_same(&Recording::from_csv(&recording.to_csv()).unwrap(), &recording);
        assert_same(&Recording::from_json(&recording.to_json()).unwrap(), &recording);
    }

    #[test]
    fn reading_arbitrary_text_does_not_panic(text in any::<String>()) {
        let _ = Recording::from_csv(&text);
        let _ = Recording::from_json(&text);
    }
}

#[test]
fn the_header_says_the_rate_achieved_beside_the_one_asked() {
    let mut recording = Recording {
        meta: Metadata {
            rate_hz: Some(1000.0),
            ..Metadata::default()
        },
        channels: vec![],
        // An I/O connection at RPI 10 ms: one row every 10 ms, 1000 Hz asked.
        times: (0..=100).map(|i| f64::from(i) * 0.010).collect(),
        columns: vec![],
        markers: vec![],
    };
    recording.set_rates(1000.0);
    assert_eq!(recording.meta.rate_hz, Some(100.0));
    assert_eq!(recording.meta.rate_asked_hz, Some(1000.0));
    // One row says nothing about a rate.
    recording.times.truncate(1);
    recording.set_rates(1000.0);
    assert_eq!(recording.meta.rate_hz, None);
    assert_eq!(recording.achieved_rate(), 0.0);
}

/// A file written as taken, cut by a crash at any byte after its header: it opens with
/// every whole row before the cut, and says it was cut after how many at what time; the
/// same file ended normally says nothing of the kind and has what its end line says.
#[test]
fn a_streamed_file_cut_anywhere_opens_with_its_whole_rows_and_says_it_was_cut() {
    use super::stream::{Layout, StreamWriter};
    let dir = tempfile::tempdir().expect("temp dir");
    let channels = vec![
        ChannelInfo {
            id: "position".into(),
            name: "Position 6064h".into(),
            unit: "0.1°".into(),
        },
        ChannelInfo {
            id: "torque".into(),
            name: "Torque 6077h".into(),
            unit: "‰".into(),
        },
    ];
    let head = Metadata {
        vendor: Some("0000026Ch".into()),
        rate_asked_hz: Some(100.0),
        ..Metadata::default()
    };
    for (layout, name) in [(Layout::Csv, "run.csv"), (Layout::Json, "run.json")] {
        let path = dir.path().join(name);
        let mut writer = StreamWriter::create(
            std::fs::File::create(&path).expect("file"),
            layout,
            &head,
            &channels,
        )
        .expect("header");
        let header_len = std::fs::metadata(&path).expect("written").len() as usize;
        for i in 0..40 {
            let t = f64::from(i) * 0.01;
            let torque = if i % 3 == 0 { f64::NAN } else { -f64::from(i) };
            writer.row(t, &[f64::from(i) * 1.5, torque]).expect("row");
            if i == 20 {
                writer
                    .mark(&Marker {
                        t: 0.205,
                        text: "outage: an exchange with the drive failed: no answer (90°)".into(),
                    })
                    .expect("mark");
            }
        }
        writer.flush().expect("flush");
        let cut = std::fs::read(&path).expect("read");
        let rows_before = |bytes: &[u8]| {
            let whole = match bytes.iter().rposition(|b| *b == b'\n') {
                Some(n) => &bytes[..=n],
                None => &bytes[..0],
            };
            String::from_utf8_lossy(whole)
                .lines()
                .filter(|l| match layout {
                    Layout::Csv => l.starts_with(|c: char| c.is_ascii_digit()),
                    Layout::Json => l.starts_with('[') || l.starts_with(",["),
                })
                .count()
        };
        for n in header_len..=cut.len() {
            let part = dir.path().join(format!("part-{name}"));
            std::fs::write(&part, &cut[..n]).expect("part written");
            let read =
                crate::telemetry::load_recording(&part, crate::telemetry::MAX_RECORDING_BYTES);
            let rows = rows_before(&cut[..n]);
            if rows == 0 {
                // The header alone: a refusal that names the file ("holds no samples").
                let error = read.expect_err("no rows");
                assert!(error.contains("holds no samples"), "{name} at {n}: {error}");
                continue;
            }
            let recording = read.unwrap_or_else(|e| panic!("{name} cut at byte {n}: {e}"));
            assert_eq!(recording.len(), rows, "{name} cut at byte {n}");
            let last = recording.times.last().copied();
            assert_eq!(last, Some(f64::from(rows as u32 - 1) * 0.01));
            assert_eq!(
                recording.meta.cut.as_deref(),
                Some(super::cut_text(rows, last).as_str()),
                "{name} cut at byte {n}"
            );
            assert!(
                recording
                    .meta
                    .cut
                    .as_deref()
                    .is_some_and(|c| c.contains("the recording did not end normally")),
                "{:?}",
                recording.meta.cut
            );
            assert_eq!(recording.channels, channels);
            assert_eq!(recording.meta.vendor.as_deref(), Some("0000026Ch"));
            assert!(
                recording.columns[1][0].is_nan(),
                "no sample stays no sample"
            );
        }
        // The trigger's time is written when it fires; the end is handed the whole
        // metadata, as `record` does, and adds only what is new.
        let fired = Metadata {
            trigger_time_s: Some(0.25),
            ..Metadata::default()
        };
        writer.meta(&fired).expect("meta");
        let last = Metadata {
            rate_hz: Some(100.0),
            ended_early: Some("interrupted by SIGINT at t = 0.390 s".into()),
            trigger_time_s: Some(0.25),
            ..head.clone()
        };
        writer.finish(&last, 40).expect("end");
        if layout == Layout::Csv {
            let text = std::fs::read_to_string(&path).expect("text");
            for key in ["trigger_time_s", "rate_asked_hz", "vendor", "rate_hz"] {
                assert_eq!(
                    text.matches(&format!("# {key}:")).count(),
                    1,
                    "{key} once in\n{text}"
                );
            }
        }
        let recording =
            crate::telemetry::load_recording(&path, crate::telemetry::MAX_RECORDING_BYTES)
                .expect("a complete file");
        assert_eq!(recording.meta.cut, None, "{name}: ended normally");
        assert_eq!(recording.len(), 40);
        assert_eq!(recording.meta.rate_hz, Some(100.0));
        assert_eq!(recording.meta.rate_asked_hz, Some(100.0));
        assert_eq!(recording.meta.ended_early, last.ended_early);
        assert_eq!(recording.meta.trigger_time_s, Some(0.25));
        assert_eq!(
            recording.markers,
            vec![Marker {
                t: 0.205,
                text: "outage: an exchange with the drive failed: no answer (90°)".into(),
            }]
        );
        if layout == Layout::Json {
            // Once complete, the file is one JSON document for any JSON tool.
            let text = std::fs::read_to_string(&path).expect("text");
            let value: serde_json::Value = serde_json::from_str(&text).expect("valid JSON");
            // 40 rows, the marker and the trigger's time.
            assert_eq!(value["rows"].as_array().map(Vec::len), Some(42));
            assert_eq!(value["end"]["samples"], 40);
        }
    }
}

#[test]
fn the_worker_s_words_about_the_link_become_markers() {
    assert_eq!(
        super::link_mark("an exchange with the drive failed: no answer within 500 ms; trying again (the link counts as lost after 3 failures in a row)").as_deref(),
        Some("outage: an exchange with the drive failed: no answer within 500 ms; trying again (the link counts as lost after 3 failures in a row)")
    );
    assert_eq!(
        super::link_mark("the link recovered after 6 failed exchange(s) in a row").as_deref(),
        Some("recovered: the link recovered after 6 failed exchange(s) in a row")
    );
    assert_eq!(
        super::link_mark("link: no answer within 166 ms, answered on try 2").as_deref(),
        Some("retry: no answer within 166 ms, answered on try 2")
    );
    // A connection that reset under the session, opened again in place.
    assert_eq!(
        super::link_mark("the connection to the drive failed: connection reset by peer; opening it again (the link counts as lost after 3 failures in a row)").as_deref(),
        Some("outage: the connection to the drive failed: connection reset by peer; opening it again (the link counts as lost after 3 failures in a row)")
    );
    assert_eq!(
        super::link_mark("the connection to the drive was opened again after 1 failed exchange(s) (connection reset by peer); the session goes on").as_deref(),
        Some("recovered: the connection to the drive was opened again after 1 failed exchange(s) (connection reset by peer); the session goes on")
    );
    assert_eq!(super::link_mark("PDO mapping changed"), None);
}
