//! The table of `rc bench motion`: a timing section (kinematics, planning, solver) and an
//! optimality section (our durations over the reference planners').

use std::fmt::Write as _;

use crate::bench::stats::Summary;

/// Ratios above this miss the target of the issue (within 2 % of the reference).
pub const TARGET_RATIO: f64 = 1.02;
/// Ratios below `1 − BELOW_TOLERANCE` count as faster than the reference: more than rounding.
pub const BELOW_TOLERANCE: f64 = 1e-9;

/// Our durations over the reference durations of one set of problems.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RatioStats {
    /// Problems with both durations.
    pub count: usize,
    /// Problems without one of them (a planner failed).
    pub failed: usize,
    pub p50: f64,
    pub min: f64,
    pub max: f64,
    /// Index of the problem with the largest ratio.
    pub worst: usize,
    /// Index of the problem with the smallest ratio.
    pub best: usize,
    /// Median durations (s): ours and the reference's.
    pub ours_p50_s: f64,
    pub reference_p50_s: f64,
    /// Ratios above [`TARGET_RATIO`].
    pub over_target: usize,
    /// Ratios below 1: faster than the reference.
    pub below_one: usize,
}

/// The median (upper for an even count) of finite values; NaN without any.
fn median(values: &[f64]) -> f64 {
    let mut sorted: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    sorted.sort_by(f64::total_cmp);
    sorted.get(sorted.len() / 2).copied().unwrap_or(f64::NAN)
}

impl RatioStats {
    /// `ours[k] / reference[k]` over the problems where both are finite and positive;
    /// `None` if there are none.
    pub fn of(ours: &[f64], reference: &[f64]) -> Option<Self> {
        let valid = |x: f64| x.is_finite() && x > 0.0;
        // (problem index, ours, reference)
        let pairs: Vec<(usize, f64, f64)> = ours
            .iter()
            .zip(reference)
            .enumerate()
            .map(|(k, (&o, &r))| (k, o, r))
            .filter(|&(_, o, r)| valid(o) && valid(r))
            .collect();
        let ratios: Vec<f64> = pairs.iter().map(|(_, o, r)| o / r).collect();
        let indexed = || pairs.iter().zip(&ratios).map(|(p, &x)| (p.0, x));
        let (best, min) = indexed().fold((0, f64::INFINITY), |a, b| if b.1 < a.1 { b } else { a });
        let (worst, max) =
            indexed().fold((0, f64::NEG_INFINITY), |a, b| if b.1 > a.1 { b } else { a });
        (!ratios.is_empty()).then(|| Self {
            count: ratios.len(),
            failed: ours.len().min(reference.len()) - pairs.len(),
            p50: median(&ratios),
            min,
            max,
            worst,
            best,
            ours_p50_s: median(&pairs.iter().map(|p| p.1).collect::<Vec<_>>()),
            reference_p50_s: median(&pairs.iter().map(|p| p.2).collect::<Vec<_>>()),
            over_target: ratios.iter().filter(|&&x| x > TARGET_RATIO).count(),
            below_one: ratios
                .iter()
                .filter(|&&x| x < 1.0 - BELOW_TOLERANCE)
                .count(),
        })
    }
}

/// A row of the timing section.
#[derive(Debug, Clone, PartialEq)]
pub enum TimingRow {
    /// Per-call times (ns) and the rate of calls per second.
    Measured {
        label: String,
        /// Whether to show µs rather than ns.
        micros: bool,
        summary: Option<Summary>,
        per_second: f64,
    },
}

/// A row of the optimality section: the ratios, or why there are none.
#[derive(Debug, Clone, PartialEq)]
pub struct OptimalityRow {
    pub label: String,
    pub ratios: Result<RatioStats, String>,
}

/// Width of the label column at least; a longer label widens it for the whole table.
const LABEL: usize = 48;
const COLUMN: usize = 8;
const COUNT: usize = 6;

