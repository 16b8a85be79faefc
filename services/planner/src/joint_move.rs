//! The synchronized joint-space point-to-point move (MoveAxes).
//!
//! `q(s) = q0 + Δ·s` with one [`DoubleS`] profile for `s`, so every joint starts and arrives
//! at the same time and the arm stays on the straight line in joint space. The path limits
//! are the tightest of the joints': `v_s = min_i v_i/|Δ_i|` (and the same for acceleration
//! and jerk), so `|q̇_i| = |Δ_i|·ṡ ≤ v_i` for every joint.

use shared_types::config::JointLimitsRad;
use shared_types::ipc::{AXES, JointPoint, MotionCommand};
use shared_types::srci::message::code;

use crate::profile::{DoubleS, Profile};

/// Largest joint displacement (rad) treated as no motion at all.
const ZERO_LENGTH_RAD: f64 = 1e-12;
/// Relative slack for a requested duration that equals the shortest one up to rounding.
const DURATION_TOLERANCE: f64 = 1e-9;

/// Why a MoveAxes cannot be executed; [`code`](Self::code) is the SRCI message code.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum MoveError {
    #[error("joint {axis} target {target_rad} rad is below the lower limit {limit_rad} rad")]
    BelowLowerLimit {
        axis: usize,
        target_rad: f64,
        limit_rad: f64,
    },
    #[error("joint {axis} target {target_rad} rad is above the upper limit {limit_rad} rad")]
    AboveUpperLimit {
        axis: usize,
        target_rad: f64,
        limit_rad: f64,
    },
    #[error("joint {axis} target is not a number")]
    InvalidTarget { axis: usize },
    #[error("velocity scale {0} is outside (0, 1]")]
    InvalidVelocityScale(f64),
    #[error("acceleration scale {0} is outside (0, 1]")]
    InvalidAccelerationScale(f64),
    #[error("deceleration scale {0} is outside (0, 1]")]
    InvalidDecelerationScale(f64),
    #[error("jerk scale {0} is outside (0, 1]")]
    InvalidJerkScale(f64),
    #[error(
        "duration {requested_s} s is invalid or shorter than the fastest possible {shortest_s} s"
    )]
    InvalidDuration { requested_s: f64, shortest_s: f64 },
}

impl MoveError {
    /// The SRCI message code reported for this error.
    pub fn code(&self) -> u16 {
        match self {
            Self::BelowLowerLimit { .. } => code::SW_LIMIT_LOWER,
            Self::AboveUpperLimit { .. } => code::SW_LIMIT_UPPER,
            Self::InvalidTarget { .. } => code::INVALID_JOINT_POSITION,
            Self::InvalidVelocityScale(_) => code::INVALID_VELOCITY_RATE,
            Self::InvalidAccelerationScale(_) => code::INVALID_ACCELERATION_RATE,
            Self::InvalidDecelerationScale(_) => code::INVALID_DECELERATION_RATE,
            Self::InvalidJerkScale(_) => code::INVALID_JERK_RATE,
            Self::InvalidDuration { .. } => code::INVALID_TIME,
        }
    }
}

/// Checks what a MoveAxes command asks for independently of where the arm is: the target
/// inside the joint limits, the scales in (0, 1], the duration finite and not negative.
pub fn validate(command: &MotionCommand, limits: &JointLimitsRad) -> Result<(), MoveError> {
    for (axis, &target_rad) in command.joints_rad.iter().enumerate() {
        if !target_rad.is_finite() {
            return Err(MoveError::InvalidTarget { axis });
        }
        check_limits(axis, target_rad, limits, 0.0)?;
    }
    validate_timing(command)
}

