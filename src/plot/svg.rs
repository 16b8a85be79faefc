//! The plot of a run as an SVG document: three panels over one time axis (joint positions,
//! joint velocities with their limits, TCP speed with the override), job markers across all
//! panels, shaded spans where the primary sequence was interrupted or two moves blend, a
//! legend, a title and a caption. Pure: a [`Recording`] in, the document's text out.
//!
//! Traces are thinned to the drawing's resolution: per pixel column the first, lowest,
//! highest and last point are kept, so that peaks survive and the file stays small however
//! long the run. Each panel's `<g>` carries its data range and pixel extent (`data-low`,
//! `data-high`, `data-top`, `data-bottom`) and each trace its joint, so that tools (and the
//! system test) can read values back.

use std::fmt::{self, Write};

use shared_types::ipc::AXES;

use super::axis::{self, Range, Scale};
use super::recording::{JobState, Recording, Sample};

/// Size of the drawing (px).
const WIDTH: f64 = 1240.0;
const HEIGHT: f64 = 1010.0;
/// The plotting area's left and right edges; the legend sits right of it.
const LEFT: f64 = 80.0;
const RIGHT: f64 = 1020.0;
/// Top of the first panel, height of each panel and the gap between them.
const TOP: f64 = 100.0;
const PANEL_HEIGHT: f64 = 240.0;
const PANEL_GAP: f64 = 40.0;
/// Ticks an axis aims at.
const Y_TICKS: usize = 5;
const X_TICKS: usize = 10;
/// Space around the data inside a panel, as a fraction of its range.
const MARGIN: f64 = 0.05;

/// Colours of joints 1 to 6, the TCP speed and the override.
const JOINT_COLOURS: [&str; AXES] = [
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b",
];
const TCP_COLOUR: &str = "#000000";
const OVERRIDE_COLOUR: &str = "#999999";

/// What the plot says besides the data.
#[derive(Debug, Clone)]
pub struct PlotLabels<'a> {
    /// First line at the top, e.g. the program and the date.
    pub title: &'a str,
    /// Lines at the bottom: where the data came from and how it was thinned.
    pub caption: &'a [String],
    /// Joint velocity limits (deg/s), drawn as dashed lines at ±limit.
    pub velocity_limits_deg_s: [f64; AXES],
}

/// The SVG document of `recording`.
pub fn render(recording: &Recording, labels: &PlotLabels<'_>) -> String {
    let mut svg = String::with_capacity(64 * 1024);
    // Writing into a String cannot fail.
    let _ = draw(&mut svg, recording, labels);
    svg
}

/// One panel: what it shows and where.
struct Panel {
    id: &'static str,
    unit_label: &'static str,
    top: f64,
    y: Scale,
}

impl Panel {
    fn new(index: usize, id: &'static str, unit_label: &'static str, range: Range) -> Self {
        let top = TOP + index as f64 * (PANEL_HEIGHT + PANEL_GAP);
        Self {
            id,
            unit_label,
            top,
            y: Scale {
                range: range.rounded_to_ticks(Y_TICKS),
                from: top + PANEL_HEIGHT,
                to: top,
            },
        }
    }

    fn bottom(&self) -> f64 {
        self.top + PANEL_HEIGHT
    }
}