/// Cells after a label left-aligned in `width`, each right-aligned in its width.
fn cells(label: &str, width: usize, values: &[(&str, usize)]) -> String {
    let mut text = format!("{label:<width$}");
    for (value, width) in values {
        let _ = write!(text, " {value:>width$}");
    }
    text.trim_end().to_string()
}

/// A rate as `12.3 k` or `4.56 M`.
fn per_second(rate: f64) -> String {
    match rate {
        r if r >= 1e6 => format!("{:.2} M", r / 1e6),
        r if r >= 1e3 => format!("{:.1} k", r / 1e3),
        r => format!("{r:.0}"),
    }
}

fn timing_line(row: &TimingRow, width: usize) -> String {
    match row {
        TimingRow::Measured {
            label,
            micros,
            summary,
            per_second: rate,
        } => {
            let unit = if *micros { "µs" } else { "ns" };
            let value = |ns: u64| {
                if *micros {
                    format!("{:.1}", ns as f64 / 1e3)
                } else {
                    ns.to_string()
                }
            };
            let [n, p50, p99, max] = match summary {
                Some(s) => [
                    s.count.to_string(),
                    value(s.p50),
                    value(s.p99),
                    value(s.max),
                ],
                None => ["0", "-", "-", "-"].map(String::from),
            };
            let rate = per_second(*rate);
            cells(
                label,
                width,
                &[
                    (unit, 4),
                    (&n, COUNT),
                    (&p50, COLUMN),
                    (&p99, COLUMN),
                    (&max, COLUMN),
                    (&rate, COLUMN + 2),
                ],
            )
        }
    }
}

fn optimality_line(row: &OptimalityRow, width: usize) -> String {
    match &row.ratios {
        Ok(r) => {
            let [n, p50, min, max, ours, reference, over, below] = [
                r.count.to_string(),
                format!("{:.3}", r.p50),
                format!("{:.3}", r.min),
                format!("{:.3}", r.max),
                format!("{:.3}", r.ours_p50_s),
                format!("{:.3}", r.reference_p50_s),
                r.over_target.to_string(),
                r.below_one.to_string(),
            ];
            cells(
                &row.label,
                width,
                &[
                    (&n, COUNT),
                    (&p50, COLUMN),
                    (&min, COLUMN),
                    (&max, COLUMN),
                    (&ours, COLUMN),
                    (&reference, COLUMN),
                    (&over, COLUMN),
                    (&below, COLUMN),
                ],
            )
        }
        Err(why) => format!("{:<width$} skipped: {why}", row.label),
    }
}

