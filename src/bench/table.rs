//! The result table of `rc bench latency`: one aligned text table with a row per telegram
//! cycle and load, and rows for the interpreter's processing time and the IPC hop comparison.

use std::fmt::Write as _;

use super::stats::Summary;

/// How a row's latency values are shown.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unit {
    /// Microseconds with one decimal.
    Micros,
    /// Whole nanoseconds.
    Nanos,
    /// A dimensionless ratio with two decimals.
    Ratio,
}

impl Unit {
    fn symbol(self) -> &'static str {
        match self {
            Self::Micros => "µs",
            Self::Nanos => "ns",
            Self::Ratio => "x",
        }
    }

    /// A value given in ns (a ratio as is).
    fn format(self, value: f64) -> String {
        match self {
            Self::Micros => format!("{:.1}", value / 1e3),
            Self::Nanos => format!("{value:.0}"),
            Self::Ratio => format!("{value:.2}"),
        }
    }
}

/// One telegram cycle time under one load: the whole pipeline, PLC to servo.
#[derive(Debug, Clone, PartialEq)]
pub struct PipelineRow {
    pub label: String,
    /// Telegram round trips (ns).
    pub round_trip: Option<Summary>,
    /// PLC cycles that ended after their deadline.
    pub overruns: u64,
    /// Replies that did not come within the response timeout.
    pub timeouts: u64,
    /// Servo tick lateness (ns).
    pub servo: Option<Summary>,
    /// Growth of the servo's overrun counter.
    pub servo_overruns: Option<u64>,
}

/// One distribution without the pipeline's counters.
#[derive(Debug, Clone, PartialEq)]
pub struct TimingRow {
    pub label: String,
    pub unit: Unit,
    pub summary: Option<Summary>,
}

/// The quotient of two distributions at p50, p99, p99.9 and the maximum.
#[derive(Debug, Clone, PartialEq)]
pub struct RatioRow {
    pub label: String,
    pub ratios: [f64; 4],
}

impl RatioRow {
    /// `numerator / denominator` figure by figure; `None` if either has no samples.
    pub fn of(
        label: &str,
        numerator: Option<Summary>,
        denominator: Option<Summary>,
    ) -> Option<Self> {
        let (a, b) = (numerator?, denominator?);
        let q = |x: u64, y: u64| x as f64 / (y.max(1) as f64);
        Some(Self {
            label: label.to_string(),
            ratios: [
                q(a.p50, b.p50),
                q(a.p99, b.p99),
                q(a.p99_9, b.p99_9),
                q(a.max, b.max),
            ],
        })
    }
}

/// A row of the table.
#[derive(Debug, Clone, PartialEq)]
pub enum Row {
    Pipeline(PipelineRow),
    Timing(TimingRow),
    Ratio(RatioRow),
}

const LABEL: usize = 23;
const UNIT: usize = 4;
const COUNT: usize = 6;
const VALUE: usize = 8;
const MISSED: usize = 7;
const SERVO: usize = 7;
const NONE: &str = "-";

/// Cells of one line: (text, width); the label is left-aligned, everything else right.
fn line(cells: &[(&str, usize)]) -> String {
    let mut text = String::new();
    for (i, (cell, width)) in cells.iter().enumerate() {
        if i == 0 {
            let _ = write!(text, "{cell:<width$}");
        } else {
            let _ = write!(text, " {cell:>width$}");
        }
    }
    text.trim_end().to_string()
}

fn centred(title: &str, width: usize) -> String {
    format!("{title:^width$}")
}

fn header() -> [String; 2] {
    let latency = COUNT + 4 * (VALUE + 1);
    let missed = 2 * MISSED + 1;
    let servo = COUNT + 4 * (SERVO + 1);
    let groups = format!(
        "{:w$} {} {} {}",
        "",
        centred("latency", latency),
        centred("missed cycles", missed),
        centred("servo tick lateness µs", servo),
        w = LABEL + UNIT + 1,
    );
    let names = line(&[
        ("row", LABEL),
        ("unit", UNIT),
        ("n", COUNT),
        ("p50", VALUE),
        ("p99", VALUE),
        ("p99.9", VALUE),
        ("max", VALUE),
        ("overrun", MISSED),
        ("timeout", MISSED),
        ("n", COUNT),
        ("p50", SERVO),
        ("p99", SERVO),
        ("max", SERVO),
        ("overrun", SERVO),
    ]);
    [groups.trim_end().to_string(), names]
}

/// The count and four figures of a summary, or dashes.
fn figures(unit: Unit, summary: Option<Summary>) -> [String; 5] {
    match summary {
        Some(s) => [
            s.count.to_string(),
            unit.format(s.p50 as f64),
            unit.format(s.p99 as f64),
            unit.format(s.p99_9 as f64),
            unit.format(s.max as f64),
        ],
        None => [NONE; 5].map(String::from),
    }
}

