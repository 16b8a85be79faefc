//! Where a move is asked to end, and how far from it the arm was read back.
//!
//! A move with an absolute target names it either in joints (MoveAxesAbsolute,
//! MoveLinearAbsoluteJ) or as a pose of a tool in a frame (MoveLinearAbsolute,
//! MoveDirectAbsolute, MoveCircularAbsolute by its EndPoint). A ReadActualPosition answers
//! both: the joints, and the pose in the tool and frame it reports back. Joints compare
//! directly; a pose only with a read in the same tool and frame (the tool or frame in use,
//! 255, only with a read that asks for the one in use too), its orientation only where the
//! move ends in the target's (not with OriMode FIX, which keeps the start's).

use std::fmt;

use shared_types::pose::rotation_from_rpy;
use shared_types::srci::payload::{Field, PayloadReader};
use shared_types::srci::tables;

use crate::request::Request;
use crate::response::ActualPosition;

/// ToolNo or FrameNo −1 on the wire (a USINT 255): the one in use.
const IN_USE: u8 = 255;

/// CircMode CENTER_WITH_ANGLE: the arc ends where its Angle says, not at the EndPoint.
const CENTER_WITH_ANGLE: u8 = 2;
/// OriMode FIX: the TCP keeps the start's orientation, whatever the target's.
const ORI_MODE_FIX: u8 = 3;

/// The absolute target of a move, as its request gives it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Target {
    /// J1..J6 in degrees.
    Joints([f64; 6]),
    /// X, Y, Z in mm and RX, RY, RZ in degrees of the tool `tool` in the frame `frame`
    /// (255: the one in use); `orientation`: whether the move ends in the pose's
    /// orientation.
    Pose {
        pose: [f64; 6],
        tool: u8,
        frame: u8,
        orientation: bool,
    },
}

/// How far a read-back position lies from a target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Deviation {
    /// The largest joint difference, in degrees.
    Joints { deg: f64 },
    /// The TCP's distance in mm and the angle (degrees) of the rotation between the two
    /// orientations.
    Pose { mm: f64, deg: f64 },
    /// The TCP's distance in mm, of a move that keeps its start orientation.
    Position { mm: f64 },
}

/// The largest deviations a move may end with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerance {
    /// Per joint, and for a pose's orientation (degrees).
    pub deg: f64,
    /// For a pose's position (mm).
    pub mm: f64,
}

impl Target {
    /// The absolute target of `request`; none for relative and offset moves, arcs given by
    /// centre and angle, jogs and everything that does not move the arm.
    pub fn of(request: &Request) -> Option<Self> {
        if let Request::MoveAxesAbsolute(m) = request {
            return Some(Self::Joints(m.joints_deg));
        }
        let mut bytes = Vec::new();
        request.encode(0, &mut bytes);
        let r = PayloadReader::new(&bytes);
        let values = |fields: [_; 6]| fields.map(|f| f64::from(r.f32(f)));
        match request.command_type() {
            tables::move_linear_absolute_j::TYPE => Some(Self::Joints(values(
                tables::move_linear_absolute_j::request::JOINT_POSITION_J1_J6,
            ))),
            tables::move_linear_absolute::TYPE => {
                use tables::move_linear_absolute::request as f;
                let fields = [f::TOOL_NO, f::FRAME_NO, f::ORI_MODE];
                Some(Self::pose(values(f::POSITION_X_RZ), &r, fields))
            }
            tables::move_direct_absolute::TYPE => {
                use tables::move_direct_absolute::request as f;
                Some(Self::Pose {
                    pose: values(f::POSITION_X_RZ),
                    tool: r.u8(f::TOOL_NO),
                    frame: r.u8(f::FRAME_NO),
                    orientation: true,
                })
            }
            tables::move_circular_absolute::TYPE => {
                use tables::move_circular_absolute::request as f;
                let fields = [f::TOOL_NO, f::FRAME_NO, f::ORI_MODE];
                (r.u8(f::CIRC_MODE) != CENTER_WITH_ANGLE)
                    .then(|| Self::pose(values(f::END_POINT_X_RZ), &r, fields))
            }
            _ => None,
        }
    }

    /// The pose target of a line or arc with its ToolNo, FrameNo and OriMode fields.
    fn pose(pose: [f64; 6], r: &PayloadReader<'_>, [tool, frame, ori_mode]: [Field; 3]) -> Self {
        Self::Pose {
            pose,
            tool: r.u8(tool),
            frame: r.u8(frame),
            orientation: r.u8(ori_mode) != ORI_MODE_FIX,
        }
    }