/// The whole table: `title` lines, the two sections, then `notes`.
pub fn render(
    title: &[String],
    timing: &[TimingRow],
    optimality: &[OptimalityRow],
    notes: &[String],
) -> String {
    let label = timing
        .iter()
        .map(|TimingRow::Measured { label, .. }| label)
        .chain(optimality.iter().map(|row| &row.label))
        .map(|label| label.chars().count())
        .fold(LABEL, usize::max);
    let timing_header = cells(
        "timing",
        label,
        &[
            ("unit", 4),
            ("n", COUNT),
            ("p50", COLUMN),
            ("p99", COLUMN),
            ("max", COLUMN),
            ("calls/s", COLUMN + 2),
        ],
    );
    let optimality_header = cells(
        "optimality: our duration / reference",
        label,
        &[
            ("n", COUNT),
            ("p50", COLUMN),
            ("min", COLUMN),
            ("max", COLUMN),
            ("ours s", COLUMN),
            ("ref s", COLUMN),
            (">1.02", COLUMN),
            ("<1.0", COLUMN),
        ],
    );
    let width = [&timing_header, &optimality_header]
        .iter()
        .map(|h| h.chars().count())
        .max()
        .unwrap_or(0);
    let rule = "-".repeat(width);
    let mut lines: Vec<String> = title.to_vec();
    lines.extend([rule.clone(), timing_header]);
    lines.extend(timing.iter().map(|row| timing_line(row, label)));
    lines.extend([rule.clone(), optimality_header]);
    lines.extend(optimality.iter().map(|row| optimality_line(row, label)));
    lines.push(rule);
    lines.extend_from_slice(notes);
    lines.join("\n") + "\n"
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ratios_count_misses_and_faster_moves_and_skip_failures() {
        let ours = [1.0, 2.1, 3.0, 0.9, 5.0];
        let reference = [1.0, 2.0, 3.0, 1.0, f64::NAN];
        let r = RatioStats::of(&ours, &reference).unwrap();
        assert_eq!((r.count, r.failed), (4, 1));
        assert_eq!(r.over_target, 1);
        assert_eq!(r.below_one, 1);
        assert!((r.min - 0.9).abs() < 1e-12 && (r.max - 1.05).abs() < 1e-12);
        assert_eq!((r.worst, r.best), (1, 3));
        assert_eq!(r.p50, 1.0);
        assert_eq!((r.ours_p50_s, r.reference_p50_s), (2.1, 2.0));
        assert_eq!(RatioStats::of(&[1.0], &[f64::NAN]), None);
        assert_eq!(
            RatioStats::of(&[f64::NAN, 1.0], &[1.0, 1.0])
                .unwrap()
                .failed,
            1
        );
    }

    #[test]
    fn rounding_is_not_faster() {
        let r = RatioStats::of(&[1.0 - 1e-12], &[1.0]).unwrap();
        assert_eq!(r.below_one, 0);
    }

    #[test]
    fn values_stand_under_their_headers() {
        let timing = [TimingRow::Measured {
            label: "IK".into(),
            micros: false,
            summary: Some(Summary {
                count: 100,
                p50: 412,
                p99: 530,
                p99_9: 600,
                max: 9120,
            }),
            per_second: 2.3e6,
        }];
        let optimality = [
            OptimalityRow {
                label: "joint".into(),
                ratios: Ok(RatioStats::of(&[1.1, 2.0], &[1.0, 2.0]).unwrap()),
            },
            OptimalityRow {
                label: "line".into(),
                ratios: Err("no reference".into()),
            },
        ];
        let text = render(&["title".into()], &timing, &optimality, &["note".into()]);
        let lines: Vec<&str> = text.lines().collect();
        let end = |line: &str, word: &str| {
            line.find(word)
                .map(|i| line[..i].chars().count() + word.chars().count())
        };
        let ik = lines.iter().find(|l| l.starts_with("IK")).unwrap();
        assert_eq!(end(ik, " 412"), end(lines[2], " p50"), "{text}");
        assert_eq!(end(ik, "2.30 M"), end(lines[2], "calls/s"), "{text}");
        let joint = lines.iter().find(|l| l.starts_with("joint")).unwrap();
        let header = lines.iter().find(|l| l.starts_with("optimality")).unwrap();
        assert_eq!(end(joint, " 1.100"), end(header, " p50"), "{text}");
        assert_eq!(
            joint.split_whitespace().collect::<Vec<_>>(),
            [
                "joint", "2", "1.100", "1.000", "1.100", "2.000", "2.000", "1", "0"
            ]
        );
        assert!(text.contains("line") && text.contains("skipped: no reference"));
        assert_eq!(*lines.last().unwrap(), "note");
    }

    #[test]
    fn a_long_label_widens_the_label_column_of_both_sections() {
        let long = "x".repeat(LABEL + 12);
        let timing = [TimingRow::Measured {
            label: "IK".into(),
            micros: false,
            summary: None,
            per_second: 1.0,
        }];
        let optimality = [OptimalityRow {
            label: long.clone(),
            ratios: Ok(RatioStats::of(&[1.0], &[1.0]).unwrap()),
        }];
        let text = render(&[], &timing, &optimality, &[]);
        let line = |start: &str| text.lines().find(|l| l.starts_with(start)).unwrap();
        let length = |start: &str| line(start).chars().count();
        assert_eq!(line("timing").find(" unit"), Some(LABEL + 12), "{text}");
        assert_eq!(length("timing"), length("IK"), "{text}");
        assert_eq!(length("optimality"), length(&long), "{text}");
    }
}
