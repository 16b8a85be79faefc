//! The Cartesian path of the TCP of a MoveLinear or MoveCircular: position and orientation
//! for a path position `s` in [0, 1], with `s` proportional to the distance travelled.
//!
//! # Straight line (MoveLinear)
//!
//! `p(s) = p0 + s·(p1 − p0)`.
//!
//! # Arc (MoveCircular)
//!
//! `p(s) = c + s·h·n + Rot(n, s·θ)·u·(r0 + s·(r1 − r0))`: about the axis `n` through the
//! centre `c` by the sweep `θ > 0`, `u` the unit vector from `c` towards the start. A true
//! circle has `r1 = r0` and `h = 0`; the CENTER mode accepts an end up to the PLC's Tolerance
//! (`circle_tolerance_m`, 0 = [`TOLERANCE_M`]) off the circle, and the RADIUS mode an end up
//! to [`TOLERANCE_M`] off the plane of the arc; both close that gap evenly along the arc, so
//! the move ends exactly at the commanded end.
//!
//! CW and CCW are seen from the tip of the CircPlane normal `a` of the AuxPoint's
//! orientation (CircPlane XZ: its y axis, YZ: its x axis, XY: its z axis): CCW turns
//! positively about `a`, CW negatively. The AuxPoint's position is
//!
//! - BORDER: a point on the arc. The arc is the unique circle through the start, the aux
//!   point and the end, travelled from the start through the aux point to the end;
//!   CircPlane and PathChoice are not used. Three points on one line (a triangle height
//!   below [`COLLINEAR_M`], coincident points included) are refused.
//! - CENTER: the centre. Start and end must be equally far from it (within the
//!   tolerance). The arc lies in the plane of the centre, the start and the end, and
//!   PathChoice picks the way round; where that plane is not determined (the end on the line
//!   through the centre and the start: a half or a full circle) it is the CircPlane through
//!   the centre, and start and end must lie in it. An end at the start is a full circle.
//!   An arc plane seen nearly edge-on from `a` (`|n·a|` below [`MIN_SENSE`]) leaves CW and
//!   CCW undefined and is refused.
//! - CENTER_WITH_ANGLE: the centre. The start turns about the axis `a` through the centre
//!   by `circle_angle_rad`, positively for CCW and negatively for CW (a negative angle turns
//!   the other way), at most one full turn; the end follows from the angle and the EndPoint
//!   is not used at all: OriMode FIX keeps the start orientation, the other modes turn it
//!   with the arc (as PATH does towards the start orientation turned by the angle). The start
//!   must lie in the CircPlane through the centre.
//! - RADIUS: SRCI's AuxPoint is a vector, "the spearhead point of the perpendicular" of the
//!   circle's plane, its length the radius (the PLCopen MC_MoveCircular definition the
//!   CircMode text repeats). The command carries the radius in `circle_radius_m` and the
//!   vector as the offset of `aux_pose` from the end, so that relative moves turn it with
//!   their target. The arc turns positively about the vector (right thumb rule); of the two
//!   circles of that radius through the start and the end in the plane normal to it,
//!   PathChoice 0 takes the one on which the end comes after the shorter sector, 1 the
//!   longer one (as PLCopen's PathChoice FALSE and TRUE). CircPlane and the AuxPoint's
//!   orientation are not used. A radius below half the chord (within [`TOLERANCE_M`]) is
//!   refused; start and end must lie in one plane normal to the vector.
//!
//! # Orientation
//!
//! OriMode 0 and 1 interpolate from the start orientation `R0` to the target's `R1` on the
//! shortest rotation, `R(s) = exp(s·ω)·R0`; 3 FIX keeps `R0`. 4 PATH keeps the orientation's
//! attitude to the path's tangent ("no change of orientation in relation to the
//! trajectory") and still ends at the target's: on an arc the orientation turns with the arc
//! and what remains to the target is spread evenly: `R(s) = Rot(n, s·θ)·exp(s·ω')·R0` with
//! `ω'` the rotation vector of `Rot(n, θ)⁻¹·R1·R0⁻¹` (a target orientation equal to the
//! start's turned with the arc gives the pure turn); on a line the tangent does not turn, so
//! the whole difference is spread, as with 1. 2 JOINT_INTERPOLATED interpolates the wrist
//! joints, not the orientation ([`wrist_interpolation`](crate::wrist_interpolation)): the
//! path here carries the orientation of 1 as a reference (on a CENTER_WITH_ANGLE arc the one
//! turning with the arc, its EndPoint having no orientation), and the orientation the joints
//! give meets it at both ends.

use core::f64::consts::{FRAC_PI_2, TAU};

use nalgebra::{Isometry3, Translation3, Unit, UnitQuaternion, Vector3};
use shared_types::ipc::{MotionCommand, MotionCommandKind, TargetReference};
use shared_types::pose;
use shared_types::srci::message::code;

/// How far (m) the end of a CENTER arc may lie off the circle the start gives where the PLC
/// leaves Tolerance at 0, the end of a RADIUS arc off the plane normal to its vector, and the
/// start of a CENTER_WITH_ANGLE arc off the CircPlane through the centre.
pub const TOLERANCE_M: f64 = 1e-3;
/// Smallest height (m) of the triangle of a BORDER arc's points, and smallest radius and
/// chord of an arc.
pub const COLLINEAR_M: f64 = 1e-4;
/// Smallest `|n·a|` between the normal of a CENTER arc's plane and the CircPlane normal
/// for CW and CCW to be told apart (the planes within about 84°).
pub const MIN_SENSE: f64 = 0.1;
/// Shortest line (m) counted as a translation.
pub(crate) const ZERO_LENGTH_M: f64 = 1e-9;
/// Smallest rotation (rad) counted as a reorientation or an arc.
const ZERO_ANGLE_RAD: f64 = 1e-9;

/// Why a command gives no Cartesian path; [`code`](Self::code) is the SRCI message code.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum PathError {
    #[error("command kind {0} has no Cartesian path")]
    NotAPath(u8),
    #[error("OriMode {0} is not supported for this move")]
    OriModeNotSupported(u8),
    #[error("OriMode {0} is not defined")]
    InvalidOriMode(u8),
    #[error("CircMode {0} is not defined")]
    InvalidCircMode(u8),
    #[error("CircPlane {0} is not defined")]
    InvalidCircPlane(u8),
    #[error("PathChoice {0} is not defined")]
    InvalidPathChoice(u8),
    #[error("the target is relative: resolve it first (targets::absolute)")]
    RelativeTarget,
    #[error("the aux point, the angle, the radius or the tolerance is not finite")]
    NotFinite,
    #[error("the tolerance {0} m is negative")]
    InvalidTolerance(f64),
    #[error("the start, the aux point and the end lie on one line")]
    Collinear,
    #[error("the start lies on the centre")]
    StartOnCentre,
    #[error("start and end lie {difference} m apart in their distance from the centre")]
    UnequalRadii { difference: f64 },
    #[error("a point lies {distance} m off the circle plane")]
    OffPlane { distance: f64 },
    #[error("the arc's plane is seen edge-on from the CircPlane: CW and CCW are undefined")]
    EdgeOn,
    #[error("start and end coincide: no circle of a given radius is defined")]
    Coincident,
    #[error("the radius {radius} m is zero or below half the chord {chord} m")]
    RadiusTooSmall { radius: f64, chord: f64 },
    #[error("the angle {0} rad is zero or more than a full turn")]
    InvalidAngle(f64),
}