/// The joint limits every point of the move of `command` must keep: the robot's `limits`,
/// narrowed to the SW limits the PLC sent with it (infinite or NaN bounds narrow nothing).
pub fn move_limits(limits: &JointLimitsRad, command: &MotionCommand) -> JointLimitsRad {
    JointLimitsRad {
        min: core::array::from_fn(|i| limits.min[i].max(command.sw_lower_rad[i])),
        max: core::array::from_fn(|i| limits.max[i].min(command.sw_upper_rad[i])),
        ..*limits
    }
}

/// Checks joint `axis` at `q_rad` against its limits narrowed by `margin_rad` on both sides.
pub fn check_limits(
    axis: usize,
    q_rad: f64,
    limits: &JointLimitsRad,
    margin_rad: f64,
) -> Result<(), MoveError> {
    if q_rad < limits.min[axis] + margin_rad {
        return Err(MoveError::BelowLowerLimit {
            axis,
            target_rad: q_rad,
            limit_rad: limits.min[axis],
        });
    }
    if q_rad > limits.max[axis] - margin_rad {
        return Err(MoveError::AboveUpperLimit {
            axis,
            target_rad: q_rad,
            limit_rad: limits.max[axis],
        });
    }
    Ok(())
}

/// Checks the timing parameters of any move: the velocity, acceleration, deceleration and
/// jerk scales in (0, 1], the duration finite and not negative.
pub fn validate_timing(command: &MotionCommand) -> Result<(), MoveError> {
    let in_unit = |x: f64| x > 0.0 && x <= 1.0;
    if !in_unit(command.velocity_scale) {
        return Err(MoveError::InvalidVelocityScale(command.velocity_scale));
    }
    if !in_unit(command.acceleration_scale) {
        return Err(MoveError::InvalidAccelerationScale(
            command.acceleration_scale,
        ));
    }
    if !in_unit(command.deceleration_scale) {
        return Err(MoveError::InvalidDecelerationScale(
            command.deceleration_scale,
        ));
    }
    if !in_unit(command.jerk_scale) {
        return Err(MoveError::InvalidJerkScale(command.jerk_scale));
    }
    if !(command.duration_s.is_finite() && command.duration_s >= 0.0) {
        return Err(MoveError::InvalidDuration {
            requested_s: command.duration_s,
            shortest_s: 0.0,
        });
    }
    Ok(())
}

/// Limits of the path parameter `s` of one move.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathLimits {
    /// Largest `ṡ`, 1/s.
    pub velocity: f64,
    /// Largest `s̈` while speeding up, 1/s².
    pub acceleration: f64,
    /// Largest `−s̈` of the braking ramp at the end of the move, 1/s².
    pub deceleration: f64,
    /// Largest `|s⃛|`, 1/s³.
    pub jerk: f64,
}

impl PathLimits {
    /// Largest `|s̈|` the move may use at all: what a stop on the path brakes with.
    pub fn braking(&self) -> f64 {
        self.acceleration.max(self.deceleration)
    }
}

/// The time scaling of one move along its path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Timing {
    /// Path limits from the robot's limits and the command's rates: what the move may do in
    /// total, override changes and stops included.
    pub limits: PathLimits,
    /// The profile, planned with the acceleration reserve held back for override changes.
    pub profile: Profile,
    /// Largest rate of change of the override (1/s) the reserve pays for.
    pub override_rate: f64,
    /// The command's JerkRate as a share of the robot's jerk limits: override ramps during
    /// the move change their rate within it too.
    pub jerk_rate: f64,
}

