//! The result of a program run: one row per step plus session statistics.

use std::io::{self, Write};
use std::time::Duration;

use crate::response::{ActualPosition, RobotData, RobotMessage};
use crate::target::{Deviation, Target, six_values};
use crate::transport::RoundTripSummary;

/// The result of one step.
#[derive(Debug, Clone, PartialEq)]
pub struct StepReport {
    /// 1-based step number.
    pub index: usize,
    pub call: String,
    /// Final state name ("DONE", "ABORTED", "ERROR"), "ACTIVE" for an Enable-type command
    /// that accepted its parameters, or what kept the step from ending ("TIMEOUT",
    /// "SKIPPED", "NOT SENT", "ABANDONED").
    pub state: String,
    /// AlarmMessageCode of the last response.
    pub code: u16,
    /// Submission to the final (or accepted) state.
    pub duration: Option<Duration>,
    /// The absolute target of a move.
    pub target: Option<Target>,
    /// The position read back: for a move with a target, by the first ReadActualPosition
    /// step submitted after it was DONE (and before the next move); for a
    /// ReadActualPosition step, what it read.
    pub reached: Option<ActualPosition>,
    /// How far `reached` lies from `target`, where the two could be compared.
    pub deviation: Option<Deviation>,
    pub passed: bool,
    /// Why the step failed, or other remarks (a target that could not be compared).
    pub note: String,
    /// For a step of a call without a typed request that does not move the arm (a read or
    /// a write by its table's fields): its response by field, name and value as text.
    pub response: Vec<(&'static str, String)>,
}

impl StepReport {
    /// The position read back, as the target is given: the pose for a pose, else the
    /// joints.
    fn reached_text(&self) -> String {
        match (self.target, self.reached) {
            (_, None) => "-".to_owned(),
            (Some(Target::Pose { .. }), Some(r)) => format!("pose {}", six_values(&r.cartesian)),
            (_, Some(r)) => format!("joints {}", six_values(&r.joints_deg)),
        }
    }
}

/// The result of a program run.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    pub program: String,
    /// From the first telegram to the end of the start-up chain.
    pub handshake: Duration,
    pub steps: Vec<StepReport>,
    pub round_trips: RoundTripSummary,
    pub cycles: u64,
    /// Cycles that ended after their deadline.
    pub overruns: u64,
    /// Robot telegrams dropped as torn or of the wrong length.
    pub invalid_frames: u64,
    /// Robot messages received through ReadMessages.
    pub messages: Vec<RobotMessage>,
    /// The robot's ReadRobotData answer.
    pub robot: Option<RobotData>,
}

fn ms(d: Duration) -> String {
    format!("{:.1} ms", d.as_secs_f64() * 1e3)
}

impl Report {
    /// Whether every step passed.
    pub fn success(&self) -> bool {
        self.steps.iter().all(|s| s.passed)
    }