impl PathError {
    /// The SRCI message code reported for this error.
    pub fn code(&self) -> u16 {
        match self {
            Self::NotAPath(_) | Self::RelativeTarget => code::INTERNAL_ERROR,
            Self::OriModeNotSupported(_) => code::ORI_MODE_NOT_SUPPORTED,
            Self::InvalidOriMode(_) => code::INVALID_ORI_MODE,
            Self::InvalidCircMode(_) | Self::InvalidCircPlane(_) | Self::InvalidPathChoice(_) => {
                code::INVALID_MODE
            }
            Self::InvalidTolerance(_) => code::TOLERANCE_ONLY_CENTER,
            Self::NotFinite
            | Self::Collinear
            | Self::StartOnCentre
            | Self::UnequalRadii { .. }
            | Self::OffPlane { .. }
            | Self::EdgeOn
            | Self::Coincident
            | Self::RadiusTooSmall { .. }
            | Self::InvalidAngle(_) => code::INVALID_POSITION,
        }
    }
}

/// Whether `command` moves the TCP on a Cartesian path (MoveLinear, MoveCircular).
pub fn is_cartesian(command: &MotionCommand) -> bool {
    matches!(
        MotionCommandKind::from_wire(command.kind),
        Some(MotionCommandKind::MoveLinear | MotionCommandKind::MoveCircular)
    )
}

/// How the orientation moves along the path (SRCI OriMode).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OriMode {
    /// 0 (standard) and 1 LINEAR_INTERPOLATED: slerp on the shortest rotation to the target.
    Interpolated,
    /// 2 JOINT_INTERPOLATED: the wrist joints move linearly to the target's.
    JointInterpolated,
    /// 3 FIX: the start orientation all the way.
    Fix,
    /// 4 PATH: keeps its attitude to the tangent (on a line: the start orientation).
    Path,
}

impl OriMode {
    /// The mode of a wire value.
    pub fn from_wire(value: u8) -> Result<Self, PathError> {
        match value {
            0 | 1 => Ok(Self::Interpolated),
            2 => Ok(Self::JointInterpolated),
            3 => Ok(Self::Fix),
            4 => Ok(Self::Path),
            _ => Err(PathError::InvalidOriMode(value)),
        }
    }
}

/// How the AuxPoint defines an arc (SRCI CircMode).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CircMode {
    /// 0: the aux point lies on the arc.
    Border,
    /// 1: the aux point is the centre.
    Center,
    /// 2: the aux point is the centre, the angle gives the end.
    CenterWithAngle,
    /// 3: the radius gives the circle.
    Radius,
}

impl CircMode {
    /// The mode of a wire value.
    pub fn from_wire(value: u8) -> Result<Self, PathError> {
        match value {
            0 => Ok(Self::Border),
            1 => Ok(Self::Center),
            2 => Ok(Self::CenterWithAngle),
            3 => Ok(Self::Radius),
            _ => Err(PathError::InvalidCircMode(value)),
        }
    }
}

/// The plane of the AuxPoint's frame an arc lies in (SRCI CircPlane).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CircPlane {
    Xz,
    Yz,
    Xy,
}

impl CircPlane {
    /// The plane of a wire value (0 XZ, 1 YZ, 2 XY).
    pub fn from_wire(value: u8) -> Result<Self, PathError> {
        match value {
            0 => Ok(Self::Xz),
            1 => Ok(Self::Yz),
            2 => Ok(Self::Xy),
            _ => Err(PathError::InvalidCircPlane(value)),
        }
    }

    /// The plane's normal in the base frame, for a frame of orientation `rotation`.
    pub fn normal(self, rotation: &UnitQuaternion<f64>) -> Unit<Vector3<f64>> {
        let local = match self {
            Self::Xz => Vector3::y_axis(),
            Self::Yz => Vector3::x_axis(),
            Self::Xy => Vector3::z_axis(),
        };
        rotation * local
    }
}

/// Which way round an arc goes, seen from the tip of the CircPlane normal (SRCI PathChoice).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PathChoice {
    Clockwise,
    CounterClockwise,
}

impl PathChoice {
    /// The choice of a wire value (0 CW, 1 CCW).
    pub fn from_wire(value: u8) -> Result<Self, PathError> {
        match value {
            0 => Ok(Self::Clockwise),
            1 => Ok(Self::CounterClockwise),
            _ => Err(PathError::InvalidPathChoice(value)),
        }
    }

    /// +1 for CCW, −1 for CW: the sense of the turn about the plane normal.
    fn sign(self) -> f64 {
        match self {
            Self::Clockwise => -1.0,
            Self::CounterClockwise => 1.0,
        }
    }
}

/// The parameters of an arc as sent, decoded.
#[derive(Debug, Clone, Copy, PartialEq)]
struct ArcRequest {
    mode: CircMode,
    plane: CircPlane,
    choice: PathChoice,
}

/// What a path command asks for independently of where the arm is.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Request {
    ori_mode: OriMode,
    /// `None` for a straight line.
    arc: Option<ArcRequest>,
}

/// Checks what a MoveLinear or MoveCircular asks for independently of where the arm is:
/// the kind, an absolute target, the OriMode and for an arc its modes and finite values.
pub fn validate(command: &MotionCommand) -> Result<(), PathError> {
    request(command).map(|_| ())
}

fn request(command: &MotionCommand) -> Result<Request, PathError> {
    let circular = match MotionCommandKind::from_wire(command.kind) {
        Some(MotionCommandKind::MoveLinear) => false,
        Some(MotionCommandKind::MoveCircular) => true,
        _ => return Err(PathError::NotAPath(command.kind)),
    };
    if TargetReference::from_wire(command.target_reference) != Some(TargetReference::Absolute) {
        return Err(PathError::RelativeTarget);
    }
    let ori_mode = OriMode::from_wire(command.ori_mode)?;
    if !circular {
        return Ok(Request {
            ori_mode,
            arc: None,
        });
    }
    let finite = command
        .aux_pose
        .iter()
        .chain([
            &command.circle_angle_rad,
            &command.circle_radius_m,
            &command.circle_tolerance_m,
        ])
        .all(|v| v.is_finite());
    if !finite {
        return Err(PathError::NotFinite);
    }
    if command.circle_tolerance_m < 0.0 {
        return Err(PathError::InvalidTolerance(command.circle_tolerance_m));
    }
    Ok(Request {
        ori_mode,
        arc: Some(ArcRequest {
            mode: CircMode::from_wire(command.circle_mode)?,
            plane: CircPlane::from_wire(command.circle_plane)?,
            choice: PathChoice::from_wire(command.path_choice)?,
        }),
    })
}

