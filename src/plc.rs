//! Playing the PLC: run an SRCI program against a controller with live progress on stdout,
//! then print the report table (`rc plc`, `rc demo`).

use std::io::{self, IsTerminal, Write};
use std::path::Path;
use std::time::Duration;

use anyhow::Context;
use plc_client::{ClientError, ClientOptions, Program, ProgressEvent};
use shared_types::srci::message::state;

/// Loads the program at `path` and runs it against `addr`; `Ok(true)` if every step passed.
pub fn run_file(
    path: &Path,
    addr: &str,
    cycle_time: Duration,
    lifesign_timeout_ms: u16,
) -> anyhow::Result<bool> {
    let program = Program::load(path)?;
    let mut options = ClientOptions::default();
    options.engine.cycle_time = cycle_time;
    options.engine.lifesign_timeout_ms = lifesign_timeout_ms;
    execute(addr, &program, &options)
}

/// Runs `program` against `addr`, showing progress, then prints the report table.
/// `Ok(true)` if every step passed; an error if the session could not run to the end.
pub fn execute(addr: &str, program: &Program, options: &ClientOptions) -> anyhow::Result<bool> {
    let stdout = io::stdout();
    let mut printer = ProgressPrinter::new(program, stdout.is_terminal());
    let result = plc_client::run_program(addr, program, options, &mut |event| {
        // Progress display is best effort; the report below is what counts.
        let _ = printer.show(&mut stdout.lock(), event);
    });
    let _ = printer.end_live_line(&mut stdout.lock());
    let (report, interruption) = match result {
        Ok(report) => (report, None),
        Err(ClientError::Interrupted { report, cause }) => (*report, Some(cause)),
        Err(e) => {
            return Err(e).with_context(|| format!("program '{}' on {addr}", program.name));
        }
    };
    let mut out = stdout.lock();
    writeln!(out)?;
    report.print_table(&mut out)?;
    out.flush()?;
    if let Some(cause) = interruption {
        return Err(cause).with_context(|| format!("program '{}' stopped early", program.name));
    }
    Ok(report.success())
}

/// Turns progress events into lines: one per state change, and a percentage for moves
/// (updated in place on a terminal, every 10 % otherwise).
struct ProgressPrinter<'a> {
    program: &'a Program,
    in_place: bool,
    /// A progress line is shown without its line break (terminal only).
    live_line: bool,
    /// The last move progress printed: step index and tens of percent.
    last_progress: Option<(usize, u8)>,
}

impl<'a> ProgressPrinter<'a> {
    fn new(program: &'a Program, in_place: bool) -> Self {
        Self {
            program,
            in_place,
            live_line: false,
            last_progress: None,
        }
    }

    fn call(&self, index: usize) -> &str {
        index
            .checked_sub(1)
            .and_then(|i| self.program.steps.get(i))
            .map_or("?", |step| step.call.as_str())
    }

    fn show(&mut self, out: &mut impl Write, event: &ProgressEvent) -> io::Result<()> {
        if let ProgressEvent::MoveProgress { index, percent } = *event {
            return self.show_progress(out, index, percent);
        }
        self.end_live_line(out)?;
        match event {
            ProgressEvent::Initialized {
                handshake,
                manufacturer,
            } => writeln!(
                out,
                "SRCI interface initialized in {:.1} ms (robot: {manufacturer})",
                handshake.as_secs_f64() * 1e3
            ),
            ProgressEvent::StepStarted { index, call } => {
                writeln!(out, "[{index}] {call}: submitted")
            }
            ProgressEvent::StateChanged { index, state, code } => writeln!(
                out,
                "[{index}] {}: {}{}",
                self.call(*index),
                state::name(*state),
                code_suffix(*code)
            ),
            ProgressEvent::StepFinished {
                index,
                state,
                code,
                passed,
            } => writeln!(
                out,
                "[{index}] {}: finished {state}{} -> {}",
                self.call(*index),
                code_suffix(*code),
                if *passed { "ok" } else { "FAILED" }
            ),
            ProgressEvent::Message(message) => writeln!(
                out,
                "robot message {}: severity {} code 0x{:08X} {}",
                message.msg_id, message.severity, message.code, message.text
            ),
            ProgressEvent::MoveProgress { .. } => Ok(()),
        }
    }