impl Timing {
    /// The timing of `command` with the path limits `limits`: the profile is planned with
    /// the share `reserve` in [0, 1) of the acceleration and deceleration held back for
    /// override changes, and stretched to the command's duration if that is positive.
    ///
    /// With `|s̈_plan| ≤ (1 − r)·a` (`d` while braking) and `|ṡ_plan| ≤ v`, time scaling by
    /// σ ≤ 1 with `|σ̇| ≤ r·min(a, d)/v` gives `|s̈| ≤ |s̈_plan|·σ² + |ṡ_plan|·|σ̇| ≤ max(a, d)`,
    /// the [`braking`](PathLimits::braking) limit.
    pub fn plan(
        limits: PathLimits,
        reserve: f64,
        command: &MotionCommand,
    ) -> Result<Self, MoveError> {
        let fastest = DoubleS::new(
            limits.velocity,
            (1.0 - reserve) * limits.acceleration,
            (1.0 - reserve) * limits.deceleration,
            limits.jerk,
        );
        let override_rate =
            reserve * limits.acceleration.min(limits.deceleration) / limits.velocity;
        Self::with_profile(limits, Profile::DoubleS(fastest), override_rate, command)
    }

    /// The timing of `command` on the fastest profile `fastest` (planned within `limits`
    /// with the reserve that pays for `override_rate`), stretched to the command's duration
    /// if that is positive; a requested duration shorter than the profile is an error.
    pub fn with_profile(
        limits: PathLimits,
        fastest: Profile,
        override_rate: f64,
        command: &MotionCommand,
    ) -> Result<Self, MoveError> {
        let requested_s = command.duration_s;
        let profile = if requested_s <= 0.0 {
            fastest
        } else if requested_s < fastest.duration() * (1.0 - DURATION_TOLERANCE) {
            return Err(MoveError::InvalidDuration {
                requested_s,
                shortest_s: fastest.duration(),
            });
        } else {
            fastest.stretched(requested_s)
        };
        Ok(Self {
            limits,
            profile,
            override_rate,
            jerk_rate: command.jerk_scale,
        })
    }
}

/// The outcome of planning a MoveAxes from a start position.
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(
    clippy::large_enum_variant,
    reason = "plans are made in the tick path, where boxing would allocate"
)]
pub enum Plan {
    /// The arm already is at the target: the move is done without motion.
    Stationary,
    /// The arm has to move.
    Move(JointMove),
}

/// A planned synchronized joint move.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointMove {
    start: [f64; AXES],
    target: [f64; AXES],
    delta: [f64; AXES],
    /// Time scaling within the scaled joint limits.
    timing: Timing,
}

impl JointMove {
    /// Plans the move of `command` (validated with [`validate`]) from `start`.
    ///
    /// `reserve` in [0, 1) is the share of the acceleration limit held back so that the
    /// override may change during the move (see [`Timing::plan`]). The deceleration scale
    /// sets the braking ramp at the end.
    pub fn plan(
        start: [f64; AXES],
        command: &MotionCommand,
        limits: &JointLimitsRad,
        reserve: f64,
    ) -> Result<Plan, MoveError> {
        validate(command, limits)?;
        let target = command.joints_rad;
        let delta: [f64; AXES] = core::array::from_fn(|i| target[i] - start[i]);
        if delta.iter().all(|d| d.abs() <= ZERO_LENGTH_RAD) {
            return Ok(Plan::Stationary);
        }
        let path = |joint: &[f64; AXES], scale: f64| {
            delta
                .iter()
                .zip(joint)
                .filter(|(d, _)| d.abs() > ZERO_LENGTH_RAD)
                .map(|(d, lim)| scale * lim / d.abs())
                .fold(f64::INFINITY, f64::min)
        };
        let path_limits = PathLimits {
            velocity: path(&limits.velocity, command.velocity_scale),
            acceleration: path(&limits.acceleration, command.acceleration_scale),
            deceleration: path(&limits.acceleration, command.deceleration_scale),
            jerk: path(&limits.jerk, command.jerk_scale),
        };
        Ok(Plan::Move(Self {
            start,
            target,
            delta,
            timing: Timing::plan(path_limits, reserve, command)?,
        }))
    }

    /// Joint position where the move ends, exactly as commanded.
    pub fn target(&self) -> [f64; AXES] {
        self.target
    }

    /// The time scaling: path limits from the scaled joint limits, profile, override rate.
    pub fn timing(&self) -> &Timing {
        &self.timing
    }