/// The orientation interpolated on a rotation vector: `exp(s·rotation)·start`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Reorientation {
    start: UnitQuaternion<f64>,
    /// Rotation vector (base frame) of the whole interpolated part.
    rotation: Vector3<f64>,
}

impl Reorientation {
    /// From `start` to `target` on the shortest rotation.
    fn between(start: UnitQuaternion<f64>, target: &UnitQuaternion<f64>) -> Self {
        Self {
            start,
            rotation: (target * start.inverse()).scaled_axis(),
        }
    }

    fn at(&self, s: f64) -> UnitQuaternion<f64> {
        UnitQuaternion::from_scaled_axis(self.rotation * s) * self.start
    }
}

/// A straight line of the TCP.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    start: Vector3<f64>,
    travel: Vector3<f64>,
    orientation: Reorientation,
}

/// A circle (or, within the tolerances, a flat spiral or helix) through which the arc runs.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Circle {
    /// On the axis, in the plane of the start.
    centre: Vector3<f64>,
    /// The arc turns positively about it.
    axis: Unit<Vector3<f64>>,
    /// From the centre towards the start.
    radial: Unit<Vector3<f64>>,
    /// Angle travelled (rad), > 0.
    sweep: f64,
    /// Distance from the axis at the start and at the end (m).
    radii: [f64; 2],
    /// Offset of the end along the axis (m).
    rise: f64,
}

impl Circle {
    fn position(&self, s: f64) -> Vector3<f64> {
        let turn = UnitQuaternion::from_axis_angle(&self.axis, s * self.sweep);
        let radius = self.radii[0] + s * (self.radii[1] - self.radii[0]);
        self.centre
            + self.axis.into_inner() * (s * self.rise)
            + turn * self.radial.into_inner() * radius
    }

    /// The arc length: `∫ √(θ²·r(s)² + k²) ds` with `r` linear in `s` and
    /// `k² = (r1 − r0)² + h²`, in closed form.
    fn length(&self) -> f64 {
        let [r0, r1] = self.radii;
        let theta = self.sweep;
        let dr = r1 - r0;
        let k2 = dr * dr + self.rise * self.rise;
        if dr.abs() < 1e-12 {
            return (theta * theta * r0 * r0 + k2).sqrt();
        }
        let k = k2.sqrt();
        let antiderivative = |x: f64| {
            let root = (theta * theta * x * x + k2).sqrt();
            0.5 * x * root + k2 / (2.0 * theta) * (theta * x / k).asinh()
        };
        (antiderivative(r1) - antiderivative(r0)) / dr
    }

    /// The circle about the axis `axis` through `centre` from `start` to `end`, the
    /// sweep the angle from one to the other about it in [0, 2π).
    fn about(
        centre: &Vector3<f64>,
        axis: Unit<Vector3<f64>>,
        start: &Vector3<f64>,
        end: &Vector3<f64>,
    ) -> Self {
        let a = axis.into_inner();
        let (u0, u1) = (start - centre, end - centre);
        let (h0, h1) = (u0.dot(&a), u1.dot(&a));
        let (p0, p1) = (u0 - a * h0, u1 - a * h1);
        let sweep = a.dot(&p0.cross(&p1)).atan2(p0.dot(&p1)).rem_euclid(TAU);
        Self {
            centre: centre + a * h0,
            axis,
            radial: Unit::new_normalize(p0),
            sweep,
            radii: [p0.norm(), p1.norm()],
            rise: h1 - h0,
        }
    }

    /// BORDER: through `start`, `aux` and `end` in this order.
    fn border(
        start: &Vector3<f64>,
        aux: &Vector3<f64>,
        end: &Vector3<f64>,
    ) -> Result<Self, PathError> {
        let (a, b) = (aux - start, end - start);
        let normal = a.cross(&b);
        let longest = a.norm().max(b.norm()).max((end - aux).norm());
        // Twice the area over the longest side: the smallest height of the triangle.
        if longest <= 0.0 || normal.norm() / longest < COLLINEAR_M {
            return Err(PathError::Collinear);
        }
        let centre = start
            + (b.cross(&normal) * a.norm_squared() + normal.cross(&a) * b.norm_squared())
                / (2.0 * normal.norm_squared());
        // The triangle start → aux → end turns positively about its normal, so does the arc.
        Ok(Self::about(
            &centre,
            Unit::new_normalize(normal),
            start,
            end,
        ))
    }

    /// CENTER: about `centre` from `start` to `end`, the way round `choice` seen from
    /// `plane_normal`, the end up to `tolerance` (m) off the circle.
    fn center(
        start: &Vector3<f64>,
        centre: &Vector3<f64>,
        end: &Vector3<f64>,
        plane_normal: Unit<Vector3<f64>>,
        choice: PathChoice,
        tolerance: f64,
    ) -> Result<Self, PathError> {
        let (u0, u1) = (start - centre, end - centre);
        let (r0, r1) = (u0.norm(), u1.norm());
        if r0 < COLLINEAR_M {
            return Err(PathError::StartOnCentre);
        }
        if (r0 - r1).abs() > tolerance {
            return Err(PathError::UnequalRadii {
                difference: (r0 - r1).abs(),
            });
        }
        let normal = u0.cross(&u1);
        if normal.norm() / r0 >= COLLINEAR_M {
            let normal = Unit::new_normalize(normal);
            let sense = normal.dot(&plane_normal);
            if sense.abs() < MIN_SENSE {
                return Err(PathError::EdgeOn);
            }
            // `normal` turns the short way round; CW or CCW may ask for the long way.
            let axis = if sense * choice.sign() > 0.0 {
                normal
            } else {
                -normal
            };
            return Ok(Self::about(centre, axis, start, end));
        }
        // A half or a full circle: the plane is the CircPlane.
        let a = plane_normal.into_inner();
        for u in [u0, u1] {
            height_over_plane(&u, &a)?;
        }
        let axis = Unit::new_unchecked(a * choice.sign());
        let mut circle = Self::about(centre, axis, start, end);
        if circle.sweep < FRAC_PI_2 {
            // The end at (or just past) the start: once round.
            circle.sweep += TAU;
        }
        Ok(circle)
    }