fn render_row(row: &Row) -> String {
    let dashes = || [NONE; 7].map(String::from);
    let (label, unit, main, rest) = match row {
        Row::Pipeline(p) => {
            // The servo columns leave out p99.9.
            let [n, p50, p99, _, max] = figures(Unit::Micros, p.servo);
            let rest = [
                p.overruns.to_string(),
                p.timeouts.to_string(),
                n,
                p50,
                p99,
                max,
                p.servo_overruns.map_or(NONE.to_string(), |o| o.to_string()),
            ];
            let main = figures(Unit::Micros, p.round_trip);
            (&p.label, Unit::Micros, main, rest)
        }
        Row::Timing(t) => (&t.label, t.unit, figures(t.unit, t.summary), dashes()),
        Row::Ratio(r) => {
            let [p50, p99, p99_9, max] = r.ratios.map(|x| Unit::Ratio.format(x));
            let main = [NONE.to_string(), p50, p99, p99_9, max];
            (&r.label, Unit::Ratio, main, dashes())
        }
    };
    let widths = [MISSED, MISSED, COUNT, SERVO, SERVO, SERVO, SERVO];
    let mut cells: Vec<(&str, usize)> = vec![(label, LABEL), (unit.symbol(), UNIT)];
    cells.push((&main[0], COUNT));
    cells.extend(main[1..].iter().map(|v| (v.as_str(), VALUE)));
    cells.extend(rest.iter().map(String::as_str).zip(widths));
    line(&cells)
}

/// The whole table: `title` lines, the column headers, the rows, then `notes`.
pub fn render(title: &[String], rows: &[Row], notes: &[String]) -> String {
    let mut text = String::new();
    for t in title {
        let _ = writeln!(text, "{t}");
    }
    let [groups, names] = header();
    let rule = "-".repeat(names.chars().count());
    let _ = writeln!(text, "{groups}\n{names}\n{rule}");
    for row in rows {
        let _ = writeln!(text, "{}", render_row(row));
    }
    let _ = writeln!(text, "{rule}");
    for n in notes {
        let _ = writeln!(text, "{n}");
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    fn summary(count: usize, base: u64) -> Summary {
        Summary {
            count,
            p50: base,
            p99: base * 2,
            p99_9: base * 3,
            max: base * 10,
        }
    }

    fn rows() -> Vec<Row> {
        let uds = summary(1000, 8_000);
        let iox = summary(1000, 4_000);
        vec![
            Row::Pipeline(PipelineRow {
                label: "8 ms idle".into(),
                round_trip: Some(summary(2000, 123_456)),
                overruns: 3,
                timeouts: 0,
                servo: Some(summary(16_000, 45_000)),
                servo_overruns: Some(1),
            }),
            Row::Pipeline(PipelineRow {
                label: "1 ms load".into(),
                round_trip: None,
                overruns: 0,
                timeouts: 2,
                servo: None,
                servo_overruns: None,
            }),
            Row::Timing(TimingRow {
                label: "on_telegram".into(),
                unit: Unit::Nanos,
                summary: Some(summary(20_000, 850)),
            }),
            Row::Timing(TimingRow {
                label: "UDS hop one-way".into(),
                unit: Unit::Micros,
                summary: Some(uds),
            }),
            Row::Ratio(RatioRow::of("UDS / iceoryx2", Some(uds), Some(iox)).unwrap()),
        ]
    }

    #[test]
    fn rows_are_aligned_under_the_headers() {
        let text = render(&["title".into()], &rows(), &["note".into()]);
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], "title");
        assert_eq!(*lines.last().unwrap(), "note");
        let names = lines[2];
        // Every value ends in the column of its header name (counted in characters: "µs").
        let end_of = |line: &str, word: &str| {
            line.find(word)
                .map(|i| line[..i].chars().count() + word.chars().count())
        };
        let p50_end = end_of(names, " p50").unwrap();
        let row = lines[4];
        assert!(row.starts_with("8 ms idle "));
        assert_eq!(end_of(row, " 123.5"), Some(p50_end), "{text}");
        assert_eq!(
            row.split_whitespace().collect::<Vec<_>>(),
            [
                "8", "ms", "idle", "µs", "2000", "123.5", "246.9", "370.4", "1234.6", "3", "0",
                "16000", "45.0", "90.0", "450.0", "1"
            ]
        );
    }

    #[test]
    fn missing_values_and_other_units() {
        let text = render(&[], &rows(), &[]);
        let find = |label: &str| text.lines().find(|l| l.starts_with(label)).unwrap();
        assert_eq!(
            find("1 ms load")
                .split_whitespace()
                .skip(3)
                .collect::<Vec<_>>(),
            [
                "µs", "-", "-", "-", "-", "-", "0", "2", "-", "-", "-", "-", "-"
            ]
        );
        assert_eq!(
            find("on_telegram").split_whitespace().collect::<Vec<_>>()[1..7],
            ["ns", "20000", "850", "1700", "2550", "8500"]
        );
        assert_eq!(
            find("UDS / iceoryx2")
                .split_whitespace()
                .collect::<Vec<_>>()[3..8],
            ["x", "-", "2.00", "2.00", "2.00"]
        );
    }

    #[test]
    fn a_ratio_needs_both_distributions() {
        assert_eq!(RatioRow::of("r", None, Some(summary(1, 1))), None);
    }
}