    /// The joint point at path position `s` with path velocity `sd` and acceleration `sdd`.
    /// `s = 1` gives the target exactly.
    pub fn point(&self, s: f64, sd: f64, sdd: f64) -> JointPoint {
        let q = if s >= 1.0 {
            self.target
        } else {
            core::array::from_fn(|i| self.start[i] + self.delta[i] * s)
        };
        JointPoint {
            q,
            qd: self.delta.map(|d| d * sd),
            qdd: self.delta.map(|d| d * sdd),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared_types::ipc::MotionCommandKind;

    fn limits() -> JointLimitsRad {
        JointLimitsRad {
            min: [-3.0; AXES],
            max: [3.0; AXES],
            velocity: [1.0, 1.0, 2.0, 2.0, 3.0, 3.0],
            acceleration: [4.0; AXES],
            jerk: [40.0; AXES],
        }
    }

    fn move_to(target: [f64; AXES]) -> MotionCommand {
        let mut c = MotionCommand::new(MotionCommandKind::MoveAxes);
        c.joints_rad = target;
        c
    }

    fn double_s(m: &JointMove) -> DoubleS {
        match m.timing().profile {
            Profile::DoubleS(p) => p,
            other => panic!("{other:?}"),
        }
    }

    fn planned(start: [f64; AXES], c: &MotionCommand) -> JointMove {
        match JointMove::plan(start, c, &limits(), 0.2) {
            Ok(Plan::Move(m)) => m,
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn path_limits_come_from_the_tightest_joint() {
        let mut c = move_to([1.0, 0.0, -2.0, 0.0, 0.0, 0.5]);
        c.velocity_scale = 0.5;
        let m = planned([0.0; AXES], &c);
        // Joint 0: 0.5·1/1 = 0.5; joint 2: 0.5·2/2 = 0.5; joint 5: 0.5·3/0.5 = 3.
        assert!((m.timing().limits.velocity - 0.5).abs() < 1e-12);
        assert!((m.timing().limits.acceleration - 2.0).abs() < 1e-12);
        assert!((m.timing().limits.deceleration - 2.0).abs() < 1e-12);
        assert!((m.timing().limits.jerk - 20.0).abs() < 1e-12);
        assert!((m.timing().override_rate - 0.2 * 2.0 / 0.5).abs() < 1e-12);
        assert!(double_s(&m).peak_acceleration() <= 0.8 * 2.0 + 1e-12);
    }

    #[test]
    fn the_deceleration_scale_sets_the_braking_ramp_only() {
        let mut c = move_to([1.0, 0.0, -2.0, 0.0, 0.0, 0.5]);
        c.acceleration_scale = 0.5;
        c.deceleration_scale = 0.5;
        let equal = planned([0.0; AXES], &c);
        c.deceleration_scale = 0.25;
        let low = planned([0.0; AXES], &c);
        // Joint 2 decides: 4 rad/s² over 2 rad, times the scales.
        assert!((low.timing().limits.acceleration - 1.0).abs() < 1e-12);
        assert!((low.timing().limits.deceleration - 0.5).abs() < 1e-12);
        assert!((low.timing().limits.braking() - 1.0).abs() < 1e-12);
        assert_eq!(
            double_s(&low).peak_acceleration(),
            double_s(&equal).peak_acceleration()
        );
        assert!(double_s(&low).peak_deceleration() <= 0.8 * 0.5 + 1e-12);
        assert!(low.timing().profile.duration() > equal.timing().profile.duration());
        // The override reserve pays for the smaller of the two.
        assert!((low.timing().override_rate - 0.2 * 0.5 / 1.0).abs() < 1e-12);
        // With equal scales the profile is the symmetric one of the acceleration scale.
        let symmetric = DoubleS::new(1.0, 0.8 * 1.0, 0.8 * 1.0, 20.0);
        assert_eq!(double_s(&equal), symmetric);
    }

    #[test]
    fn joints_stay_on_the_line_and_arrive_exactly() {
        let start = [0.1, -0.2, 0.3, 0.0, 1.0, -1.0];
        let target = [1.1, 0.2, -0.3, 0.0, 2.5, -1.25];
        let m = planned(start, &move_to(target));
        let end = m.point(1.0, 0.0, 0.0);
        assert_eq!(end.q, target);
        let mid = m.point(0.25, 0.0, 0.0);
        for i in 0..AXES {
            let expected = start[i] + 0.25 * (target[i] - start[i]);
            assert!((mid.q[i] - expected).abs() < 1e-15);
        }
    }

    #[test]
    fn zero_length_move_is_stationary() {
        let start = [0.5; AXES];
        assert_eq!(
            JointMove::plan(start, &move_to(start), &limits(), 0.2),
            Ok(Plan::Stationary)
        );
    }

    #[test]
    fn targets_outside_the_limits_are_rejected_with_their_codes() {
        let mut t = [0.0; AXES];
        t[3] = -3.1;
        let e = validate(&move_to(t), &limits()).unwrap_err();
        assert_eq!(e.code(), 0x8C53);
        t[3] = 3.1;
        let e = validate(&move_to(t), &limits()).unwrap_err();
        assert_eq!(e.code(), 0x8C54);
        t[3] = f64::NAN;
        let e = validate(&move_to(t), &limits()).unwrap_err();
        assert_eq!(e.code(), code::INVALID_JOINT_POSITION);
    }

    #[test]
    fn sw_limits_narrow_the_mechanical_ones_only() {
        let mut c = move_to([0.0; AXES]);
        c.sw_lower_rad[1] = -1.0;
        c.sw_upper_rad[2] = 5.0;
        c.sw_upper_rad[3] = f64::NAN;
        let l = move_limits(&limits(), &c);
        assert_eq!(l.min, [-3.0, -1.0, -3.0, -3.0, -3.0, -3.0]);
        assert_eq!(l.max, [3.0; AXES]);
        assert_eq!(l.velocity, limits().velocity);
        c.joints_rad[1] = -1.5;
        assert_eq!(validate(&c, &l).unwrap_err().code(), code::SW_LIMIT_LOWER);
        assert!(validate(&c, &limits()).is_ok());
    }

    #[test]
    fn scales_outside_the_unit_interval_are_rejected() {
        let mut c = move_to([0.0; AXES]);
        c.velocity_scale = 0.0;
        assert_eq!(validate(&c, &limits()).unwrap_err().code(), 0x8D38);
        c.velocity_scale = 1.0;
        c.acceleration_scale = 1.5;
        assert_eq!(validate(&c, &limits()).unwrap_err().code(), 0x8D01);
        c.acceleration_scale = 1.0;
        c.deceleration_scale = -0.5;
        assert_eq!(validate(&c, &limits()).unwrap_err().code(), 0x8D06);
        c.deceleration_scale = 1.0;
        c.jerk_scale = f64::NAN;
        assert_eq!(validate(&c, &limits()).unwrap_err().code(), 0x8D11);
        c.jerk_scale = 1.0;
        c.duration_s = -1.0;
        assert_eq!(validate(&c, &limits()).unwrap_err().code(), 0x8D34);
    }

    #[test]
    fn requested_duration_stretches_or_is_rejected() {
        let mut c = move_to([1.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let fastest = planned([0.0; AXES], &c).timing().profile.duration();
        c.duration_s = 2.0 * fastest;
        let m = planned([0.0; AXES], &c);
        assert!((m.timing().profile.duration() - 2.0 * fastest).abs() < 1e-12);
        c.duration_s = 0.9 * fastest;
        let e = JointMove::plan([0.0; AXES], &c, &limits(), 0.2).unwrap_err();
        assert_eq!(e.code(), 0x8D34);
    }
}
