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
/// Bisection steps for the share of the acceleration held back for override changes
/// ([`Timing::fastest_profile`]): to 2⁻¹² of the reserve.
const RESERVE_BISECTIONS: usize = 12;

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

/// The error of a rate or reference share outside (0, 1].
type InvalidShare = fn(f64) -> MoveError;

/// Checks the timing parameters of any move: the velocity, acceleration, deceleration and
/// jerk scales and the TCP reference shares in (0, 1], the duration finite and not negative.
pub fn validate_timing(command: &MotionCommand) -> Result<(), MoveError> {
    let in_unit = |x: f64| x > 0.0 && x <= 1.0;
    let [v, a, d, j] = command.tcp_reference;
    let shares: [(f64, InvalidShare); 8] = [
        (command.velocity_scale, MoveError::InvalidVelocityScale),
        (
            command.acceleration_scale,
            MoveError::InvalidAccelerationScale,
        ),
        (
            command.deceleration_scale,
            MoveError::InvalidDecelerationScale,
        ),
        (command.jerk_scale, MoveError::InvalidJerkScale),
        (v, MoveError::InvalidVelocityScale),
        (a, MoveError::InvalidAccelerationScale),
        (d, MoveError::InvalidDecelerationScale),
        (j, MoveError::InvalidJerkScale),
    ];
    if let Some((share, error)) = shares.into_iter().find(|(x, _)| !in_unit(*x)) {
        return Err(error(share));
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
    /// total, override changes included.
    pub limits: PathLimits,
    /// Path limits from the robot's limits alone (the rates at 100 %): what a stop on the
    /// path of a profile on constant bounds brakes within, as fast as the limits allow
    /// whatever the command's rates.
    pub stop: PathLimits,
    /// The profile, planned with the acceleration reserve held back for override changes.
    pub profile: Profile,
    /// Largest rate of change of the override (1/s) the reserve pays for.
    pub override_rate: f64,
    /// The command's JerkRate as a share of the robot's jerk limits: override ramps during
    /// the move change their rate within it too.
    pub jerk_rate: f64,
}

impl Timing {
    /// The timing of `command` with the path limits `limits`: the fastest profile that
    /// leaves room for override changes at the rate the share `reserve` in [0, 1) of the
    /// acceleration and deceleration pays for at full speed, stretched to the command's
    /// duration if that is positive.
    ///
    /// Time scaling by σ ≤ 1 gives `s̈ = s̈_plan·σ² + ṡ_plan·σ̇`, so with
    /// `|σ̇| ≤ ω = r·min(a, d)/v` a profile that keeps `|s̈_plan| + ṡ_plan·ω` within `a`
    /// (`d` while braking) at every instant keeps them under any override change. Holding
    /// back the share `r` does that everywhere; the profile's acceleration is at its peak
    /// well before its speed is ([`fastest_profile`](Self::fastest_profile)), so less of it
    /// does too, most of all on moves that peak below the speed limit.
    pub fn plan(
        limits: PathLimits,
        stop: PathLimits,
        reserve: f64,
        command: &MotionCommand,
    ) -> Result<Self, MoveError> {
        let (fastest, override_rate) = Self::fastest_profile(limits, reserve);
        Self::with_profile(
            limits,
            stop,
            Profile::DoubleS(fastest),
            override_rate,
            command,
        )
    }

    /// The fastest double-S within `limits` that leaves room for override changes at the
    /// rate the share `reserve` pays for at full speed (see [`plan`](Self::plan)), and that
    /// rate (1/s). The shares of the acceleration and of the deceleration held back are the
    /// smallest that keep `|s̈| + ṡ·r·a/v` of the profile within `a` while it speeds up and
    /// `|s̈| + ṡ·r·d/v` within `d` while it brakes (`reserve` always does, as `ṡ ≤ v`), both
    /// rates at least `ω = r·min(a, d)/v`. They are found by bisection: one share for both,
    /// then each on its own with the other fixed.
    pub fn fastest_profile(limits: PathLimits, reserve: f64) -> (DoubleS, f64) {
        let (a, d) = (limits.acceleration, limits.deceleration);
        let override_rate = reserve * a.min(d) / limits.velocity;
        let with_shares = |[accelerating, braking]: [f64; 2]| {
            DoubleS::new(
                limits.velocity,
                (1.0 - accelerating) * a,
                (1.0 - braking) * d,
                limits.jerk,
            )
        };
        let fits = |profile: &DoubleS| {
            let (v_peak, jerk) = (profile.peak_velocity(), profile.peak_jerk());
            // The largest |s̈_plan| + ṡ_plan·ω of a ramp to the peak `peak`: where its jerk
            // starts to take the acceleration away, `peak²/2j` short of the peak speed,
            // unless ω·ṡ grows faster than the jerk takes s̈ away (then bounded by the peak
            // speed itself).
            let during = |peak: f64, rate: f64| {
                let short = if rate * peak <= jerk {
                    peak * peak / (2.0 * jerk)
                } else {
                    0.0
                };
                peak + rate * (v_peak - short).max(0.0)
            };
            // Each ramp leaves room for the rate its own limit's reserve pays for (at least
            // ω), so that the one ramp does not depend on the other's limit.
            let rate = |limit: f64| reserve * limit / limits.velocity;
            during(profile.peak_acceleration(), rate(a)) <= a
                && during(profile.peak_deceleration(), rate(d)) <= d
        };
        let unreserved = with_shares([0.0; 2]);
        if fits(&unreserved) {
            return (unreserved, override_rate);
        }
        // The smallest share in [0, reserve] for which `shares_of(share)` fits, with its
        // profile; `start`, a share that fits with its profile, where no trial does.
        let smallest = |shares_of: &dyn Fn(f64) -> [f64; 2], start: (f64, DoubleS)| {
            let (mut low, mut high, mut found) = (0.0, reserve, start);
            for _ in 0..RESERVE_BISECTIONS {
                let share = 0.5 * (low + high);
                let profile = with_shares(shares_of(share));
                if fits(&profile) {
                    high = share;
                    found = (share, profile);
                } else {
                    low = share;
                }
            }
            found
        };
        // One share for both ramps first, then each on its own with the other fixed: the
        // acceleration's over the same interval whatever the braking, so that a lower
        // deceleration changes the acceleration ramp only where it changes the peak speed.
        let (both, fastest) = smallest(&|share| [share; 2], (reserve, with_shares([reserve; 2])));
        let (accelerating, fastest) = smallest(&|share| [share, both], (both, fastest));
        let (_, fastest) = smallest(&|share| [accelerating, share], (both, fastest));
        (fastest, override_rate)
    }

    /// The timing of `command` on the fastest profile `fastest` (planned within `limits`
    /// with the reserve that pays for `override_rate`; a stop brakes within `stop`),
    /// stretched to the command's duration if that is positive; a requested duration
    /// shorter than the profile is an error.
    pub fn with_profile(
        limits: PathLimits,
        stop: PathLimits,
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
            stop,
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
        let stop = PathLimits {
            acceleration: path(&limits.acceleration, 1.0),
            deceleration: path(&limits.acceleration, 1.0),
            jerk: path(&limits.jerk, 1.0),
            ..path_limits
        };
        Ok(Plan::Move(Self {
            start,
            target,
            delta,
            timing: Timing::plan(path_limits, stop, reserve, command)?,
        }))
    }

    /// Joint position where the move starts.
    pub fn start(&self) -> [f64; AXES] {
        self.start
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
    use proptest::prelude::*;
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
        assert!(override_room_used(m.timing()) <= 1.0 + 1e-9);
        // Its acceleration peaks at a third of the speed limit: less than the whole reserve
        // leaves the room (computed: 1.652 of 2).
        assert!(double_s(&m).peak_acceleration() > 0.8 * 2.0 + 0.05);
    }

    #[test]
    fn the_deceleration_scale_sets_the_braking_ramp_only() {
        let mut c = move_to([1.0, 0.0, -2.0, 0.0, 0.0, 0.5]);
        // Slow enough to cruise either way: the peak speed, which sets how much of the
        // reserve the acceleration ramp needs, does not depend on the braking then.
        c.velocity_scale = 0.5;
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
        assert!(double_s(&low).peak_deceleration() < double_s(&equal).peak_deceleration());
        assert!(override_room_used(low.timing()) <= 1.0 + 1e-9);
        assert!(low.timing().profile.duration() > equal.timing().profile.duration());
        // The override reserve pays for the smaller of the two.
        assert!((low.timing().override_rate - 0.2 * 0.5 / 0.5).abs() < 1e-12);
        // With equal scales the profile is symmetric.
        let symmetric = double_s(&equal);
        assert_eq!(symmetric.peak_acceleration(), symmetric.peak_deceleration());
    }

    /// The largest `|s̈| + ṡ·ω` along the profile of `timing`, sampled, as a share of the
    /// limit of the phase (acceleration while speeding up, deceleration while braking),
    /// `ω` its override rate: at most 1 where any override change at that rate keeps the
    /// limits.
    fn override_room_used(timing: &Timing) -> f64 {
        const STEPS: usize = 4000;
        let (profile, l) = (timing.profile, timing.limits);
        (0..=STEPS)
            .map(|k| {
                let (_, sd, sdd) = profile.eval(profile.duration() * k as f64 / STEPS as f64);
                let limit = if sdd >= 0.0 {
                    l.acceleration
                } else {
                    l.deceleration
                };
                (sdd.abs() + sd * timing.override_rate) / limit
            })
            .fold(0.0, f64::max)
    }

    proptest! {
        /// The reserve is sized by the profile's own speeds: never more than the whole
        /// reserve, never less than what keeps room for the override rate.
        #[test]
        fn the_reserve_leaves_room_for_the_override_rate_and_no_more(
            velocity in 0.1f64..5.0,
            acceleration in 0.5f64..20.0,
            deceleration in 0.5f64..20.0,
            jerk in 1.0f64..200.0,
            reserve in 0.0f64..0.5,
        ) {
            let limits = PathLimits { velocity, acceleration, deceleration, jerk };
            let (profile, override_rate) = Timing::fastest_profile(limits, reserve);
            let timing = Timing { limits, stop: limits, profile: Profile::DoubleS(profile), override_rate, jerk_rate: 1.0 };
            prop_assert!(override_room_used(&timing) <= 1.0 + 1e-9);
            let kept = 1.0 - reserve;
            let whole = DoubleS::new(velocity, kept * acceleration, kept * deceleration, jerk);
            let none = DoubleS::new(velocity, acceleration, deceleration, jerk);
            prop_assert!(profile.duration() <= whole.duration() * (1.0 + 1e-12));
            prop_assert!(profile.duration() >= none.duration() * (1.0 - 1e-12));
        }
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