    /// CENTER_WITH_ANGLE: `start` turned about `plane_normal` through `centre` by `angle`
    /// (the sign of `choice` on top).
    fn center_with_angle(
        start: &Vector3<f64>,
        centre: &Vector3<f64>,
        plane_normal: Unit<Vector3<f64>>,
        choice: PathChoice,
        angle: f64,
    ) -> Result<Self, PathError> {
        if angle.abs() <= ZERO_ANGLE_RAD || angle.abs() > TAU + ZERO_ANGLE_RAD {
            return Err(PathError::InvalidAngle(angle));
        }
        let a = plane_normal.into_inner();
        let u0 = start - centre;
        let height = height_over_plane(&u0, &a)?;
        let radial = u0 - a * height;
        if radial.norm() < COLLINEAR_M {
            return Err(PathError::StartOnCentre);
        }
        let signed = angle * choice.sign();
        Ok(Self {
            centre: centre + a * height,
            axis: Unit::new_unchecked(a * signed.signum()),
            radial: Unit::new_normalize(radial),
            sweep: signed.abs(),
            radii: [radial.norm(); 2],
            rise: 0.0,
        })
    }

    /// RADIUS: of `radius` in the plane through `start` and `end` normal to `normal`,
    /// turning positively about `normal`; the arc on which the end comes after the longer
    /// sector if `longer`, else the shorter one.
    fn radius(
        start: &Vector3<f64>,
        end: &Vector3<f64>,
        normal: &Vector3<f64>,
        longer: bool,
        radius: f64,
    ) -> Result<Self, PathError> {
        let d = end - start;
        if d.norm() < COLLINEAR_M {
            return Err(PathError::Coincident);
        }
        if radius < COLLINEAR_M || normal.norm() < COLLINEAR_M {
            return Err(PathError::RadiusTooSmall {
                radius,
                chord: d.norm(),
            });
        }
        let a = Unit::new_normalize(*normal);
        let rise = height_over_plane(&d, &a)?;
        let chord = d - a.into_inner() * rise;
        let c = chord.norm();
        if c < COLLINEAR_M {
            return Err(PathError::Coincident);
        }
        if radius < 0.5 * c - TOLERANCE_M {
            return Err(PathError::RadiusTooSmall { radius, chord: c });
        }
        let half = (radius * radius - 0.25 * c * c).max(0.0).sqrt();
        // Seen from the tip of `a`, the centre of the short CCW arc lies left of the chord.
        let left = a.cross(&chord) / c;
        let side = if longer { -1.0 } else { 1.0 };
        let centre = start + chord * 0.5 + left * (half * side);
        Ok(Self::about(&centre, a, start, end))
    }
}

/// The height of `offset` over a plane of normal `normal`, refused beyond [`TOLERANCE_M`].
fn height_over_plane(offset: &Vector3<f64>, normal: &Vector3<f64>) -> Result<f64, PathError> {
    let height = offset.dot(normal);
    if height.abs() > TOLERANCE_M {
        return Err(PathError::OffPlane {
            distance: height.abs(),
        });
    }
    Ok(height)
}

/// An arc of the TCP.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Arc {
    circle: Circle,
    orientation: Reorientation,
    /// OriMode PATH: the orientation turns with the arc on top of `orientation`.
    turns_with_path: bool,
}

/// The Cartesian path of the TCP: a straight line or an arc, with the orientation along it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CartesianPath {
    Line(Segment),
    Arc(Arc),
}

impl CartesianPath {
    /// The path of a MoveLinear or MoveCircular `command` from the TCP pose `start`.
    pub fn new(command: &MotionCommand, start: &Isometry3<f64>) -> Result<Self, PathError> {
        let request = request(command)?;
        let target = pose::isometry(command.pose);
        let p0 = start.translation.vector;
        let r0 = start.rotation;
        let Some(arc) = request.arc else {
            // The tangent of a line does not turn, so PATH spreads the whole difference to
            // the target's orientation, as on an arc what is left after the arc's turn.
            let target_rotation = match request.ori_mode {
                OriMode::Fix => r0,
                OriMode::Interpolated | OriMode::JointInterpolated | OriMode::Path => {
                    target.rotation
                }
            };
            return Ok(Self::Line(Segment {
                start: p0,
                travel: target.translation.vector - p0,
                orientation: Reorientation::between(r0, &target_rotation),
            }));
        };
        let aux = pose::isometry(command.aux_pose);
        let centre = aux.translation.vector;
        let end = target.translation.vector;
        let normal = arc.plane.normal(&aux.rotation);
        let circle = match arc.mode {
            CircMode::Border => Circle::border(&p0, &centre, &end)?,
            CircMode::Center => {
                let tolerance = if command.circle_tolerance_m > 0.0 {
                    command.circle_tolerance_m
                } else {
                    TOLERANCE_M
                };
                Circle::center(&p0, &centre, &end, normal, arc.choice, tolerance)?
            }
            CircMode::CenterWithAngle => Circle::center_with_angle(
                &p0,
                &centre,
                normal,
                arc.choice,
                command.circle_angle_rad,
            )?,
            CircMode::Radius => Circle::radius(
                &p0,
                &end,
                &(centre - end),
                // PLCopen's PathChoice TRUE (here CCW, 1): the longer sector.
                arc.choice == PathChoice::CounterClockwise,
                command.circle_radius_m,
            )?,
        };
        let by_angle = arc.mode == CircMode::CenterWithAngle;
        let (orientation, turns_with_path) = match request.ori_mode {
            OriMode::Fix => (Reorientation::between(r0, &r0), false),
            // The EndPoint is not used: its orientation may be anything.
            // (JOINT_INTERPOLATED ends at the joints of this reference orientation.)
            OriMode::Interpolated | OriMode::JointInterpolated | OriMode::Path if by_angle => {
                (Reorientation::between(r0, &r0), true)
            }
            OriMode::Interpolated | OriMode::JointInterpolated => {
                (Reorientation::between(r0, &target.rotation), false)
            }
            OriMode::Path => {
                let turn = UnitQuaternion::from_axis_angle(&circle.axis, circle.sweep);
                let rest = turn.inverse() * target.rotation;
                (Reorientation::between(r0, &rest), true)
            }
        };
        Ok(Self::Arc(Arc {
            circle,
            orientation,
            turns_with_path,
        }))
    }

    /// The TCP pose at path position `s` in [0, 1] (base frame).
    pub fn tcp(&self, s: f64) -> Isometry3<f64> {
        let (position, rotation) = match self {
            Self::Line(line) => (line.start + line.travel * s, line.orientation.at(s)),
            Self::Arc(arc) => {
                let mut rotation = arc.orientation.at(s);
                if arc.turns_with_path {
                    let circle = &arc.circle;
                    rotation =
                        UnitQuaternion::from_axis_angle(&circle.axis, s * circle.sweep) * rotation;
                }
                (arc.circle.position(s), rotation)
            }
        };
        Isometry3::from_parts(Translation3::from(position), rotation)
    }

    /// The length (m) of the TCP's path.
    pub fn length(&self) -> f64 {
        match self {
            Self::Line(line) => line.travel.norm(),
            Self::Arc(arc) => arc.circle.length(),
        }
    }