fn draw(out: &mut String, recording: &Recording, labels: &PlotLabels<'_>) -> fmt::Result {
    let samples = recording.samples();
    let degrees = |rad: f64| rad.to_degrees();
    let x = time_scale(recording);
    let positions = Panel::new(
        0,
        "positions",
        "joint position (deg)",
        Range::of(
            samples.iter().flat_map(|s| s.q.map(degrees)),
            MARGIN,
            Range {
                low: -180.0,
                high: 180.0,
            },
        ),
    );
    let limits = labels.velocity_limits_deg_s;
    let velocities = Panel::new(
        1,
        "velocities",
        "joint velocity (deg/s)",
        Range::of(
            samples
                .iter()
                .flat_map(|s| s.qd.map(degrees))
                .chain(limits)
                .chain(limits.map(|l| -l)),
            MARGIN,
            Range {
                low: -1.0,
                high: 1.0,
            },
        ),
    );
    let speeds = Range::of(
        samples.iter().map(|s| s.tcp_speed * 1e3).chain([0.0]),
        MARGIN,
        Range {
            low: 0.0,
            high: 1.0,
        },
    );
    // A speed is never negative: the axis starts at 0 (the margin only above).
    let speeds = Range {
        low: 0.0,
        high: speeds.high.max(1.0),
    };
    let tcp = Panel::new(2, "tcp", "TCP speed (mm/s)", speeds);
    let panels = [&positions, &velocities, &tcp];

    writeln!(
        out,
        r##"<?xml version="1.0" encoding="UTF-8"?>
<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{HEIGHT}" viewBox="0 0 {WIDTH} {HEIGHT}" font-family="sans-serif" font-size="12">
<rect x="0" y="0" width="{WIDTH}" height="{HEIGHT}" fill="#ffffff"/>
<text x="{LEFT}" y="30" font-size="18" font-weight="bold">{}</text>"##,
        escape(labels.title)
    )?;
    for panel in panels {
        frame(out, panel, &x)?;
        for band in BANDS {
            spans(out, panel, &x, samples, &band)?;
        }
    }
    joint_traces(out, &positions, &x, samples, |s| s.q)?;
    for (joint, limit) in limits.iter().enumerate() {
        for sign in [1.0, -1.0] {
            let y = velocities.y.map(sign * limit);
            writeln!(
                out,
                r#"<line class="limit" data-joint="{}" x1="{LEFT}" y1="{y:.1}" x2="{RIGHT}" y2="{y:.1}" stroke="{}" stroke-width="1" stroke-dasharray="6 4"/>"#,
                joint + 1,
                JOINT_COLOURS[joint]
            )?;
        }
    }
    joint_traces(out, &velocities, &x, samples, |s| s.qd)?;
    override_trace(out, &tcp, &x, samples)?;
    let trace = samples.iter().map(|s| (s.t_s, s.tcp_speed * 1e3));
    polyline(out, &tcp, &x, TCP_COLOUR, 0, trace)?;
    markers(out, recording, &x, tcp.bottom())?;
    time_axis(out, &x, tcp.bottom())?;
    legend(out)?;
    for (i, line) in labels.caption.iter().enumerate() {
        writeln!(
            out,
            r##"<text x="{LEFT}" y="{:.1}" font-size="11" fill="#444444">{}</text>"##,
            tcp.bottom() + 62.0 + 15.0 * i as f64,
            escape(line)
        )?;
    }
    writeln!(out, "</svg>")
}

/// The time axis: from 0 (or earlier) to the last sample or marker, at whole ticks.
fn time_scale(recording: &Recording) -> Scale {
    let times = recording
        .samples()
        .iter()
        .map(|s| s.t_s)
        .chain(recording.markers().iter().map(|m| m.t_s))
        .chain([0.0]);
    Scale {
        range: Range::of(
            times,
            0.0,
            Range {
                low: 0.0,
                high: 1.0,
            },
        )
        .rounded_to_ticks(X_TICKS),
        from: LEFT,
        to: RIGHT,
    }
}

