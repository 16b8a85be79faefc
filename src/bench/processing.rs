//! Interpreter processing time: how long the SRCI server core takes to answer one telegram,
//! measured in-process on the [`Rig`] (no IPC, no network).

use std::time::Instant;

use shared_types::config::Config;

use super::elapsed_ns;
use super::rig::{Rig, RigError};
use super::stats::{Distribution, Recorder};

/// Telegrams the PLC may need for start-up, GroupReset and EnableRobot.
const START_LIMIT: usize = 10_000;

/// What was measured.
pub struct Processing {
    /// Time per call (ns).
    pub times: Distribution,
    /// Moves the PLC completed meanwhile.
    pub moves: u64,
}

/// Times `telegrams` calls of `Server::on_telegram` in a session whose PLC keeps moving the
/// arm back and forth.
pub fn measure(config: &Config, telegrams: usize) -> Result<Processing, RigError> {
    let mut rig = Rig::new(config)?;
    rig.run_until_moving(START_LIMIT)?;
    let moves_before = rig.moves_done();
    let mut times = Recorder::with_capacity(telegrams);
    for _ in 0..telegrams {
        rig.prepare()?;
        let start = Instant::now();
        rig.answer();
        times.record(elapsed_ns(start));
        rig.absorb()?;
    }
    Ok(Processing {
        times: times.into_distribution(),
        moves: rig.moves_done() - moves_before,
    })
}