    /// Whether the TCP does not move: a line of no length without a reorientation. An arc
    /// always moves.
    pub fn is_stationary(&self) -> bool {
        match self {
            Self::Line(line) => {
                line.travel.norm() <= ZERO_LENGTH_M
                    && line.orientation.rotation.norm() <= ZERO_ANGLE_RAD
            }
            Self::Arc(_) => false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::PI;
    use proptest::prelude::*;

    /// The start TCP of the tests: at (0.4, 0.1, 0.3), turned a little.
    fn start() -> Isometry3<f64> {
        pose::isometry([0.4, 0.1, 0.3, 0.2, -0.1, 0.3])
    }

    fn circular(mode: u8, aux: [f64; 3], end: [f64; 3]) -> MotionCommand {
        let mut c = MotionCommand::new(MotionCommandKind::MoveCircular);
        c.circle_mode = mode;
        // The base XY plane, CCW seen from above, unless a test says otherwise.
        c.circle_plane = 2;
        c.path_choice = 1;
        c.aux_pose = [aux[0], aux[1], aux[2], 0.0, 0.0, 0.0];
        let rotation = pose::pose(&start());
        c.pose = [
            end[0],
            end[1],
            end[2],
            rotation[3],
            rotation[4],
            rotation[5],
        ];
        c
    }

    /// Why the path of `c` from [`start`] is refused.
    fn refused(c: &MotionCommand) -> PathError {
        CartesianPath::new(c, &start()).unwrap_err()
    }

    fn position(path: &CartesianPath, s: f64) -> Vector3<f64> {
        path.tcp(s).translation.vector
    }

    fn arc_of(path: &CartesianPath) -> &Arc {
        match path {
            CartesianPath::Arc(arc) => arc,
            CartesianPath::Line(_) => panic!("a line"),
        }
    }

    /// Asserts that every sample lies `radius` from `centre` in the plane through it normal
    /// to `normal`.
    fn assert_on_circle(
        path: &CartesianPath,
        centre: Vector3<f64>,
        normal: Vector3<f64>,
        radius: f64,
    ) {
        for k in 0..=100 {
            let p = position(path, k as f64 / 100.0) - centre;
            assert!(
                (p.norm() - radius).abs() < 1e-9,
                "{} m from the centre",
                p.norm()
            );
            assert!(p.dot(&normal.normalize()).abs() < 1e-9, "off the plane");
        }
    }

    fn v(x: f64, y: f64, z: f64) -> Vector3<f64> {
        Vector3::new(x, y, z)
    }

    /// The start (0.4, 0.1, 0.3) on a circle of radius 0.1 about (0.3, 0.1, 0.3) in the
    /// base XY plane.
    const CENTRE: [f64; 3] = [0.3, 0.1, 0.3];

    #[test]
    fn border_goes_through_the_aux_point_from_start_to_end() {
        // A quarter via 45°, the end at 90° CCW seen from +z.
        let aux = [
            0.3 + 0.1 * (PI / 4.0).cos(),
            0.1 + 0.1 * (PI / 4.0).sin(),
            0.3,
        ];
        let c = circular(0, aux, [0.3, 0.2, 0.3]);
        let path = CartesianPath::new(&c, &start()).unwrap();
        assert_on_circle(&path, Vector3::from(CENTRE), Vector3::z(), 0.1);
        assert!((position(&path, 0.0) - start().translation.vector).norm() < 1e-12);
        assert!((position(&path, 1.0) - v(0.3, 0.2, 0.3)).norm() < 1e-12);
        assert!((position(&path, 0.5) - Vector3::from(aux)).norm() < 1e-12);
        assert!((path.length() - 0.1 * PI / 2.0).abs() < 1e-12);
        // Via the aux point on the far side: three quarters the other way round.
        let c = circular(0, [0.3, 0.0, 0.3], [0.3, 0.2, 0.3]);
        let path = CartesianPath::new(&c, &start()).unwrap();
        assert_on_circle(&path, Vector3::from(CENTRE), Vector3::z(), 0.1);
        assert!((path.length() - 0.1 * 1.5 * PI).abs() < 1e-12);
        assert!((position(&path, 1.0 / 3.0) - v(0.3, 0.0, 0.3)).norm() < 1e-12);
    }

    #[test]
    fn border_refuses_points_on_one_line() {
        let p0 = start().translation.vector;
        for (aux, end) in [
            // On the line between start and end, beyond the end, at the start, at the end.
            ([0.45, 0.1, 0.3], [0.5, 0.1, 0.3]),
            ([0.6, 0.1, 0.3], [0.5, 0.1, 0.3]),
            ([p0.x, p0.y, p0.z], [0.5, 0.2, 0.3]),
            ([0.5, 0.2, 0.3], [0.5, 0.2, 0.3]),
            // Start and end coincide.
            ([0.3, 0.2, 0.3], [p0.x, p0.y, p0.z]),
            // 50 µm off the line.
            ([0.45, 0.10005, 0.3], [0.5, 0.1, 0.3]),
        ] {
            let c = circular(0, aux, end);
            let e = CartesianPath::new(&c, &start()).unwrap_err();
            assert_eq!(e, PathError::Collinear, "{aux:?} {end:?}");
            assert_eq!(e.code(), code::INVALID_POSITION);
        }
    }

    #[test]
    fn center_goes_the_way_path_choice_says() {
        // XY plane (z up): CCW from 0° to 90° is a quarter, CW three quarters.
        let mut c = circular(1, CENTRE, [0.3, 0.2, 0.3]);
        let ccw = CartesianPath::new(&c, &start()).unwrap();
        assert_on_circle(&ccw, Vector3::from(CENTRE), Vector3::z(), 0.1);
        assert!((ccw.length() - 0.1 * PI / 2.0).abs() < 1e-12);
        assert!(position(&ccw, 0.5).y > 0.1);
        c.path_choice = 0;
        let cw = CartesianPath::new(&c, &start()).unwrap();
        assert_on_circle(&cw, Vector3::from(CENTRE), Vector3::z(), 0.1);
        assert!((cw.length() - 0.1 * 1.5 * PI).abs() < 1e-12);
        assert!(position(&cw, 1.0 / 3.0).y < 0.1 - 0.09);
        assert!((position(&cw, 1.0) - v(0.3, 0.2, 0.3)).norm() < 1e-12);
        // Seen from below (the aux frame turned upside down) CW and CCW swap.
        c.aux_pose[3] = PI;
        let flipped = CartesianPath::new(&c, &start()).unwrap();
        assert!((flipped.length() - 0.1 * PI / 2.0).abs() < 1e-12);
    }

    #[test]
    fn center_with_the_end_at_the_start_is_a_full_circle() {
        let p0 = start().translation.vector;
        let mut c = circular(1, CENTRE, [p0.x, p0.y, p0.z]);
        for choice in [0, 1] {
            c.path_choice = choice;
            let path = CartesianPath::new(&c, &start()).unwrap();
            assert_on_circle(&path, Vector3::from(CENTRE), Vector3::z(), 0.1);
            assert!((path.length() - 0.1 * TAU).abs() < 1e-12);
            let quarter = position(&path, 0.25);
            let expected = if choice == 1 { 0.2 } else { 0.0 };
            assert!((quarter.y - expected).abs() < 1e-12, "{quarter:?}");
        }
        // An end a few µm past the start (rounded on the wire) is still once round.
        c.pose[1] += 5e-6;
        c.path_choice = 1;
        let path = CartesianPath::new(&c, &start()).unwrap();
        assert!((path.length() - 0.1 * TAU).abs() < 1e-4);
        assert!((position(&path, 1.0) - v(p0.x, p0.y + 5e-6, p0.z)).norm() < 1e-12);
    }

    #[test]
    fn center_half_circle_lies_in_the_circ_plane() {
        // From (0.4, 0.1, 0.3) to (0.2, 0.1, 0.3), opposite the start: the points leave the
        // plane open, the CircPlane decides.
        let mut c = circular(1, CENTRE, [0.2, 0.1, 0.3]);
        c.circle_plane = 0;
        c.path_choice = 1;
        let xz = CartesianPath::new(&c, &start()).unwrap();
        assert_on_circle(&xz, Vector3::from(CENTRE), Vector3::y(), 0.1);
        // CCW about +y turns +x towards −z.
        assert!((position(&xz, 0.5) - v(0.3, 0.1, 0.2)).norm() < 1e-12);
        c.circle_plane = 2;
        let xy = CartesianPath::new(&c, &start()).unwrap();
        assert!((position(&xy, 0.5) - v(0.3, 0.2, 0.3)).norm() < 1e-12);
        // The YZ plane does not hold them.
        c.circle_plane = 1;
        assert!(matches!(refused(&c), PathError::OffPlane { .. }));
    }

    #[test]
    fn center_refuses_what_is_no_arc_about_it() {
        // End 2 mm farther from the centre than the start.
        let mut c = circular(1, CENTRE, [0.3, 0.202, 0.3]);
        assert!(matches!(refused(&c), PathError::UnequalRadii { .. }));
        // Within the tolerance the arc ends exactly at the end.
        c.pose[1] = 0.2005;
        let path = CartesianPath::new(&c, &start()).unwrap();
        assert!((position(&path, 1.0) - v(0.3, 0.2005, 0.3)).norm() < 1e-12);
        // The PLC's Tolerance instead of the default: 0.4 mm refuses it, 3 mm takes 2 mm.
        c.circle_tolerance_m = 4e-4;
        assert!(matches!(refused(&c), PathError::UnequalRadii { .. }));
        c.pose[1] = 0.202;
        c.circle_tolerance_m = 3e-3;
        let path = CartesianPath::new(&c, &start()).unwrap();
        assert!((position(&path, 1.0) - v(0.3, 0.202, 0.3)).norm() < 1e-12);
        // The start on the centre.
        let p0 = start().translation.vector;
        let c = circular(1, [p0.x, p0.y, p0.z], [0.3, 0.2, 0.3]);
        assert_eq!(refused(&c), PathError::StartOnCentre);
        // An arc in the base YZ plane seen edge-on from the XY plane.
        let mut c = circular(1, [0.4, 0.0, 0.3], [0.4, 0.0, 0.4]);
        assert_eq!(refused(&c), PathError::EdgeOn);
        assert_eq!(refused(&c).code(), code::INVALID_POSITION);
        c.circle_plane = 1;
        assert!(CartesianPath::new(&c, &start()).is_ok());
    }

    #[test]
    fn center_with_angle_turns_the_start_by_the_angle() {
        let mut c = circular(2, CENTRE, [9.0, 9.0, 9.0]);
        c.circle_angle_rad = PI / 2.0;
        c.path_choice = 1;
        // The EndPoint's orientation is not used either.
        c.pose[3..].copy_from_slice(&[1.0, -2.0, 0.5]);
        let ccw = CartesianPath::new(&c, &start()).unwrap();
        assert_on_circle(&ccw, Vector3::from(CENTRE), Vector3::z(), 0.1);
        assert!((position(&ccw, 1.0) - v(0.3, 0.2, 0.3)).norm() < 1e-12);
        let turned =
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), PI / 2.0) * start().rotation;
        assert!(ccw.tcp(1.0).rotation.angle_to(&turned) < 1e-12);
        c.ori_mode = 3;
        let fixed = CartesianPath::new(&c, &start()).unwrap();
        assert!(fixed.tcp(1.0).rotation.angle_to(&start().rotation) < 1e-12);
        c.ori_mode = 0;
        c.path_choice = 0;
        let cw = CartesianPath::new(&c, &start()).unwrap();
        assert!((position(&cw, 1.0) - v(0.3, 0.0, 0.3)).norm() < 1e-12);
        // A negative angle turns the other way.
        c.circle_angle_rad = -PI / 2.0;
        let back = CartesianPath::new(&c, &start()).unwrap();
        assert!((position(&back, 1.0) - v(0.3, 0.2, 0.3)).norm() < 1e-12);
        // A full turn.
        c.circle_angle_rad = TAU;
        let full = CartesianPath::new(&c, &start()).unwrap();
        assert!((full.length() - 0.1 * TAU).abs() < 1e-12);
        for angle in [0.0, 1e-12, TAU + 0.1, -7.0] {
            c.circle_angle_rad = angle;
            assert_eq!(
                CartesianPath::new(&c, &start()),
                Err(PathError::InvalidAngle(angle))
            );
        }
        c.circle_angle_rad = f64::NAN;
        assert_eq!(validate(&c), Err(PathError::NotFinite));
        // The start must lie in the CircPlane through the centre.
        c.circle_angle_rad = 1.0;
        c.circle_plane = 1;
        assert!(matches!(refused(&c), PathError::OffPlane { .. }));
    }

