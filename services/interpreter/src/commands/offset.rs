//! MoveDirectOffset and MoveLinearOffset: a target given as a ReferencePosition in FrameNo
//! and an Offset from it, along and about the axes ReferenceType names (those of the
//! reference position itself, TOOL, or those of the frame, FRAME). The target is absolute
//! and goes to the planner as a MoveDirect or MoveLinear to it; the configuration and turns
//! are the reference position's (the Offset's own are not used: it is a displacement).

use shared_types::ipc::{MotionCommand, MotionCommandKind};
use shared_types::pose;
use shared_types::srci::message::CommandHeader;
use shared_types::srci::payload::{Field, PayloadReader};
use shared_types::srci::tables::{move_direct_offset as mdo, move_linear_offset as mlo};

use super::motion::{self, CartesianLayout, DynamicsLayout, MoveLayout, wire_pose};
use super::relative::reference_type;
use crate::displacement;
use crate::tcp_pose;
use crate::user_data::UserData;

/// Where an offset move's fields sit: the ReferencePosition as the Cartesian target, the
/// Offset, ReferenceType and OriMode.
struct OffsetLayout {
    reference: CartesianLayout,
    offset: [Field; 6],
    reference_type: Field,
    ori_mode: Field,
}

const MOVE_DIRECT_OFFSET: OffsetLayout = OffsetLayout {
    reference: CartesianLayout {
        common: MoveLayout {
            dynamics: DynamicsLayout {
                velocity: mdo::request::VELOCITY_RATE,
                acceleration: mdo::request::ACCELERATION_RATE,
                deceleration: mdo::request::DECELERATION_RATE,
                jerk: mdo::request::JERK_RATE,
                time: mdo::request::TIME,
            },
            tool: mdo::request::TOOL_NO,
            blending_mode: mdo::request::BLENDING_MODE,
            blending_parameter: mdo::request::BLENDING_PARAMETER,
        },
        frame: mdo::request::FRAME_NO,
        position: mdo::request::REFERENCE_POSITION_X_RZ,
        shoulder: mdo::request::SHOULDER,
        elbow: mdo::request::ELBOW,
        wrist: mdo::request::WRIST,
        turn_number: mdo::request::REFERENCE_POSITION_TURN_NUMBER,
        config_mode: mdo::request::CONFIG_MODE,
        turn_mode: mdo::request::TURN_MODE,
    },
    offset: mdo::request::OFFSET_X_RZ,
    reference_type: mdo::request::REFERENCE_TYPE,
    ori_mode: mdo::request::ORI_MODE,
};

const MOVE_LINEAR_OFFSET: OffsetLayout = OffsetLayout {
    reference: CartesianLayout {
        common: MoveLayout {
            dynamics: DynamicsLayout {
                velocity: mlo::request::VELOCITY_RATE,
                acceleration: mlo::request::ACCELERATION_RATE,
                deceleration: mlo::request::DECELERATION_RATE,
                jerk: mlo::request::JERK_RATE,
                time: mlo::request::TIME,
            },
            tool: mlo::request::TOOL_NO,
            blending_mode: mlo::request::BLENDING_MODE,
            blending_parameter: mlo::request::BLENDING_PARAMETER,
        },
        frame: mlo::request::FRAME_NO,
        position: mlo::request::REFERENCE_POSITION_X_RZ,
        shoulder: mlo::request::SHOULDER,
        elbow: mlo::request::ELBOW,
        wrist: mlo::request::WRIST,
        turn_number: mlo::request::REFERENCE_POSITION_TURN_NUMBER,
        config_mode: mlo::request::CONFIG_MODE,
        turn_mode: mlo::request::TURN_MODE,
    },
    offset: mlo::request::OFFSET_X_RZ,
    reference_type: mlo::request::REFERENCE_TYPE,
    ori_mode: mlo::request::ORI_MODE,
};