/// A panel's box, grid, y ticks and unit, in a group that carries its data range.
fn frame(out: &mut String, panel: &Panel, x: &Scale) -> fmt::Result {
    let range = panel.y.range;
    writeln!(
        out,
        r#"<g class="panel" id="{}" data-low="{}" data-high="{}" data-top="{}" data-bottom="{}" data-left="{LEFT}" data-right="{RIGHT}" data-t0="{}" data-t1="{}">"#,
        panel.id,
        range.low,
        range.high,
        panel.top,
        panel.bottom(),
        x.range.low,
        x.range.high
    )?;
    writeln!(
        out,
        r##"<rect x="{LEFT}" y="{}" width="{}" height="{PANEL_HEIGHT}" fill="none" stroke="#333333"/>"##,
        panel.top,
        RIGHT - LEFT
    )?;
    let step = axis::step_of(range, Y_TICKS);
    for value in range.ticks(Y_TICKS) {
        let y = panel.y.map(value);
        writeln!(
            out,
            r##"<line x1="{LEFT}" y1="{y:.1}" x2="{RIGHT}" y2="{y:.1}" stroke="#e5e5e5"/><text x="{:.1}" y="{:.1}" text-anchor="end">{}</text>"##,
            LEFT - 6.0,
            y + 4.0,
            axis::label(value, step)
        )?;
    }
    for value in x.range.ticks(X_TICKS) {
        let px = x.map(value);
        writeln!(
            out,
            r##"<line x1="{px:.1}" y1="{}" x2="{px:.1}" y2="{}" stroke="#f0f0f0"/>"##,
            panel.top,
            panel.bottom()
        )?;
    }
    writeln!(
        out,
        r#"<text transform="translate(22 {:.1}) rotate(-90)" text-anchor="middle">{}</text>"#,
        panel.top + PANEL_HEIGHT / 2.0,
        panel.unit_label
    )?;
    writeln!(out, "</g>")
}

/// A kind of time span shaded across the panels.
struct Band {
    /// Class of its rectangles and its legend text.
    name: &'static str,
    fill: &'static str,
    /// Whether a sample lies in such a span.
    holds: fn(&Sample) -> bool,
}

/// The spans shaded: where the primary sequence was interrupted, and where two moves blend.
const BANDS: [Band; 2] = [
    Band {
        name: "interrupted",
        fill: "#fbe3c8",
        holds: |s| s.interrupted,
    },
    Band {
        name: "blending",
        fill: "#cfe3f7",
        holds: |s| s.blending,
    },
];

/// Light bands over `panel` where the samples are in `band`.
fn spans(
    out: &mut String,
    panel: &Panel,
    x: &Scale,
    samples: &[Sample],
    band: &Band,
) -> fmt::Result {
    let mut shade = |from: f64, to: f64| {
        let (x0, x1) = (x.map(from), x.map(to));
        writeln!(
            out,
            r##"<rect class="{}" x="{x0:.1}" y="{}" width="{:.1}" height="{PANEL_HEIGHT}" fill="{}" fill-opacity="0.6"/>"##,
            band.name,
            panel.top,
            (x1 - x0).max(0.0),
            band.fill
        )
    };
    let mut start = None;
    for s in samples {
        match (start, (band.holds)(s)) {
            (None, true) => start = Some(s.t_s),
            (Some(from), false) => {
                shade(from, s.t_s)?;
                start = None;
            }
            _ => {}
        }
    }
    match (start, samples.last()) {
        (Some(from), Some(last)) => shade(from, last.t_s),
        _ => Ok(()),
    }
}

/// One trace per joint of the joint values `of` each sample (rad), in degrees.
fn joint_traces(
    out: &mut String,
    panel: &Panel,
    x: &Scale,
    samples: &[Sample],
    of: impl Fn(&Sample) -> [f64; AXES],
) -> fmt::Result {
    for (joint, colour) in JOINT_COLOURS.iter().enumerate() {
        let trace = samples.iter().map(|s| (s.t_s, of(s)[joint].to_degrees()));
        polyline(out, panel, x, colour, joint + 1, trace)?;
    }
    Ok(())
}