    /// A RADIUS arc from the start to `end` about the normal `normal` (its length the
    /// radius): the AuxPoint as the planner gets it, the end displaced by the vector.
    fn radius_arc(end: [f64; 3], normal: Vector3<f64>, longer: bool) -> MotionCommand {
        let aux = Vector3::from(end) + normal;
        let mut c = circular(3, aux.into(), end);
        c.circle_radius_m = normal.norm();
        c.path_choice = u8::from(longer);
        // Neither the CircPlane nor the AuxPoint's orientation counts.
        c.circle_plane = 1;
        c.aux_pose[3..].copy_from_slice(&[0.4, -1.0, 2.0]);
        c
    }

    #[test]
    fn radius_turns_about_the_aux_vector_and_path_choice_takes_the_longer_sector() {
        // From (0.4, 0.1, 0.3) to (0.3, 0.2, 0.3): a chord of √2·0.1, radius 0.1.
        let end = [0.3, 0.2, 0.3];
        let up = v(0.0, 0.0, 0.1);
        let short_ccw = CartesianPath::new(&radius_arc(end, up, false), &start()).unwrap();
        assert_on_circle(&short_ccw, Vector3::from(CENTRE), Vector3::z(), 0.1);
        assert!((short_ccw.length() - 0.1 * PI / 2.0).abs() < 1e-12);
        let long_ccw = CartesianPath::new(&radius_arc(end, up, true), &start()).unwrap();
        assert_on_circle(&long_ccw, v(0.4, 0.2, 0.3), Vector3::z(), 0.1);
        assert!((long_ccw.length() - 0.1 * 1.5 * PI).abs() < 1e-12);
        // The vector pointing down: clockwise seen from above.
        let short_cw = CartesianPath::new(&radius_arc(end, -up, false), &start()).unwrap();
        assert_on_circle(&short_cw, v(0.4, 0.2, 0.3), Vector3::z(), 0.1);
        assert!((short_cw.length() - 0.1 * PI / 2.0).abs() < 1e-12);
        let long_cw = CartesianPath::new(&radius_arc(end, -up, true), &start()).unwrap();
        assert_on_circle(&long_cw, Vector3::from(CENTRE), Vector3::z(), 0.1);
        for (path, normal) in [
            (short_ccw, up),
            (long_ccw, up),
            (short_cw, -up),
            (long_cw, -up),
        ] {
            assert!((position(&path, 1.0) - Vector3::from(end)).norm() < 1e-12);
            // Turns positively about the vector: the right thumb rule.
            assert!(arc_of(&path).circle.axis.dot(&normal) > 0.0);
        }
        // Half the chord (within the tolerance) is a half circle either way.
        let half_chord = 0.5 * 0.1 * 2f64.sqrt() - 5e-4;
        for longer in [false, true] {
            let c = radius_arc(end, v(0.0, 0.0, half_chord), longer);
            let half = CartesianPath::new(&c, &start()).unwrap();
            assert!((arc_of(&half).circle.sweep - PI).abs() < 1e-9);
        }
        // Too small, coincident, out of the plane normal to the vector.
        let c = radius_arc(end, v(0.0, 0.0, 0.05), false);
        assert!(matches!(refused(&c), PathError::RadiusTooSmall { .. }));
        let c = radius_arc(end, v(0.1, 0.0, 0.0), false);
        assert!(matches!(refused(&c), PathError::OffPlane { .. }));
        let p0 = start().translation.vector;
        let c = radius_arc(p0.into(), up, false);
        assert_eq!(CartesianPath::new(&c, &start()), Err(PathError::Coincident));
    }