/// Checks a MoveDirectOffset or MoveLinearOffset request and turns it into a MoveDirect or
/// MoveLinear to the reference position displaced by the offset, in the base frame.
pub(super) fn decode(msg: &[u8], h: CommandHeader, data: &UserData) -> Result<MotionCommand, u16> {
    let (layout, kind) = if h.command_type == mlo::TYPE {
        (&MOVE_LINEAR_OFFSET, MotionCommandKind::MoveLinear)
    } else {
        (&MOVE_DIRECT_OFFSET, MotionCommandKind::MoveDirect)
    };
    let (mut c, reference) = motion::decode_cartesian(msg, h, data, &layout.reference, kind)?;
    let r = PayloadReader::new(msg);
    let offset = wire_pose(&r, layout.offset)?;
    let axes = reference_type(&r, layout.reference_type)?;
    let frame = tcp_pose::world_frame(data, r.u8(layout.reference.frame))?;
    let target = displacement::offset(
        &tcp_pose::from_wire(reference),
        &tcp_pose::from_wire(offset),
        axes,
    );
    c.pose = pose::pose(&(frame * target));
    c.ori_mode = motion::ori_mode(msg, layout.ori_mode)?;
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::commands::test_support::{cartesian_request, factory_data, header};
    use crate::user_data::FrameData;
    use shared_types::ipc::TargetReference;
    use shared_types::srci::message::code;
    use shared_types::srci::payload::PayloadWriter;

    fn request(layout: &OffsetLayout, edit: impl FnOnce(&mut PayloadWriter)) -> Vec<u8> {
        // The reference turned 90° about Z in the frame: its X is the frame's Y.
        let reference = [300.0, 0.0, 200.0, 0.0, 0.0, 90.0];
        cartesian_request(&layout.reference, mlo::request::LEN, reference, |w| {
            w.set_u8(layout.reference.frame, 2);
            for (f, v) in layout
                .offset
                .into_iter()
                .zip([20.0, 0.0, 0.0, 0.0, 0.0, 0.0])
            {
                w.set_f32(f, v);
            }
            edit(w);
        })
    }

    /// Frame 2: 100 mm along the world's X, not turned.
    fn data() -> UserData {
        let mut data = factory_data();
        let frame = FrameData {
            pose: [100.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            ..Default::default()
        };
        data.write_frame(2, Default::default(), frame).unwrap();
        data
    }

    fn assert_position(c: &MotionCommand, expected: [f64; 3]) {
        for (a, b) in c.pose.iter().zip(expected) {
            assert!((a - b).abs() < 1e-9, "{:?}", c.pose);
        }
    }

    #[test]
    fn the_offset_follows_the_reference_axes_or_the_frame_axes() {
        let tool = request(&MOVE_LINEAR_OFFSET, |_| {});
        let c = decode(&tool, header(mlo::TYPE), &data()).unwrap();
        assert_eq!(c.kind, MotionCommandKind::MoveLinear as u8);
        assert_eq!(c.target_reference, TargetReference::Absolute as u8);
        assert_position(&c, [0.4, 0.02, 0.2]);
        let frame = request(&MOVE_DIRECT_OFFSET, |w| {
            w.set_u8(mdo::request::REFERENCE_TYPE, 1);
        });
        let c = decode(&frame, header(mdo::TYPE), &data()).unwrap();
        assert_eq!(c.kind, MotionCommandKind::MoveDirect as u8);
        assert_position(&c, [0.42, 0.0, 0.2]);
    }

    #[test]
    fn bad_offsets_are_refused() {
        let nan = request(&MOVE_LINEAR_OFFSET, |w| {
            w.set_f32(mlo::request::OFFSET_RY, f32::NAN)
        });
        assert_eq!(
            decode(&nan, header(mlo::TYPE), &data()).unwrap_err(),
            code::INVALID_POSITION
        );
        let undefined = request(&MOVE_LINEAR_OFFSET, |w| {
            w.set_u8(mlo::request::REFERENCE_TYPE, 3);
        });
        assert_eq!(
            decode(&undefined, header(mlo::TYPE), &data()).unwrap_err(),
            code::INVALID_MODE
        );
    }
}