    /// How far `reached` (read in the tool and frame `asked`, 255 for the ones in use) lies
    /// from the target, or why the two cannot be compared: a pose read in another tool or
    /// frame than the move's.
    pub fn deviation(
        &self,
        reached: &ActualPosition,
        asked: (u8, u8),
    ) -> Result<Deviation, String> {
        match *self {
            Self::Joints(joints) => Ok(Deviation::Joints {
                deg: joints
                    .iter()
                    .zip(reached.joints_deg)
                    .map(|(t, r)| (t - r).abs())
                    .fold(0.0, f64::max),
            }),
            Self::Pose {
                pose,
                tool,
                frame,
                orientation,
            } => {
                // The one in use is known to be the same only where both asked for it.
                let same = |target: u8, asked: u8, read: u8| {
                    if target == IN_USE {
                        asked == IN_USE
                    } else {
                        target == read
                    }
                };
                if !same(tool, asked.0, reached.tool) || !same(frame, asked.1, reached.frame) {
                    return Err(format!(
                        "target in tool {tool} frame {frame}, read in tool {} frame {}: \
                         not compared",
                        reached.tool, reached.frame
                    ));
                }
                let r = reached.cartesian;
                let mm = (0..3).map(|i| (pose[i] - r[i]).powi(2)).sum::<f64>().sqrt();
                if !orientation {
                    return Ok(Deviation::Position { mm });
                }
                let rotation = |p: [f64; 6]| {
                    rotation_from_rpy(p[3].to_radians(), p[4].to_radians(), p[5].to_radians())
                };
                let deg = (rotation(pose).inverse() * rotation(r))
                    .angle()
                    .to_degrees();
                Ok(Deviation::Pose { mm, deg })
            }
        }
    }
}

impl Deviation {
    /// Whether the deviation is within `tolerance`.
    pub fn within(&self, tolerance: Tolerance) -> bool {
        match *self {
            Self::Joints { deg } => deg <= tolerance.deg,
            Self::Pose { mm, deg } => mm <= tolerance.mm && deg <= tolerance.deg,
            Self::Position { mm } => mm <= tolerance.mm,
        }
    }
}

/// Six joints or pose values as the report shows them, two decimals each.
pub(crate) fn six_values(v: &[f64; 6]) -> String {
    v.iter()
        .map(|x| format!("{x:.2}"))
        .collect::<Vec<_>>()
        .join(" ")
}

impl fmt::Display for Target {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Joints(j) => write!(f, "joints {}", six_values(j)),
            Self::Pose { pose, .. } => write!(f, "pose {}", six_values(pose)),
        }
    }
}