    #[test]
    fn undefined_wire_values_are_refused_with_their_codes() {
        let base = circular(0, [0.3, 0.2, 0.3], [0.2, 0.1, 0.3]);
        type Change = fn(&mut MotionCommand);
        let cases: [(Change, u16); 7] = [
            (|c| c.circle_mode = 4, code::INVALID_MODE),
            (|c| c.circle_plane = 3, code::INVALID_MODE),
            (|c| c.path_choice = 2, code::INVALID_MODE),
            (|c| c.ori_mode = 5, code::INVALID_ORI_MODE),
            (|c| c.aux_pose[0] = f64::INFINITY, code::INVALID_POSITION),
            (
                |c| c.circle_tolerance_m = -1e-3,
                code::TOLERANCE_ONLY_CENTER,
            ),
            (|c| c.target_reference = 1, code::INTERNAL_ERROR),
        ];
        for (change, expected) in cases {
            let mut c = base;
            change(&mut c);
            assert_eq!(validate(&c).unwrap_err().code(), expected, "{c:?}");
        }
        assert!(validate(&base).is_ok());
        // JOINT_INTERPOLATED is for lines.
        let mut line = base;
        line.kind = MotionCommandKind::MoveLinear as u8;
        line.ori_mode = 2;
        assert!(validate(&line).is_ok());
        line.kind = MotionCommandKind::MoveAxes as u8;
        assert_eq!(validate(&line), Err(PathError::NotAPath(1)));
    }

