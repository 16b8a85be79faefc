//! The actual position in any tool and frame: the flange pose in the world frame (from the
//! planner) composed with the tool offset and the chain of user frames (from the user data).
//!
//! Orientation convention of every pose: [`shared_types::pose`].

use nalgebra::Isometry3;
use shared_types::pose;

use crate::user_data::{HIGHEST_INDEX, UserData};

/// A pose as SRCI sends it: X, Y, Z in mm, RX, RY, RZ in degrees.
pub type WirePose = [f64; 6];

/// An SRCI pose (mm, degrees) as an isometry in metres.
pub fn from_wire(p: WirePose) -> Isometry3<f64> {
    pose::isometry([
        p[0] / 1000.0,
        p[1] / 1000.0,
        p[2] / 1000.0,
        p[3].to_radians(),
        p[4].to_radians(),
        p[5].to_radians(),
    ])
}

/// An isometry in metres as an SRCI pose (mm, degrees).
pub fn to_wire(t: &Isometry3<f64>) -> WirePose {
    let p = pose::pose(t);
    [
        p[0] * 1000.0,
        p[1] * 1000.0,
        p[2] * 1000.0,
        p[3].to_degrees(),
        p[4].to_degrees(),
        p[5].to_degrees(),
    ]
}

/// Frame `frame` (255 = the one in use) in the world, or the code that refuses the index.
pub fn world_frame(data: &UserData, frame: u8) -> Result<Isometry3<f64>, u16> {
    let (frame_no, _) = data.read_frame(frame)?;
    world_to_frame(data, frame_no)
}

/// World → frame `index` through its reference frames (the store refuses cycles; the
/// chain is bounded by the number of frames anyway).
fn world_to_frame(data: &UserData, index: u8) -> Result<Isometry3<f64>, u16> {
    let mut t = Isometry3::identity();
    let mut i = index;
    for _ in 0..=HIGHEST_INDEX {
        if i == 0 {
            return Ok(t);
        }
        let (_, frame) = data.read_frame(i)?;
        t = from_wire(frame.data.pose.map(f64::from)) * t;
        i = frame.data.reference_frame;
    }
    Ok(t)
}

/// The TCP of tool `tool` in frame `frame` (255 = the one in use) for the flange pose
/// `flange` (world frame: m and rad, R = Rz·Ry·Rx); returns the tool and frame numbers used
/// and the pose, or the code that refuses an index.
pub fn tcp_pose(
    data: &UserData,
    flange: [f64; 6],
    tool: u8,
    frame: u8,
) -> Result<(u8, u8, WirePose), u16> {
    let (tool_no, tool_entry) = data.read_tool(tool)?;
    let (frame_no, _) = data.read_frame(frame)?;
    let world_flange = pose::isometry(flange);
    let flange_tcp = from_wire(tool_entry.data.pose.map(f64::from));
    let world_frame = world_to_frame(data, frame_no)?;
    let frame_tcp = world_frame.inverse() * world_flange * flange_tcp;
    Ok((tool_no, frame_no, to_wire(&frame_tcp)))
}

/// The TCP of tool `tool` (255 = the one in use) in the flange frame: m and rad
/// (R = Rz·Ry·Rx), as the planner takes it; or the code that refuses the index.
pub fn tool_offset(data: &UserData, tool: u8) -> Result<[f64; 6], u16> {
    let (_, entry) = data.read_tool(tool)?;
    Ok(pose::pose(&from_wire(entry.data.pose.map(f64::from))))
}

/// A target given in frame `frame` (255 = the one in use; mm and degrees) in the world
/// frame: m and rad (R = Rz·Ry·Rx), as the planner takes it; or the code that refuses the
/// index.
pub fn world_target(data: &UserData, frame: u8, target: WirePose) -> Result<[f64; 6], u16> {
    let (frame_no, _) = data.read_frame(frame)?;
    let world_frame = world_to_frame(data, frame_no)?;
    Ok(pose::pose(&(world_frame * from_wire(target))))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wire_poses_round_trip() {
        let p = [500.0, -20.0, 300.0, 10.0, -35.0, 120.0];
        let back = to_wire(&from_wire(p));
        for (a, b) in p.iter().zip(back) {
            assert!((a - b).abs() < 1e-9, "{p:?} vs {back:?}");
        }
    }

    #[test]
    fn tool_zero_in_frame_zero_is_the_flange() {
        let cfg = shared_types::config::Config::load(None).unwrap();
        let data = UserData::factory(crate::user_data::RobotBounds::of(&cfg.robot).0);
        let flange = [0.5, 0.1, 0.3, 0.0, core::f64::consts::FRAC_PI_2, 0.0];
        let (t, f, p) = tcp_pose(&data, flange, 255, 255).unwrap();
        assert_eq!((t, f), (0, 0));
        assert!(
            (p[0] - 500.0).abs() < 1e-9 && (p[4] - 90.0).abs() < 1e-9,
            "{p:?}"
        );
    }
}
