//! The commissioning record as one self-contained HTML page: inline CSS, the plots as
//! inline SVG, no script and no external resource, so a customer opens it in any
//! browser, offline, and prints it.

use std::fmt::Write;

use super::record::{Difference, DriveRecord, Figure, Plot, Record, StepRecord, Verdict};

/// `text` with HTML's special characters escaped.
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

const STYLE: &str = "
body{font-family:system-ui,-apple-system,'Segoe UI',Roboto,'DejaVu Sans',sans-serif;
 color:#1b1b1b;margin:2em auto;max-width:60em;padding:0 1em;line-height:1.4}
h1{font-size:1.6em;margin-bottom:.2em} h2{margin-top:1.6em;border-bottom:2px solid #ccc}
h3{margin-bottom:.3em}
table{border-collapse:collapse;width:100%;margin:.5em 0 1em;font-size:.92em}
th,td{border:1px solid #bbb;padding:.25em .5em;text-align:left;vertical-align:top}
th{background:#eee} td.num{text-align:right;font-variant-numeric:tabular-nums}
.verdict{font-weight:bold;text-transform:uppercase}
.verdict.passed,.banner.passed{color:#0a6b1f} .verdict.failed,.banner.failed,span.failed{color:#b00020}
.verdict.skipped,.banner.skipped{color:#555} .verdict.aborted,.banner.aborted{color:#a35200}
span.failed{font-weight:bold}
tr.failed td{background:#fde8eb} tr.aborted td{background:#fff0e0}
.banner{padding:.6em 1em;border-radius:4px;font-size:1.3em;font-weight:bold;margin:1em 0}
.banner.passed{background:#e3f4e6} .banner.failed{background:#fde8eb}
.banner.aborted{background:#fff0e0} .banner.skipped{background:#eee}
.meta td:first-child{width:14em;color:#444}
.note{color:#333} .small{font-size:.85em;color:#555} code{font-size:.95em}
svg{border:1px solid #ccc;background:#fff;max-width:100%;height:auto}
footer{margin-top:2em;border-top:1px solid #ccc;padding-top:.5em;font-size:.85em;color:#444;
 word-break:break-all}
@media print{body{margin:0;max-width:none} h2{page-break-before:auto}
 tr,svg{page-break-inside:avoid}}
";

fn verdict_cell(v: Verdict) -> String {
    format!("<span class=\"verdict {w}\">{w}</span>", w = v.word())
}

fn number(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 1e12 {
        format!("{v:.0}")
    } else if v.abs() >= 100.0 {
        format!("{v:.1}")
    } else {
        format!("{v:.3}")
    }
}

fn figure_text(f: &Figure) -> String {
    escape(&f.shown())
}

/// The measured values and limits of a step, one per line.
fn figures_cells(step: &StepRecord) -> (String, String) {
    let measured: Vec<String> = step
        .figures
        .iter()
        .map(|f| {
            let mark = match f.passed {
                Some(false) => " class=\"failed\"",
                _ => "",
            };
            format!("<span{mark}>{}: {}</span>", escape(&f.name), figure_text(f))
        })
        .collect();
    let limits: Vec<String> = step
        .figures
        .iter()
        .filter_map(|f| {
            f.limit
                .as_ref()
                .map(|l| format!("{} {}", escape(&f.name), escape(l)))
        })
        .collect();
    (measured.join("<br>"), limits.join("<br>"))
}

/// A line plot as inline SVG, with the value range and the time axis labelled and a
/// dashed line where each step began.
pub fn svg_plot(plot: &Plot, title: &str) -> String {
    const W: f64 = 720.0;
    const H: f64 = 220.0;
    const L: f64 = 64.0;
    const R: f64 = 12.0;
    const T: f64 = 22.0;
    const B: f64 = 30.0;
    let mut out = String::new();
    let _ = write!(
        out,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 {W} {H}\" width=\"{W}\" height=\"{H}\" role=\"img\" aria-label=\"{}\">",
        escape(title)
    );
    let _ = write!(
        out,
        "<text x=\"{L}\" y=\"15\" font-size=\"12\" fill=\"#333\">{} [{}]</text>",
        escape(&plot.signal),
        escape(&plot.unit)
    );
    let points: Vec<[f64; 2]> = plot
        .points
        .iter()
        .copied()
        .filter(|p| p[0].is_finite() && p[1].is_finite())
        .collect();
    if points.len() < 2 {
        let _ = write!(
            out,
            "<text x=\"{L}\" y=\"{}\" font-size=\"12\">no samples</text></svg>",
            H / 2.0
        );
        return out;
    }
    let (mut t0, mut t1, mut v0, mut v1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for p in &points {
        t0 = t0.min(p[0]);
        t1 = t1.max(p[0]);
        v0 = v0.min(p[1]);
        v1 = v1.max(p[1]);
    }
    if t1 <= t0 {
        t1 = t0 + 1.0;
    }
    if v1 - v0 < 1e-9 {
        v0 -= 1.0;
        v1 += 1.0;
    }
    let pad = (v1 - v0) * 0.05;
    let (v0, v1) = (v0 - pad, v1 + pad);
    let x = |t: f64| L + (t - t0) / (t1 - t0) * (W - L - R);
    let y = |v: f64| T + (v1 - v) / (v1 - v0) * (H - T - B);
    // Frame and zero line.
    let _ = write!(
        out,
        "<rect x=\"{L}\" y=\"{T}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"#999\"/>",
        W - L - R,
        H - T - B
    );
    if v0 < 0.0 && v1 > 0.0 {
        let _ = write!(
            out,
            "<line x1=\"{L}\" x2=\"{}\" y1=\"{y0:.1}\" y2=\"{y0:.1}\" stroke=\"#ccc\"/>",
            W - R,
            y0 = y(0.0)
        );
    }
    for start in &plot.step_starts {
        if (t0..=t1).contains(start) {
            let _ = write!(
                out,
                "<line x1=\"{sx:.1}\" x2=\"{sx:.1}\" y1=\"{T}\" y2=\"{}\" stroke=\"#8888ff\" stroke-dasharray=\"4 3\"/>",
                H - B,
                sx = x(*start)
            );
        }
    }
    let mut path = String::new();
    for p in &points {
        let _ = write!(path, "{:.1},{:.1} ", x(p[0]), y(p[1]));
    }
    let _ = write!(
        out,
        "<polyline fill=\"none\" stroke=\"#1f5fbf\" stroke-width=\"1.5\" points=\"{}\"/>",
        path.trim_end()
    );
    // Labels: the value range and the time span.
    let _ = write!(
        out,
        "<text x=\"{}\" y=\"{}\" font-size=\"11\" text-anchor=\"end\">{}</text>",
        L - 4.0,
        T + 10.0,
        number(v1)
    );
    let _ = write!(
        out,
        "<text x=\"{}\" y=\"{}\" font-size=\"11\" text-anchor=\"end\">{}</text>",
        L - 4.0,
        H - B,
        number(v0)
    );
    let _ = write!(
        out,
        "<text x=\"{L}\" y=\"{}\" font-size=\"11\">{} s</text>",
        H - 10.0,
        number(t0)
    );
    let _ = write!(
        out,
        "<text x=\"{}\" y=\"{}\" font-size=\"11\" text-anchor=\"end\">{} s</text></svg>",
        W - R,
        H - 10.0,
        number(t1)
    );
    out
}

fn differences_table(out: &mut String, title: &str, rows: &[Difference], reference: &str) {
    let _ = write!(out, "<h3>{}</h3>", escape(title));
    if rows.is_empty() {
        out.push_str("<p class=\"small\">None.</p>");
        return;
    }
    let _ = write!(
        out,
        "<table><tr><th>Object</th><th>Name</th><th>Value</th><th>{}</th></tr>",
        escape(reference)
    );
    for d in rows {
        let _ = write!(
            out,
            "<tr><td><code>{}</code></td><td>{}</td><td>{}</td><td>{}</td></tr>",
            escape(&d.object),
            escape(&d.name),
            escape(&d.value),
            escape(&d.reference)
        );
    }
    out.push_str("</table>");
}

fn drive_section(out: &mut String, drive: &DriveRecord) {
    let _ = write!(
        out,
        "<h2 id=\"drive-{id}\">{name} — {v}</h2><p class=\"small\">Link: <code>{link}</code></p>",
        id = escape(&drive.name.replace(' ', "-")),
        name = escape(&drive.name),
        v = verdict_cell(drive.verdict),
        link = escape(&drive.link)
    );
    out.push_str("<h3>Identity</h3><table class=\"meta\">");
    if drive.identity.is_empty() {
        out.push_str("<tr><td colspan=\"2\">not read</td></tr>");
    }
    for (what, value) in &drive.identity {
        let _ = write!(
            out,
            "<tr><td>{}</td><td>{}</td></tr>",
            escape(what),
            escape(value)
        );
    }
    out.push_str("</table>");
    out.push_str(
        "<h3>Steps</h3><table class=\"verdicts\"><tr><th>#</th><th>Step</th><th>Verdict</th>\
         <th>Measured</th><th>Limit</th><th>Note</th><th>Time</th></tr>",
    );
    for step in &drive.steps {
        let (measured, limits) = figures_cells(step);
        let _ = write!(
            out,
            "<tr class=\"{cls}\" data-step=\"{n}\" data-verdict=\"{cls}\"><td class=\"num\">{n}</td><td>{title}<br><span class=\"small\">{kind}</span></td>\
             <td>{v}</td><td>{measured}</td><td>{limits}</td><td class=\"note\">{note}</td>\
             <td class=\"num\">{t:.1} s</td></tr>",
            cls = step.verdict.word(),
            n = step.number,
            title = escape(&step.title),
            kind = escape(&step.kind),
            v = verdict_cell(step.verdict),
            note = escape(&step.note),
            t = step.duration_s
        );
    }
    out.push_str("</table>");
    for step in drive.steps.iter().filter(|s| s.plot.is_some()) {
        if let Some(plot) = &step.plot {
            let title = format!("Step {}: {}", step.number, step.title);
            let _ = write!(
                out,
                "<h3>{}</h3><figure>{}<figcaption class=\"small\">Dashed lines: where each move of the test began.</figcaption></figure>",
                escape(&title),
                svg_plot(plot, &title)
            );
        }
    }
    differences_table(
        out,
        "Settings that differ from the factory values",
        &drive.differs_from_factory,
        "Factory value",
    );
    match &drive.differs_from_baseline {
        Some(rows) => differences_table(
            out,
            "Settings that differ from the project's baseline",
            rows,
            "Baseline",
        ),
        None => out.push_str(
            "<h3>Settings that differ from the project's baseline</h3>\
             <p class=\"small\">The project holds no baseline (backup) for this drive.</p>",
        ),
    }
    out.push_str("<h3>Fault timeline of the run</h3>");
    if drive.timeline.is_empty() {
        out.push_str("<p class=\"small\">No fault, warning or limit during the run.</p>");
    } else {
        out.push_str("<table><tr><th>Time (UTC)</th><th>Severity</th><th>What</th></tr>");
        for e in &drive.timeline {
            let _ = write!(
                out,
                "<tr><td>{}</td><td>{}</td><td>{}</td></tr>",
                escape(&e.wall),
                escape(&e.severity),
                escape(&e.text)
            );
        }
        out.push_str("</table>");
    }
}

/// The whole page.
pub fn render(record: &Record) -> String {
    let mut out = String::with_capacity(64 * 1024);
    let title = format!("Commissioning record — {}", record.procedure);
    let _ = write!(
        out,
        "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\">\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\
         <title>{t}</title><style>{STYLE}</style></head><body><h1>{t}</h1>",
        t = escape(&title)
    );
    if record.rehearsal {
        out.push_str(
            "<p class=\"banner skipped\">Rehearsal: simulated drives stood in for the machine's. \
             Nothing here was measured on the machine.</p>",
        );
    }
    let _ = write!(
        out,
        "<p class=\"banner {v}\" id=\"verdict\">Overall: {v}</p>",
        v = record.verdict.word()
    );
    out.push_str("<table class=\"meta\">");
    for (what, value) in [
        ("Machine", record.machine.as_str()),
        ("Procedure", record.procedure.as_str()),
        ("Procedure file", record.procedure_file.as_str()),
        ("Procedure file SHA-256", record.procedure_sha256.as_str()),
        ("Run by", record.operator.as_str()),
        ("Started (UTC)", record.started.as_str()),
        ("Finished (UTC)", record.finished.as_str()),
        ("Tool", record.tool.as_str()),
    ] {
        let _ = write!(
            out,
            "<tr><td>{}</td><td>{}</td></tr>",
            escape(what),
            escape(value)
        );
    }
    out.push_str("</table>");
    if !record.description.trim().is_empty() {
        let _ = write!(out, "<p>{}</p>", escape(&record.description));
    }
    out.push_str("<table><tr><th>Drive</th><th>Verdict</th><th>Steps passed</th><th>Failed</th><th>Skipped</th></tr>");
    for d in &record.drives {
        let count = |v: Verdict| d.steps.iter().filter(|s| s.verdict == v).count();
        let _ = write!(
            out,
            "<tr class=\"{cls}\"><td><a href=\"#drive-{id}\">{name}</a></td><td>{v}</td><td class=\"num\">{p}</td><td class=\"num\">{f}</td><td class=\"num\">{s}</td></tr>",
            cls = d.verdict.word(),
            id = escape(&d.name.replace(' ', "-")),
            name = escape(&d.name),
            v = verdict_cell(d.verdict),
            p = count(Verdict::Passed),
            f = count(Verdict::Failed),
            s = count(Verdict::Skipped)
        );
    }
    out.push_str("</table>");
    for drive in &record.drives {
        drive_section(&mut out, drive);
    }
    let _ = writeln!(
        out,
        "<footer>SHA-256 of this record's data (the JSON file beside it, with this field empty): \
         <code id=\"sha256\">{}</code></footer></body></html>",
        escape(&record.sha256)
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_from_the_drive_or_the_file_cannot_open_a_tag() {
        assert_eq!(
            escape("<script>alert('x') & \"y\"</script>"),
            "&lt;script&gt;alert(&#39;x&#39;) &amp; &quot;y&quot;&lt;/script&gt;"
        );
    }

    #[test]
    fn a_plot_is_inline_svg_with_its_range() {
        let plot = Plot {
            signal: "position 6064h".into(),
            unit: "units".into(),
            points: vec![[0.0, 0.0], [0.5, 1000.0], [1.0, 2000.0]],
            step_starts: vec![0.0, 0.5],
        };
        let svg = svg_plot(&plot, "t");
        assert!(svg.starts_with("<svg xmlns=\"http://www.w3.org/2000/svg\""));
        assert!(svg.contains("<polyline"));
        assert_eq!(svg.matches("stroke-dasharray").count(), 2);
        assert!(svg.ends_with("</svg>"));
    }
}