impl fmt::Display for Deviation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Joints { deg } => write!(f, "{deg:.3} deg"),
            Self::Pose { mm, deg } => write!(f, "{mm:.3} mm {deg:.3} deg"),
            Self::Position { mm } => write!(f, "{mm:.3} mm"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table_step;

    fn step(call: &str, keys: &str) -> Request {
        let table = table_step::find(call).unwrap();
        table_step::request(table, &toml::from_str(keys).unwrap()).unwrap()
    }

    fn read(cartesian: [f64; 6], joints_deg: [f64; 6], tool: u8, frame: u8) -> ActualPosition {
        ActualPosition {
            tool,
            frame,
            cartesian,
            joints_deg,
        }
    }

    #[test]
    fn absolute_moves_name_their_targets_and_relative_ones_none() {
        let pose = [-417.0, 215.0, 373.25, -180.0, 0.0, 90.0];
        let line = |ori_mode: u8| {
            step(
                "MoveLinearAbsolute",
                &format!(
                    "position = [-417.0, 215.0, 373.25, -180.0, 0.0, 90.0]\ntool_no = 2\n\
                     frame_no = 1\nori_mode = {ori_mode}"
                ),
            )
        };
        assert_eq!(
            Target::of(&line(1)),
            Some(Target::Pose {
                pose,
                tool: 2,
                frame: 1,
                orientation: true
            })
        );
        // FIX keeps the start's orientation: only the position is the target's.
        assert!(matches!(
            Target::of(&line(ORI_MODE_FIX)),
            Some(Target::Pose {
                orientation: false,
                ..
            })
        ));
        let joints = step(
            "MoveLinearAbsoluteJ",
            "joint_position = [0.0, 90.0, 90.0, 90.0, -90.0, 12.5]",
        );
        assert_eq!(
            Target::of(&joints),
            Some(Target::Joints([0.0, 90.0, 90.0, 90.0, -90.0, 12.5]))
        );
        let arc = |mode: u8| {
            step(
                "MoveCircularAbsolute",
                &format!(
                    "aux_point = [0.0, 0.0, 300.0, 180.0, 0.0, 0.0]\n\
                     end_point = [100.0, 0.0, 300.0, 180.0, 0.0, 0.0]\ncirc_mode = {mode}"
                ),
            )
        };
        assert!(matches!(
            Target::of(&arc(0)),
            Some(Target::Pose { pose, .. }) if pose[0] == 100.0
        ));
        assert_eq!(Target::of(&arc(CENTER_WITH_ANGLE)), None);
        let relative = step(
            "MoveLinearRelative",
            "distance = [0.0, 0.0, 50.0, 0.0, 0.0, 0.0]",
        );
        assert_eq!(Target::of(&relative), None);
        assert_eq!(Target::of(&Request::GroupStop), None);
    }

    /// RX 180° and RX −180° are the same orientation, and a turn of RZ by 0.1° about a
    /// tool pointing down is 0.1° whatever the angles look like.
    #[test]
    fn a_pose_deviates_by_its_distance_and_the_angle_between_the_orientations() {
        let target = Target::Pose {
            pose: [100.0, 0.0, 300.0, 180.0, 0.0, 90.0],
            tool: IN_USE,
            frame: 0,
            orientation: true,
        };
        let reached = read([100.03, 0.04, 300.0, -180.0, 0.0, 90.1], [0.0; 6], 3, 0);
        let d = target.deviation(&reached, (IN_USE, 0)).unwrap();
        let Deviation::Pose { mm, deg } = d else {
            panic!("{d:?}")
        };
        assert!((mm - 0.05).abs() < 1e-9, "{mm}");
        assert!((deg - 0.1).abs() < 1e-9, "{deg}");
        let tolerance = Tolerance { deg: 0.05, mm: 0.1 };
        assert!(!d.within(tolerance), "0.1 deg off");
        assert!(d.within(Tolerance {
            deg: 0.2,
            ..tolerance
        }));
        assert_eq!(d.to_string(), "0.050 mm 0.100 deg");
        let kept = Target::Pose {
            pose: [100.0, 0.0, 300.0, 180.0, 0.0, 90.0],
            tool: IN_USE,
            frame: 0,
            orientation: false,
        };
        assert_eq!(
            kept.deviation(&reached, (IN_USE, 0)).map(|d| d.to_string()),
            Ok("0.050 mm".to_owned())
        );
    }

    /// The tool in use (255) of a move is the same as a read's only where the read asked
    /// for the one in use too: a read in tool 0 says nothing of a move in tool 3 then.
    #[test]
    fn a_pose_read_in_another_tool_or_frame_is_not_compared() {
        let target = Target::Pose {
            pose: [0.0; 6],
            tool: 1,
            frame: 0,
            orientation: true,
        };
        let at = |tool| read([0.0; 6], [0.0; 6], tool, 0);
        let e = target.deviation(&at(0), (0, 0)).unwrap_err();
        assert_eq!(
            e,
            "target in tool 1 frame 0, read in tool 0 frame 0: not compared"
        );
        assert!(target.deviation(&at(1), (1, 0)).is_ok());
        assert!(target.deviation(&at(1), (IN_USE, 0)).is_ok());
        let in_use = Target::Pose {
            pose: [0.0; 6],
            tool: IN_USE,
            frame: 0,
            orientation: true,
        };
        assert!(in_use.deviation(&at(0), (0, 0)).is_err());
        assert!(in_use.deviation(&at(3), (IN_USE, 0)).is_ok());
    }

    #[test]
    fn joints_deviate_by_the_largest_difference() {
        let d = Target::Joints([0.0, 90.0, 90.0, 90.0, -90.0, 0.0])
            .deviation(
                &read([0.0; 6], [0.0, 90.5, 90.0, 90.0, -90.2, 0.0], 0, 0),
                (0, 0),
            )
            .unwrap();
        assert_eq!(d, Deviation::Joints { deg: 0.5 });
    }
}
