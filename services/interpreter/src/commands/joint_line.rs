//! MoveLinearAbsoluteJ: the TCP on a straight line to a joint target. The target joints give
//! the TCP pose (forward kinematics with the move's tool), their configuration bits and turn
//! numbers; the planner's line then ends exactly at those joints (ConfigMode USE_CONFIG,
//! TurnMode USE_TURN_NUMBER).

use shared_types::ipc::{MotionCommand, MotionCommandKind};
use shared_types::srci::message::{CommandHeader, code};
use shared_types::srci::payload::PayloadReader;
use shared_types::srci::tables::move_linear_absolute_j as mlaj;

use super::motion::{self, DynamicsLayout, MoveLayout, decode_move, joint_target};
use crate::arm::ArmModel;
use crate::user_data::UserData;

/// ConfigMode USE_CONFIG of every element: the configuration bits sent with the pose.
const USE_CONFIG: u8 = 0;
/// TurnMode USE_TURN_NUMBER: the turn numbers sent with the pose.
const USE_TURN_NUMBER: u8 = 0;

const LAYOUT: MoveLayout = MoveLayout {
    dynamics: DynamicsLayout {
        velocity: mlaj::request::VELOCITY_RATE,
        acceleration: mlaj::request::ACCELERATION_RATE,
        deceleration: mlaj::request::DECELERATION_RATE,
        jerk: mlaj::request::JERK_RATE,
        time: mlaj::request::TIME,
    },
    tool: mlaj::request::TOOL_NO,
    blending_mode: mlaj::request::BLENDING_MODE,
    blending_parameter: mlaj::request::BLENDING_PARAMETER,
};

/// Checks a MoveLinearAbsoluteJ request and turns it into a MoveLinear to the TCP pose of
/// its joints (within the SW limits). Only an orientation turned to the target's (OriMode
/// 0, 1 and 4 PATH, which on a line is the same turn) or the wrist joints interpolated to
/// the target's (2) ends at the joints; FIX keeps the start orientation and is refused
/// (0x8E08).
pub(super) fn decode(
    msg: &[u8],
    h: CommandHeader,
    data: &UserData,
    arm: &ArmModel,
) -> Result<MotionCommand, u16> {
    let r = PayloadReader::new(msg);
    let mut c = decode_move(&r, &LAYOUT, h, MotionCommandKind::MoveLinear, data)?;
    let joints = joint_target(&r, mlaj::request::JOINT_POSITION_J1_J6, data)?;
    c.ori_mode = match motion::ori_mode(msg, mlaj::request::ORI_MODE)? {
        m @ (0..=2 | 4) => m,
        _ => return Err(code::ORI_MODE_NOT_SUPPORTED),
    };
    let target = arm
        .joint_target(&joints, c.tool)
        .ok_or(code::TARGET_UNREACHABLE)?;
    c.pose = target.pose;
    c.arm_config = target.arm_config;
    c.turn_numbers = target.turn_numbers;
    c.config_modes = [USE_CONFIG; 3];
    c.turn_mode = USE_TURN_NUMBER;
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::commands::test_support::{default_rates, factory_data, header};
    use crate::user_data::ToolData;
    use shared_types::srci::payload::PayloadWriter;

    fn request(joints_deg: [f32; 6], edit: impl FnOnce(&mut PayloadWriter)) -> Vec<u8> {
        let mut b = vec![0u8; mlaj::request::LEN];
        let mut w = PayloadWriter::new(&mut b);
        default_rates(&mut w, &LAYOUT.dynamics);
        for (f, v) in mlaj::request::JOINT_POSITION_J1_J6
            .into_iter()
            .zip(joints_deg)
        {
            w.set_f32(f, v);
        }
        edit(&mut w);
        b
    }

    #[test]
    fn the_target_joints_give_the_pose_configuration_and_turns_of_the_line() {
        let cfg = shared_types::config::Config::load(None).unwrap();
        let mut data = factory_data();
        let tool = ToolData {
            pose: [0.0, 0.0, 100.0, 0.0, 0.0, 0.0],
            ..Default::default()
        };
        data.write_tool(1, Default::default(), tool, false).unwrap();
        let arm = ArmModel::new(&cfg.robot.kinematics);
        let joints = [10.0, 80.0, 100.0, 80.0, -90.0, 200.0];
        let msg = request(joints, |w| w.set_u8(mlaj::request::TOOL_NO, 1));
        let c = decode(&msg, header(mlaj::TYPE), &data, &arm).unwrap();
        let q = joints.map(|d| f64::from(d).to_radians());
        let expected = arm.joint_target(&q, c.tool).unwrap();
        assert_eq!(c.kind, MotionCommandKind::MoveLinear as u8);
        assert_eq!(c.pose, expected.pose);
        assert_eq!(
            (c.arm_config, c.turn_numbers),
            (expected.arm_config, expected.turn_numbers)
        );
        assert_eq!(c.turn_numbers[2] >> 4, 1, "J6 one turn up");
        assert_eq!((c.config_modes, c.turn_mode), ([0; 3], 0));
        assert!((c.tool[2] - 0.1).abs() < 1e-9);
        // JOINT_INTERPOLATED and PATH end at the joints too.
        for ori_mode in [2, 4] {
            let msg = request(joints, |w| w.set_u8(mlaj::request::ORI_MODE, ori_mode));
            assert_eq!(
                decode(&msg, header(mlaj::TYPE), &data, &arm)
                    .unwrap()
                    .ori_mode,
                ori_mode
            );
        }
    }

    #[test]
    fn refusals_carry_their_codes() {
        let cfg = shared_types::config::Config::load(None).unwrap();
        let data = factory_data();
        let arm = ArmModel::new(&cfg.robot.kinematics);
        let home = [0.0, 90.0, 90.0, 90.0, -90.0, 0.0];
        let cases: [(Vec<u8>, u16); 5] = [
            (
                request([f32::NAN, 90.0, 90.0, 90.0, -90.0, 0.0], |_| {}),
                code::INVALID_JOINT_POSITION,
            ),
            (
                request([0.0, 90.0, 90.0, 90.0, -90.0, 1000.0], |_| {}),
                code::SW_LIMIT_UPPER,
            ),
            (
                request(home, |w| w.set_u8(mlaj::request::ORI_MODE, 3)),
                code::ORI_MODE_NOT_SUPPORTED,
            ),
            (
                request(home, |w| w.set_u8(mlaj::request::ORI_MODE, 5)),
                code::INVALID_ORI_MODE,
            ),
            (
                request(home, |w| w.set_u8(mlaj::request::BLENDING_MODE, 6)),
                code::INVALID_BLENDING_MODE,
            ),
        ];
        for (msg, expected) in cases {
            assert_eq!(
                decode(&msg, header(mlaj::TYPE), &data, &arm).unwrap_err(),
                expected
            );
        }
    }
}