    /// Writes the steps as an aligned text table, then the session statistics.
    pub fn print_table(&self, w: &mut impl Write) -> io::Result<()> {
        const HEADER: [&str; 9] = [
            "#",
            "call",
            "state",
            "code",
            "time",
            "target [deg | mm, deg]",
            "reached",
            "deviation",
            "result",
        ];
        let rows: Vec<[String; 9]> = self
            .steps
            .iter()
            .map(|s| {
                [
                    s.index.to_string(),
                    s.call.clone(),
                    s.state.clone(),
                    format!("0x{:04X}", s.code),
                    s.duration.map_or_else(|| "-".to_owned(), ms),
                    s.target.map_or_else(|| "-".to_owned(), |t| t.to_string()),
                    s.reached_text(),
                    s.deviation
                        .map_or_else(|| "-".to_owned(), |d| d.to_string()),
                    if s.passed && s.note.is_empty() {
                        "ok".to_owned()
                    } else if s.passed {
                        format!("ok ({})", s.note)
                    } else {
                        format!("FAILED {}", s.note)
                    },
                ]
            })
            .collect();
        let mut width = HEADER.map(str::len);
        for row in &rows {
            for (w, cell) in width.iter_mut().zip(row) {
                *w = (*w).max(cell.chars().count());
            }
        }
        let line = |w: &mut dyn Write, cells: [&str; 9]| -> io::Result<()> {
            let mut text = String::new();
            for (i, cell) in cells.iter().enumerate() {
                if i > 0 {
                    text.push_str("  ");
                }
                // The last column is not padded, so lines carry no trailing blanks.
                if i + 1 == cells.len() {
                    text.push_str(cell);
                } else {
                    text.push_str(&format!("{cell:<0$}", width[i]));
                }
            }
            writeln!(w, "{}", text.trim_end())
        };
        writeln!(w, "program {}", self.program)?;
        line(w, HEADER)?;
        for row in &rows {
            line(w, row.each_ref().map(String::as_str))?;
        }
        writeln!(w)?;
        if let Some(robot) = &self.robot {
            writeln!(
                w,
                "robot: {} (interpreter cycle {} ms)",
                robot.manufacturer, robot.interpreter_cycle_time_ms
            )?;
        }
        writeln!(w, "handshake: {}", ms(self.handshake))?;
        let rt = &self.round_trips;
        let us = |d: Duration| format!("{:.3} ms", d.as_secs_f64() * 1e3);
        writeln!(
            w,
            "round trip: median {}, p99 {}, worst {} over {} exchanges",
            us(rt.median),
            us(rt.p99),
            us(rt.max),
            rt.count
        )?;
        writeln!(
            w,
            "cycles: {}, overruns: {}, invalid robot frames: {}",
            self.cycles, self.overruns, self.invalid_frames
        )?;
        for m in &self.messages {
            writeln!(
                w,
                "message {}: severity {} code 0x{:08X} {}",
                m.msg_id, m.severity, m.code, m.text
            )?;
        }
        for s in self.steps.iter().filter(|s| !s.response.is_empty()) {
            writeln!(w, "step {} {}:", s.index, s.call)?;
            for (name, value) in &s.response {
                writeln!(w, "  {name} = {value}")?;
            }
        }
        let passed = self.steps.iter().filter(|s| s.passed).count();
        writeln!(
            w,
            "result: {} ({passed}/{} steps passed)",
            if self.success() { "SUCCESS" } else { "FAILURE" },
            self.steps.len()
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_is_aligned_and_reports_failures() {
        let step = |index, call: &str, passed| StepReport {
            index,
            call: call.to_owned(),
            state: "DONE".to_owned(),
            code: 0,
            duration: Some(Duration::from_millis(12)),
            target: None,
            reached: None,
            deviation: None,
            passed,
            note: String::new(),
            response: Vec::new(),
        };
        let mut mv = step(2, "MoveAxesAbsolute", false);
        mv.target = Some(Target::Joints([0.0, 90.0, 90.0, 90.0, -90.0, 0.0]));
        mv.reached = Some(ActualPosition {
            tool: 0,
            frame: 0,
            cartesian: [0.0; 6],
            joints_deg: [0.0, 90.5, 90.0, 90.0, -90.0, 0.0],
        });
        mv.deviation = Some(Deviation::Joints { deg: 0.5 });
        mv.note = "expected ABORTED".to_owned();
        let mut read = step(3, "ReadToolData", true);
        read.response = vec![
            ("tool_no", "2".to_owned()),
            ("tool_data_id", "7".to_owned()),
        ];
        let report = Report {
            program: "t".to_owned(),
            handshake: Duration::from_millis(50),
            steps: vec![step(1, "GroupReset", true), mv, read],
            round_trips: RoundTripSummary::default(),
            cycles: 10,
            overruns: 0,
            invalid_frames: 0,
            messages: Vec::new(),
            robot: None,
        };
        assert!(!report.success());
        let mut out = Vec::new();
        report.print_table(&mut out).unwrap();
        let text = String::from_utf8(out).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        let col = |l: &str| l.find("state").or_else(|| l.find("DONE")).unwrap();
        assert_eq!(col(lines[1]), col(lines[2]));
        assert_eq!(col(lines[2]), col(lines[3]));
        assert!(text.contains("FAILED expected ABORTED"));
        assert!(text.contains("step 3 ReadToolData:\n  tool_no = 2\n  tool_data_id = 7\n"));
        assert!(text.contains("result: FAILURE (2/3 steps passed)"));
    }
}
