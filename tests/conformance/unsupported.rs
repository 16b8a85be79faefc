//! Every command type the controller does not announce in RCSupportedFunctions is answered
//! ERROR 0x8F11 (not implemented), with a ReadMessages entry.

use std::time::Duration;

use plc_client::Request;
use shared_types::srci::message::{code, severity, state};
use shared_types::srci::tables::{self as t, COMMAND_TYPES};

use crate::common::{initialized, wait_for_message};

/// Functions being added in this development round that have no RCSupportedFunctions bit,
/// so that the map cannot tell whether they are implemented.
const WITHOUT_A_BIT_IN_PROGRESS: [u16; 2] = [t::create_server_log::TYPE, t::read_server_log::TYPE];

#[test]
fn every_function_not_announced_is_answered_8f11() {
    let (_c, mut plc) = initialized("unsup");
    let data = plc.task().robot_data().cloned().expect("ReadRobotData");
    let unannounced: Vec<(&str, u16)> = COMMAND_TYPES
        .iter()
        .copied()
        .filter(|&(_, ty)| !data.supports(ty) && !WITHOUT_A_BIT_IN_PROGRESS.contains(&ty))
        .collect();
    assert!(unannounced.len() > 70, "most of the 115 functions");
    // In batches that fit the Active Command Register, header-only requests.
    for batch in unannounced.chunks(24) {
        let handles: Vec<_> = batch
            .iter()
            .map(|&(_, ty)| {
                plc.task_mut()
                    .submit(&Request::Raw {
                        command_type: ty,
                        execution_mode: 2,
                        payload: Vec::new(),
                    })
                    .expect("submit")
            })
            .collect();
        plc.run_until(
            |task| {
                handles
                    .iter()
                    .all(|h| task.status(*h).is_some_and(|s| s.is_final()))
            },
            Duration::from_secs(10),
        )
        .expect("every command answered");
        for (&(name, ty), h) in batch.iter().zip(&handles) {
            let s = plc.task().status(*h).cloned().expect("status");
            assert_eq!(
                (s.state, s.severity, s.code),
                (state::ERROR, severity::ERROR, code::NOT_IMPLEMENTED),
                "{name} ({ty}) not announced, so not implemented: {s:?}"
            );
            plc.task_mut().release(*h);
        }
    }
    let m = wait_for_message(&mut plc, code::NOT_IMPLEMENTED);
    assert_eq!((m.msg_type, m.severity), (4, severity::ERROR), "{m:?}");
}

/// A command type the specification does not define at all is "command type out of range"
/// (0x8F20), not "not implemented" (0x8F11, for defined functions the robot lacks).
#[test]
fn an_undefined_command_type_is_out_of_range() {
    use crate::common::execute;
    let (_c, mut plc) = initialized("undef");
    for ty in [0u16, 4242, 65535] {
        assert!(
            COMMAND_TYPES.iter().all(|&(_, t)| t != ty),
            "{ty} undefined"
        );
        let request = Request::Raw {
            command_type: ty,
            execution_mode: 2,
            payload: Vec::new(),
        };
        let s = execute(&mut plc, &request, Duration::from_secs(5));
        // A type outside the specification's command catalogue is out of range.
        assert_eq!(
            (s.state, s.severity, s.code),
            (state::ERROR, severity::ERROR, 0x8F20),
            "type {ty} is not in the catalogue, so 0x8F20 (out of range): {s:?}"
        );
    }
}