    #[test]
    fn orientation_modes_along_an_arc() {
        let mut c = circular(1, CENTRE, [0.3, 0.2, 0.3]);
        let r0 = start().rotation;
        let target = UnitQuaternion::from_euler_angles(0.5, 0.2, -0.4);
        c.pose[3..].copy_from_slice(
            &pose::pose(&Isometry3::from_parts(Translation3::identity(), target))[3..],
        );
        // Interpolated: the slerp.
        let path = CartesianPath::new(&c, &start()).unwrap();
        for s in [0.0, 0.3, 1.0] {
            assert!(path.tcp(s).rotation.angle_to(&r0.slerp(&target, s)) < 1e-9);
        }
        // FIX: the start all the way.
        c.ori_mode = 3;
        let path = CartesianPath::new(&c, &start()).unwrap();
        assert!(path.tcp(0.7).rotation.angle_to(&r0) < 1e-12);
        // PATH with the target the start turned by the arc: turns with the tangent.
        c.ori_mode = 4;
        let turned = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), PI / 2.0) * r0;
        c.pose[3..].copy_from_slice(
            &pose::pose(&Isometry3::from_parts(Translation3::identity(), turned))[3..],
        );
        let path = CartesianPath::new(&c, &start()).unwrap();
        for k in 0..=10 {
            let s = k as f64 / 10.0;
            let expected = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), s * PI / 2.0) * r0;
            assert!(path.tcp(s).rotation.angle_to(&expected) < 1e-9, "s = {s}");
        }
        // PATH to another orientation still ends there.
        c.pose[3..].copy_from_slice(
            &pose::pose(&Isometry3::from_parts(Translation3::identity(), target))[3..],
        );
        let path = CartesianPath::new(&c, &start()).unwrap();
        assert!(path.tcp(1.0).rotation.angle_to(&target) < 1e-9);
        assert!(path.tcp(0.0).rotation.angle_to(&r0) < 1e-12);
    }

    #[test]
    fn a_line_is_the_straight_segment() {
        let mut c = MotionCommand::new(MotionCommandKind::MoveLinear);
        c.pose = [0.5, 0.3, 0.1, 0.0, 0.0, 0.0];
        let path = CartesianPath::new(&c, &start()).unwrap();
        let p0 = start().translation.vector;
        let p1 = v(0.5, 0.3, 0.1);
        assert!((path.length() - (p1 - p0).norm()).abs() < 1e-12);
        assert!((position(&path, 0.25) - (p0 + (p1 - p0) * 0.25)).norm() < 1e-12);
        assert!(!path.is_stationary());
        c.pose = pose::pose(&start());
        assert!(CartesianPath::new(&c, &start()).unwrap().is_stationary());
    }

    #[test]
    fn orientation_modes_along_a_line() {
        let mut c = MotionCommand::new(MotionCommandKind::MoveLinear);
        let target = UnitQuaternion::from_euler_angles(0.5, 0.2, -0.4);
        c.pose = pose::pose(&Isometry3::from_parts(
            Translation3::new(0.5, 0.3, 0.1),
            target,
        ));
        let r0 = start().rotation;
        for (mode, end) in [(0, target), (1, target), (2, target), (3, r0), (4, target)] {
            c.ori_mode = mode;
            let path = CartesianPath::new(&c, &start()).unwrap();
            assert!(
                path.tcp(0.0).rotation.angle_to(&r0) < 1e-12,
                "OriMode {mode}"
            );
            assert!(
                path.tcp(1.0).rotation.angle_to(&end) < 1e-9,
                "OriMode {mode}"
            );
            assert!(
                path.tcp(0.5).rotation.angle_to(&r0.slerp(&end, 0.5)) < 1e-9,
                "OriMode {mode}"
            );
        }
        // A pure reorientation: FIX does not move, PATH turns to the target as 1 does.
        c.pose = pose::pose(&Isometry3::from_parts(start().translation, target));
        c.ori_mode = 3;
        assert!(CartesianPath::new(&c, &start()).unwrap().is_stationary());
        c.ori_mode = 4;
        assert!(!CartesianPath::new(&c, &start()).unwrap().is_stationary());
    }

    proptest! {
        /// Random BORDER arcs: every sample on the circle through the three points, the
        /// speed even (s proportional to the distance), the tangent continuous.
        #[test]
        fn random_arcs_stay_on_their_circle(
            centre in prop::array::uniform3(-0.5f64..0.5),
            radius in 0.01f64..0.5,
            tilt in prop::array::uniform3(-PI..PI),
            angles in prop::array::uniform3(0.0f64..TAU),
        ) {
            let rotation = UnitQuaternion::from_euler_angles(tilt[0], tilt[1], tilt[2]);
            let centre = Vector3::from(centre);
            let at = |angle: f64| centre + rotation * v(angle.cos(), angle.sin(), 0.0) * radius;
            let mut sorted = angles;
            sorted.sort_by(f64::total_cmp);
            // Points far enough apart to make a well-defined circle.
            prop_assume!(sorted[1] - sorted[0] > 0.05 && sorted[2] - sorted[1] > 0.05 && TAU - sorted[2] + sorted[0] > 0.05);
            let (p0, aux, p1) = (at(angles[0]), at(angles[1]), at(angles[2]));
            // And not so close on a small circle that the path refuses them as collinear
            // (the triangle's smallest height within COLLINEAR_M).
            let longest = (aux - p0).norm().max((p1 - p0).norm()).max((p1 - aux).norm());
            prop_assume!((aux - p0).cross(&(p1 - p0)).norm() / longest > 2.0 * COLLINEAR_M);
            let start = Isometry3::from_parts(Translation3::from(p0), UnitQuaternion::identity());
            let c = circular(0, aux.into(), p1.into());
            let path = CartesianPath::new(&c, &start).unwrap();
            let normal = rotation * Vector3::z();
            let length = path.length();
            let h = 1e-5;
            let mut through_aux = false;
            for k in 0..=200 {
                let s = k as f64 / 200.0;
                let p = position(&path, s) - centre;
                prop_assert!((p.norm() - radius).abs() < 1e-9);
                prop_assert!(p.dot(&normal).abs() < 1e-9);
                through_aux |= (position(&path, s) - aux).norm() < 0.6 * length / 200.0;
                let (a, b) = ((s - h).max(0.0), (s + h).min(1.0));
                let mid = 0.5 * (a + b);
                // Speed |dp/ds| is the length everywhere; the tangent turns smoothly: the
                // difference quotients either side of s agree.
                let behind = (position(&path, mid) - position(&path, a)) / (mid - a);
                let ahead = (position(&path, b) - position(&path, mid)) / (b - mid);
                prop_assert!((ahead.norm() - length).abs() < 1e-4 * length.max(1.0));
                prop_assert!((ahead - behind).norm() < 1e-3 * length.max(1e-3));
            }
            prop_assert!(through_aux);
            prop_assert!((position(&path, 0.0) - p0).norm() < 1e-9);
            prop_assert!((position(&path, 1.0) - p1).norm() < 1e-9);
        }

        /// Random CENTER arcs in random CircPlanes and RADIUS arcs about random vectors start
        /// and end exactly and stay at the radius.
        #[test]
        fn random_center_and_radius_arcs_end_exactly(
            tilt in prop::array::uniform3(-PI..PI),
            radius in 0.02f64..0.5,
            angles in prop::array::uniform2(0.0f64..TAU),
            ccw in any::<bool>(),
            radius_mode in any::<bool>(),
            upwards in any::<bool>(),
        ) {
            let rotation = UnitQuaternion::from_euler_angles(tilt[0], tilt[1], tilt[2]);
            let centre = v(0.3, -0.2, 0.4);
            let at = |angle: f64| centre + rotation * v(angle.cos(), angle.sin(), 0.0) * radius;
            let (p0, p1) = (at(angles[0]), at(angles[1]));
            prop_assume!((p1 - p0).norm() > 1e-3);
            let start = Isometry3::from_parts(Translation3::from(p0), UnitQuaternion::identity());
            // RADIUS: the vector along ± the plane normal; CENTER: the aux frame's XY plane is
            // the circle's.
            let sign = if upwards || !radius_mode { 1.0 } else { -1.0 };
            let c = if radius_mode {
                radius_arc(p1.into(), rotation * Vector3::z() * (sign * radius), ccw)
            } else {
                let mut c = circular(1, centre.into(), p1.into());
                let rpy = pose::pose(&Isometry3::from_parts(Translation3::identity(), rotation));
                c.aux_pose[3..].copy_from_slice(&rpy[3..]);
                c.circle_plane = 2;
                c.path_choice = u8::from(ccw);
                c
            };
            let path = CartesianPath::new(&c, &start).unwrap();
            prop_assert!((position(&path, 0.0) - p0).norm() < 1e-9);
            prop_assert!((position(&path, 1.0) - p1).norm() < 1e-9);
            let arc = arc_of(&path);
            // The sense: CCW (CENTER) or the vector's (RADIUS) turns positively about the
            // plane normal.
            let sense = arc.circle.axis.dot(&(rotation * Vector3::z()));
            let expected = if radius_mode { sign } else if ccw { 1.0 } else { -1.0 };
            prop_assert!((sense - expected).abs() < 1e-9);
            let centre_of_arc = if radius_mode { arc.circle.centre } else { centre };
            for k in 0..=50 {
                let p = position(&path, k as f64 / 50.0) - centre_of_arc;
                prop_assert!((p.norm() - radius).abs() < 1e-9);
            }
            if radius_mode {
                // PathChoice 1 takes the longer sector.
                let sweep = arc.circle.sweep;
                let longer = sweep >= PI - 1e-9;
                let shorter = sweep <= PI + 1e-9;
                prop_assert!(if ccw { longer } else { shorter }, "sweep {}", sweep);
            }
        }
    }
}