/// One data trace as a polyline, thinned to the pixel columns; `joint` 0 is the TCP.
fn polyline(
    out: &mut String,
    panel: &Panel,
    x: &Scale,
    colour: &str,
    joint: usize,
    trace: impl Iterator<Item = (f64, f64)>,
) -> fmt::Result {
    let points = thin(
        trace
            .filter(|(t, v)| t.is_finite() && v.is_finite())
            .map(|(t, v)| (x.map(t), panel.y.map(v))),
    );
    write!(
        out,
        r#"<polyline class="trace" data-panel="{}" data-joint="{joint}" fill="none" stroke="{colour}" stroke-width="1.3" stroke-linejoin="round" stroke-linecap="round" points=""#,
        panel.id
    )?;
    // A single point is drawn as a dot: a zero-length line with round caps.
    let repeat = if points.len() == 1 { 2 } else { 1 };
    for (i, (px, py)) in points
        .iter()
        .flat_map(|p| std::iter::repeat_n(p, repeat))
        .enumerate()
    {
        if i > 0 {
            out.push(' ');
        }
        write!(out, "{px:.1},{py:.1}")?;
    }
    writeln!(out, r#""/>"#)
}

/// Keeps per pixel column (of consecutive points) the first, lowest, highest and last point,
/// in their order: the trace looks the same, its extremes stay.
fn thin(points: impl Iterator<Item = (f64, f64)>) -> Vec<(f64, f64)> {
    let mut kept = Vec::new();
    let mut column: Vec<(f64, f64)> = Vec::new();
    for p in points {
        if column.first().is_some_and(|c| c.0.floor() != p.0.floor()) {
            keep_extremes(&column, &mut kept);
            column.clear();
        }
        column.push(p);
    }
    keep_extremes(&column, &mut kept);
    kept
}

/// Appends the first, lowest, highest and last point of `column` to `kept`, in their order
/// and without repeats.
fn keep_extremes(column: &[(f64, f64)], kept: &mut Vec<(f64, f64)>) {
    if column.is_empty() {
        return;
    }
    let (mut low, mut high) = (0, 0);
    for (i, p) in column.iter().enumerate() {
        if p.1 < column[low].1 {
            low = i;
        }
        if p.1 > column[high].1 {
            high = i;
        }
    }
    let mut indices = [0, low, high, column.len() - 1];
    indices.sort_unstable();
    for i in indices {
        if kept.last() != Some(&column[i]) {
            kept.push(column[i]);
        }
    }
}

/// The override (right axis of the TCP panel) as a thin step path; 100 % lies a little
/// below the panel's top edge so that a constant full override stays visible.
fn override_trace(out: &mut String, panel: &Panel, x: &Scale, samples: &[Sample]) -> fmt::Result {
    let percent = Scale {
        range: Range {
            low: 0.0,
            high: 110.0,
        },
        from: panel.bottom(),
        to: panel.top,
    };
    for value in [0.0, 50.0, 100.0] {
        writeln!(
            out,
            r#"<text x="{:.1}" y="{:.1}" fill="{OVERRIDE_COLOUR}">{value} %</text>"#,
            RIGHT + 5.0,
            percent.map(value) + 4.0
        )?;
    }
    write!(
        out,
        r#"<path class="override" fill="none" stroke="{OVERRIDE_COLOUR}" stroke-width="1" d=""#
    )?;
    let mut previous: Option<f64> = None;
    for s in samples {
        let value = s.override_fraction * 100.0;
        if !(value.is_finite() && s.t_s.is_finite()) {
            continue;
        }
        let (px, py) = (x.map(s.t_s), percent.map(value));
        match previous {
            None => write!(out, "M{px:.1},{py:.1}")?,
            Some(prev) if prev != py => write!(out, " H{px:.1} V{py:.1}")?,
            Some(_) => {}
        }
        previous = Some(py);
    }
    if let (Some(last), Some(_)) = (samples.last(), previous) {
        write!(out, " H{:.1}", x.map(last.t_s))?;
    }
    writeln!(out, r#""/>"#)
}

/// Colour and dash of the marker of a job state.
fn marker_style(state: JobState) -> (&'static str, &'static str) {
    match state {
        JobState::Active => ("#2ca02c", "4 3"),
        JobState::Interrupted => ("#ff7f0e", "2 2"),
        JobState::Done => ("#1f77b4", "none"),
        JobState::Aborted | JobState::Error => ("#d62728", "none"),
    }
}

/// A vertical line across all panels per job state change, labelled at the top.
fn markers(out: &mut String, recording: &Recording, x: &Scale, bottom: f64) -> fmt::Result {
    for m in recording.markers() {
        if !m.t_s.is_finite() {
            continue;
        }
        let px = x.map(m.t_s);
        let (colour, dash) = marker_style(m.state);
        writeln!(
            out,
            r#"<line class="marker" data-job="{}" data-state="{}" x1="{px:.1}" y1="{TOP}" x2="{px:.1}" y2="{bottom:.1}" stroke="{colour}" stroke-width="1" stroke-dasharray="{dash}"/><text transform="translate({:.1} {:.1}) rotate(-90)" font-size="9" fill="{colour}">#{} {}</text>"#,
            m.job,
            m.state.name(),
            px + 3.0,
            TOP - 4.0,
            m.job,
            m.state.name()
        )?;
    }
    Ok(())
}

/// Ticks and the title of the shared time axis, under the last panel.
fn time_axis(out: &mut String, x: &Scale, bottom: f64) -> fmt::Result {
    let step = axis::step_of(x.range, X_TICKS);
    for value in x.range.ticks(X_TICKS) {
        let px = x.map(value);
        writeln!(
            out,
            r##"<line x1="{px:.1}" y1="{bottom:.1}" x2="{px:.1}" y2="{:.1}" stroke="#333333"/><text x="{px:.1}" y="{:.1}" text-anchor="middle">{}</text>"##,
            bottom + 5.0,
            bottom + 19.0,
            axis::label(value, step)
        )?;
    }
    writeln!(
        out,
        r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">time (s)</text>"#,
        (LEFT + RIGHT) / 2.0,
        bottom + 38.0
    )
}

/// The legend right of the panels.
fn legend(out: &mut String) -> fmt::Result {
    let x = RIGHT + 55.0;
    let mut y = TOP + 10.0;
    let mut entry = |out: &mut String, colour: &str, dash: &str, width: f64, text: &str| {
        let line = writeln!(
            out,
            r#"<line x1="{x}" y1="{y}" x2="{}" y2="{y}" stroke="{colour}" stroke-width="{width}" stroke-dasharray="{dash}"/><text x="{}" y="{}">{text}</text>"#,
            x + 22.0,
            x + 28.0,
            y + 4.0
        );
        y += 18.0;
        line
    };
    for (joint, colour) in JOINT_COLOURS.iter().enumerate() {
        entry(out, colour, "none", 2.0, &format!("J{}", joint + 1))?;
    }
    entry(out, "#555555", "6 4", 1.0, "velocity limits")?;
    entry(out, TCP_COLOUR, "none", 2.0, "TCP speed")?;
    entry(out, OVERRIDE_COLOUR, "none", 1.0, "override")?;
    for state in [
        JobState::Active,
        JobState::Interrupted,
        JobState::Done,
        JobState::Aborted,
    ] {
        let (colour, dash) = marker_style(state);
        let text = if state == JobState::Aborted {
            "ABORTED/ERROR"
        } else {
            state.name()
        };
        entry(out, colour, dash, 1.0, text)?;
    }
    for band in BANDS {
        writeln!(
            out,
            r##"<rect x="{x}" y="{:.1}" width="22" height="10" fill="{}"/><text x="{}" y="{:.1}">{}</text>"##,
            y - 5.0,
            band.fill,
            x + 28.0,
            y + 4.0,
            band.name
        )?;
        y += 18.0;
    }
    Ok(())
}

/// Text with the XML special characters escaped.
fn escape(text: &str) -> String {
    let mut escaped = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => escaped.push_str("&amp;"),
            '<' => escaped.push_str("&lt;"),
            '>' => escaped.push_str("&gt;"),
            '"' => escaped.push_str("&quot;"),
            '\'' => escaped.push_str("&apos;"),
            // Control characters are not allowed in XML 1.0.
            c if c.is_control() => escaped.push(' '),
            c => escaped.push(c),
        }
    }
    escaped
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plot::recording::JobMarker;
    use crate::plot::recording::tests::sample;
    use proptest::prelude::*;

    const LIMITS: [f64; AXES] = [180.0, 180.0, 180.0, 225.0, 225.0, 225.0];

    fn svg_of(recording: &Recording) -> String {
        render(
            recording,
            &PlotLabels {
                title: "rc plc: <pick & place>",
                caption: &["caption \"one\"".to_string()],
                velocity_limits_deg_s: LIMITS,
            },
        )
    }

    /// A recording of `samples`, with markers.
    fn recording_of(samples: impl IntoIterator<Item = Sample>, markers: &[JobMarker]) -> Recording {
        let mut r = Recording::with_capacity(10_000, 16);
        for s in samples {
            r.push_sample(s);
        }
        for m in markers {
            r.push_marker(*m);
        }
        r.finish();
        r
    }

    /// Checks that `text` is well-formed XML as this renderer writes it: balanced elements,
    /// quoted attributes, no raw `<` or `&` in text or attribute values. Returns the tags.
    fn check_xml(text: &str) -> Vec<String> {
        let body = text
            .strip_prefix(r#"<?xml version="1.0" encoding="UTF-8"?>"#)
            .expect("XML declaration");
        let mut open: Vec<String> = Vec::new();
        let mut tags = Vec::new();
        let mut rest = body;
        let mut seen_root = false;
        while let Some(start) = rest.find('<') {
            check_text(&rest[..start]);
            let end = rest[start..].find('>').expect("tag ends") + start;
            let tag = &rest[start + 1..end];
            assert!(!tag.contains('<'), "'<' inside a tag: {tag}");
            if let Some(name) = tag.strip_prefix('/') {
                assert_eq!(open.pop().as_deref(), Some(name), "balanced </{name}>");
            } else {
                let self_closing = tag.ends_with('/');
                let tag = tag.trim_end_matches('/');
                let name = tag.split_whitespace().next().expect("tag name").to_string();
                assert!(!seen_root || !open.is_empty(), "one root element");
                seen_root = true;
                check_attributes(&tag[name.len()..]);
                tags.push(tag.to_string());
                if !self_closing {
                    open.push(name);
                }
            }
            rest = &rest[end + 1..];
        }
        check_text(rest);
        assert!(open.is_empty(), "unclosed elements: {open:?}");
        tags
    }

    fn check_text(text: &str) {
        let mut rest = text;
        while let Some(i) = rest.find('&') {
            let entity = &rest[i..rest[i..].find(';').map_or(rest.len(), |e| i + e + 1)];
            assert!(
                ["&amp;", "&lt;", "&gt;", "&quot;", "&apos;"].contains(&entity),
                "bad entity {entity}"
            );
            rest = &rest[i + 1..];
        }
    }

    fn check_attributes(mut attrs: &str) {
        loop {
            attrs = attrs.trim_start();
            if attrs.is_empty() {
                return;
            }
            let eq = attrs.find("=\"").expect("attribute with a quoted value");
            assert!(
                !attrs[..eq].contains(char::is_whitespace),
                "attribute name: {attrs}"
            );
            let value_end = attrs[eq + 2..].find('"').expect("closing quote") + eq + 2;
            check_text(&attrs[eq + 2..value_end]);
            attrs = &attrs[value_end + 1..];
        }
    }

    /// The value of attribute `name` of a tag.
    fn attr<'a>(tag: &'a str, name: &str) -> Option<&'a str> {
        let key = format!(" {name}=\"");
        let start = tag.find(&key)? + key.len();
        Some(&tag[start..start + tag[start..].find('"')?])
    }

    fn points(tag: &str) -> Vec<(f64, f64)> {
        attr(tag, "points")
            .expect("points")
            .split_whitespace()
            .map(|p| {
                let (x, y) = p.split_once(',').expect("x,y");
                (x.parse().expect("x"), y.parse().expect("y"))
            })
            .collect()
    }

    fn number(tag: &str, name: &str) -> f64 {
        attr(tag, name).expect(name).parse().expect(name)
    }

    /// The data value at pixel `y` of the panel tag `panel`, and the time at pixel `x`.
    fn value_at(panel: &str, x: f64, y: f64) -> (f64, f64) {
        let (low, high) = (number(panel, "data-low"), number(panel, "data-high"));
        let (top, bottom) = (number(panel, "data-top"), number(panel, "data-bottom"));
        let (t0, t1) = (number(panel, "data-t0"), number(panel, "data-t1"));
        let (left, right) = (number(panel, "data-left"), number(panel, "data-right"));
        (
            t0 + (x - left) / (right - left) * (t1 - t0),
            low + (bottom - y) / (bottom - top) * (high - low),
        )
    }

    fn polylines(tags: &[String]) -> Vec<&String> {
        tags.iter().filter(|t| t.starts_with("polyline")).collect()
    }

    fn assert_inside_view_box(tags: &[String]) {
        for tag in tags {
            let coordinates = if tag.starts_with("polyline") {
                points(tag)
            } else {
                Vec::new()
            };
            for (x, y) in coordinates {
                assert!(
                    (0.0..=WIDTH).contains(&x) && (0.0..=HEIGHT).contains(&y),
                    "{x},{y}"
                );
            }
            for (name, limit) in [
                ("x", WIDTH),
                ("x1", WIDTH),
                ("x2", WIDTH),
                ("y", HEIGHT),
                ("y1", HEIGHT),
                ("y2", HEIGHT),
            ] {
                if let Some(v) = attr(tag, name) {
                    let v: f64 = v.parse().expect("coordinate");
                    assert!((0.0..=limit).contains(&v), "{name}={v} in {tag}");
                }
            }
        }
    }

    #[test]
    fn a_run_has_thirteen_traces_limits_markers_and_escaped_labels() {
        let ramp = (0..=1000).map(|i| {
            let t = f64::from(i) * 1e-3;
            let mut s = sample(t, 0.0);
            s.q[0] = (90.0 * t).to_radians();
            s.qd[0] = 90f64.to_radians();
            s.tcp_speed = 0.25 * t;
            s.interrupted = (400..600).contains(&i);
            s.blending = (700..800).contains(&i);
            s
        });
        let markers = [
            JobMarker {
                t_s: 0.0,
                job: 1,
                state: JobState::Active,
            },
            JobMarker {
                t_s: 1.0,
                job: 1,
                state: JobState::Done,
            },
        ];
        let text = svg_of(&recording_of(ramp, &markers));
        let tags = check_xml(&text);
        assert_eq!(polylines(&tags).len(), 6 + 6 + 1);
        assert_eq!(
            tags.iter()
                .filter(|t| t.starts_with("line class=\"limit\""))
                .count(),
            12
        );
        assert_eq!(
            tags.iter()
                .filter(|t| t.starts_with("line class=\"marker\""))
                .count(),
            2
        );
        assert_eq!(
            tags.iter()
                .filter(|t| t.starts_with("rect class=\"interrupted\""))
                .count(),
            3
        );
        assert_eq!(
            tags.iter()
                .filter(|t| t.starts_with("rect class=\"blending\""))
                .count(),
            3
        );
        assert!(text.contains("rc plc: &lt;pick &amp; place&gt;"));
        assert!(text.contains("caption &quot;one&quot;"));
        assert!(text.contains("joint velocity (deg/s)") && text.contains("TCP speed (mm/s)"));
        assert_inside_view_box(&tags);
    }

    #[test]
    fn a_known_ramp_appears_where_it_should() {
        // 5 samples per pixel column.
        let ramp = (0..=5000).map(|i| {
            let t = f64::from(i) * 2e-4;
            let mut s = sample(t, 0.0);
            s.q[0] = (90.0 * t).to_radians();
            s.tcp_speed = 0.25 * t;
            s
        });
        let text = svg_of(&recording_of(ramp, &[]));
        let tags = check_xml(&text);
        let panel = |id: &str| {
            tags.iter()
                .find(|t| attr(t, "id") == Some(id))
                .unwrap_or_else(|| panic!("panel {id}"))
        };
        let trace = |panel_id: &str, joint: &str| {
            tags.iter()
                .find(|t| {
                    attr(t, "data-panel") == Some(panel_id) && attr(t, "data-joint") == Some(joint)
                })
                .unwrap_or_else(|| panic!("trace {panel_id} {joint}"))
        };
        let j1 = points(trace("positions", "1"));
        let positions = panel("positions");
        let (t_first, v_first) = value_at(positions, j1[0].0, j1[0].1);
        let (t_last, v_last) = value_at(positions, j1[j1.len() - 1].0, j1[j1.len() - 1].1);
        // 0.1 px of rounding: well under a degree and a millisecond here.
        assert!(
            t_first.abs() < 2e-3 && v_first.abs() < 0.5,
            "{t_first} {v_first}"
        );
        assert!(
            (t_last - 1.0).abs() < 2e-3 && (v_last - 90.0).abs() < 0.5,
            "{t_last} {v_last}"
        );
        for &(x, y) in &j1 {
            let (t, v) = value_at(positions, x, y);
            assert!((v - 90.0 * t).abs() < 1.0, "ramp point {t} s {v} deg");
        }
        // The resting joints lie on 0.
        for &(x, y) in &points(trace("positions", "2")) {
            assert!(value_at(positions, x, y).1.abs() < 0.5);
        }
        let tcp = points(trace("tcp", "0"));
        let (_, speed) = value_at(panel("tcp"), tcp[tcp.len() - 1].0, tcp[tcp.len() - 1].1);
        assert!((speed - 250.0).abs() < 2.0, "{speed} mm/s");
        // Thinned to the pixel columns, not one point per sample.
        assert!(j1.len() < 2500, "{} points", j1.len());
    }

    #[test]
    fn empty_single_flat_and_nan_runs_render() {
        let mut nan = sample(0.5, f64::NAN);
        nan.qd = [f64::INFINITY; AXES];
        nan.tcp_speed = f64::NAN;
        nan.override_fraction = f64::NAN;
        let cases: [Vec<Sample>; 4] = [
            vec![],
            vec![sample(0.0, 0.3)],
            (0..100).map(|i| sample(f64::from(i) * 1e-3, 0.3)).collect(),
            vec![sample(0.0, 0.1), nan, sample(1.0, 0.2)],
        ];
        for samples in cases {
            let n = samples.len();
            let text = svg_of(&recording_of(samples, &[]));
            assert!(
                !text.contains("NaN") && !text.contains("inf"),
                "{n} samples:\n{text}"
            );
            let tags = check_xml(&text);
            assert_eq!(polylines(&tags).len(), 13);
            assert_inside_view_box(&tags);
            if n == 1 {
                assert_eq!(
                    points(polylines(&tags)[0]).len(),
                    2,
                    "a single sample is a dot"
                );
            }
        }
    }

    #[test]
    fn thinning_keeps_the_extremes_of_each_column_in_order() {
        let points = [
            (10.2, 5.0),
            (10.5, 9.0),
            (10.6, 1.0),
            (10.9, 4.0),
            (11.0, 3.0),
        ];
        assert_eq!(
            thin(points.into_iter()),
            [
                (10.2, 5.0),
                (10.5, 9.0),
                (10.6, 1.0),
                (10.9, 4.0),
                (11.0, 3.0)
            ]
        );
        let many = (0..100).map(|i| (10.0 + f64::from(i) / 1000.0, f64::from(i % 7)));
        let kept = thin(many);
        // First and lowest are the same point here: 0, then 6 (highest), then 99 % 7 (last).
        assert_eq!(kept.len(), 3);
        assert_eq!(kept.iter().map(|p| p.1).fold(f64::NAN, f64::max), 6.0);
        assert_eq!(kept.iter().map(|p| p.1).fold(f64::NAN, f64::min), 0.0);
    }

    proptest! {
        #[test]
        fn any_run_renders_inside_the_view_box(
            values in prop::collection::vec((-10.0f64..10.0, -5.0f64..5.0, 0.0f64..3.0, 0.0f64..1.5), 0..300),
        ) {
            let samples = values.iter().enumerate().map(|(i, (q, qd, v, o))| {
                let mut s = sample(i as f64 * 2e-3, *q);
                s.qd = [*qd; AXES];
                s.tcp_speed = *v;
                s.override_fraction = *o;
                s
            });
            let tags = check_xml(&svg_of(&recording_of(samples, &[])));
            prop_assert_eq!(polylines(&tags).len(), 13);
            assert_inside_view_box(&tags);
        }
    }
}
