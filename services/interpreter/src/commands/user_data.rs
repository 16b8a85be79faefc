//! The user-data functions as commands: Read/Write ToolData, FrameData, LoadData,
//! RobotDefaultDynamics, RobotReferenceDynamics and RobotSWLimits, executed at once against
//! the store and answered DONE (with the full response) or ERROR.

use shared_types::srci::message::{CommandHeader, state};

use crate::server::{Now, Server};
use crate::user_data::srci;

impl Server {
    /// Executes user-data function `h.command_type`; `false` if it is not one.
    pub(crate) fn user_data_command(
        &mut self,
        cmd_id: u16,
        h: CommandHeader,
        msg: &[u8],
        now: Now,
    ) -> bool {
        // A running, queued or interrupted move uses the current tool and load.
        let moving = self
            .status
            .is_some_and(|s| s.moving || s.active_job != 0 || s.queued_jobs != 0);
        let Some(outcome) = srci::execute(&mut self.user_data, h.command_type, msg, moving) else {
            return false;
        };
        match outcome {
            Ok(reply) => self.respond(cmd_id, h, state::DONE, 0, now, |b| reply.encode(b)),
            Err(code) => self.respond(cmd_id, h, state::ERROR, code, now, |_| {}),
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::super::IMPLEMENTED;
    use crate::user_data::srci::FUNCTIONS;

    #[test]
    fn every_user_data_function_is_announced() {
        for ty in FUNCTIONS {
            assert!(
                IMPLEMENTED.contains(&ty),
                "type {ty} missing in IMPLEMENTED"
            );
        }
    }
}