    fn show_progress(
        &mut self,
        out: &mut impl Write,
        index: usize,
        percent: f64,
    ) -> io::Result<()> {
        let line = format!("[{index}] {}: {percent:5.1} %", self.call(index));
        if self.in_place {
            write!(out, "\r{line}\x1b[K")?;
            self.live_line = true;
            return out.flush();
        }
        let tens = tens_of_percent(percent);
        if self.last_progress != Some((index, tens)) {
            self.last_progress = Some((index, tens));
            writeln!(out, "{line}")?;
        }
        Ok(())
    }

    fn end_live_line(&mut self, out: &mut impl Write) -> io::Result<()> {
        if std::mem::take(&mut self.live_line) {
            writeln!(out)?;
        }
        Ok(())
    }
}

/// Which tenth of the way a move is in (0..=10).
fn tens_of_percent(percent: f64) -> u8 {
    // Clamped first, so the cast cannot truncate.
    (percent.clamp(0.0, 100.0) / 10.0).floor() as u8
}

fn code_suffix(code: u16) -> String {
    if code == 0 {
        String::new()
    } else {
        format!(" (code 0x{code:04X})")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn demo() -> Program {
        Program::parse(plc_client::DEMO_PROGRAM, "demo").unwrap()
    }

    fn render(in_place: bool, events: &[ProgressEvent]) -> String {
        let program = demo();
        let mut printer = ProgressPrinter::new(&program, in_place);
        let mut out = Vec::new();
        for event in events {
            printer.show(&mut out, event).unwrap();
        }
        printer.end_live_line(&mut out).unwrap();
        String::from_utf8(out).unwrap()
    }

    fn progress(percent: f64) -> ProgressEvent {
        ProgressEvent::MoveProgress { index: 4, percent }
    }

    #[test]
    fn state_changes_name_the_step_and_code() {
        let text = render(
            false,
            &[
                ProgressEvent::StateChanged {
                    index: 4,
                    state: state::ABORTED,
                    code: 0x6C06,
                },
                ProgressEvent::StepFinished {
                    index: 4,
                    state: "ABORTED".into(),
                    code: 0x6C06,
                    passed: true,
                },
            ],
        );
        assert_eq!(
            text,
            "[4] MoveAxesAbsolute: ABORTED (code 0x6C06)\n\
             [4] MoveAxesAbsolute: finished ABORTED (code 0x6C06) -> ok\n"
        );
    }

    #[test]
    fn move_progress_is_printed_every_ten_percent_off_a_terminal() {
        let events: Vec<_> = [1.0, 5.0, 10.0, 19.0, 20.5, 100.0].map(progress).into();
        let text = render(false, &events);
        let percents: Vec<_> = text
            .lines()
            .map(|l| l.rsplit(": ").next().unwrap())
            .collect();
        assert_eq!(percents, ["  1.0 %", " 10.0 %", " 20.5 %", "100.0 %"]);
    }

    #[test]
    fn move_progress_updates_one_line_on_a_terminal() {
        let text = render(
            true,
            &[
                progress(10.0),
                progress(20.0),
                ProgressEvent::StateChanged {
                    index: 4,
                    state: state::DONE,
                    code: 0,
                },
            ],
        );
        assert_eq!(
            text,
            "\r[4] MoveAxesAbsolute:  10.0 %\x1b[K\r[4] MoveAxesAbsolute:  20.0 %\x1b[K\n\
             [4] MoveAxesAbsolute: DONE\n"
        );
    }

    #[test]
    fn tens_of_percent_is_clamped() {
        assert_eq!(tens_of_percent(-3.0), 0);
        assert_eq!(tens_of_percent(99.9), 9);
        assert_eq!(tens_of_percent(250.0), 10);
        assert_eq!(tens_of_percent(f64::NAN), 0);
    }
}
