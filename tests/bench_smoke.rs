//! `rc bench latency` runs end to end (a short run): it prints the table with every row and
//! writes the percentile file. The numbers are only parsed, never judged: timing depends on
//! the machine.

use std::path::PathBuf;
use std::process::Command;

const PIPELINE_ROWS: [&str; 6] = [
    "8 ms idle",
    "8 ms load",
    "2 ms idle",
    "2 ms load",
    "1 ms idle",
    "1 ms load",
];

/// The cells of the table row starting with `label`, after the label.
fn cells<'a>(table: &'a str, label: &str) -> Vec<&'a str> {
    let line = table
        .lines()
        .find(|l| l.starts_with(&format!("{label} ")))
        .unwrap_or_else(|| panic!("no row '{label}' in:\n{table}"));
    line[label.len()..].split_whitespace().collect()
}

fn number(cell: &str, row: &str) -> f64 {
    cell.parse()
        .unwrap_or_else(|_| panic!("row '{row}': '{cell}' is not a number"))
}

/// Checks the row's unit and sample count (`None`: none shown) and that the `numbers` cells
/// after the count are numbers; returns its cells.
fn check_row<'a>(
    table: &'a str,
    label: &str,
    unit: &str,
    count: Option<f64>,
    numbers: usize,
) -> Vec<&'a str> {
    let c = cells(table, label);
    assert_eq!(c[0], unit, "row '{label}': {c:?}");
    match count {
        Some(n) => assert_eq!(number(c[1], label), n, "row '{label}': samples"),
        None => assert_eq!(c[1], "-", "row '{label}'"),
    }
    for cell in &c[2..2 + numbers] {
        number(cell, label);
    }
    c
}

#[test]
fn a_short_latency_run_prints_every_row_and_writes_the_distributions() {
    let dir: PathBuf = std::env::temp_dir().join(format!("rc-bench-smoke-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let output = Command::new(env!("CARGO_BIN_EXE_rc"))
        .args(["bench", "latency", "--cycles", "100"])
        .current_dir(&dir)
        .output()
        .expect("run rc bench latency");
    let table = String::from_utf8_lossy(&output.stdout).into_owned();
    assert!(
        output.status.success(),
        "rc bench latency failed ({}):\n{table}\n{}",
        output.status,
        String::from_utf8_lossy(&output.stderr)
    );

    for row in PIPELINE_ROWS {
        // unit, n p50 p99 p99.9 max, overrun timeout, servo n p50 p99 max overrun
        let c = check_row(&table, row, "µs", Some(100.0), 11);
        assert_eq!(c.len(), 13, "row '{row}': {c:?}");
    }
    // 10 samples per telegram cycle.
    check_row(&table, "interpreter on_telegram", "ns", Some(1000.0), 4);
    check_row(&table, "iceoryx2 hop one-way", "µs", Some(1000.0), 4);
    check_row(&table, "UDS hop one-way", "µs", Some(1000.0), 4);
    check_row(&table, "UDS / iceoryx2", "x", None, 4);

    let hgrm = std::fs::read_to_string(dir.join("bench-latency.hgrm")).expect("the .hgrm file");
    std::fs::remove_dir_all(&dir).unwrap();
    // Per pipeline row a round-trip and a servo section, then processing and the two hops.
    assert_eq!(hgrm.matches("Total count").count(), 6 * 2 + 3);
    let said = table
        .lines()
        .find_map(|l| l.strip_prefix("percentile distributions: "))
        .expect("the table names the .hgrm file");
    assert!(said.ends_with("/bench-latency.hgrm"), "{said}");
}
