//! The commanded motion of the arm, advanced one interpolation tick at a time.
//!
//! A [`Motion`] is small and `Copy`, so the executor can step a copy ahead to fill the
//! setpoint window with exactly the points the real motion will take if nothing changes.
//!
//! # Blends
//!
//! A running move carries its [`Handover`]: undecided until the executor decides, once, at
//! the beginning of the move's blend window, whether it blends into the next move of its
//! sequence (see [`blend`](crate::blend)). A planned blend starts B when A's time reaches the
//! overlap start, if B still is the next move of the sequence; then A is DONE and B ACTIVE
//! in the same tick (as a blended PLCopen block is Done when the next one takes over), and
//! both advance on the one time scale σ until A ends. During the overlap the status reports
//! B as the running move.
//!
//! An overlap whose blended jerk would exceed the jerk limits at full speed runs at most at
//! its [`Overlap::max_scale`](crate::blend::Overlap::max_scale): from A's time
//! [`PlannedBlend::slow_down_at`] on, σ ramps towards the lower of the override and that
//! scale (as an override ramp does), arriving before the overlap starts whatever the
//! override does after the decision, and stays at most there until A ends (a σ that
//! entered the overlap still rising, below that scale where it comes to rest); then B
//! ramps back up to the override.
//!
//! A stop or an interrupt during the overlap brakes on the blended path: σ goes to 0 at the
//! blend's stop rate, which keeps every joint within its velocity and acceleration limits,
//! the rate changing as gradually as an override ramp's. If A ends before the arm
//! stands, B alone brakes on its path. An interrupted B goes back to its sequence and, on
//! continue, is planned anew from where the arm stopped (A is done already).
//!
//! # Override
//!
//! A change of the override is a pure re-timing: the profiles' time τ advances σ seconds
//! per second, and σ approaches the override with `|σ̇|` at most the move's override rate
//! (which its acceleration reserve pays for) and `|σ̈|` at most
//! [`Dynamics::scale_acceleration`] of [`OVERRIDE_JERK_SHARE`] times the move's JerkRate,
//! braking its rate to arrive at rest. The commanded
//! rates are `q̇ = σ·q̇ₜ`, `q̈ = σ²·q̈ₜ + σ̇·q̇ₜ`, `q⃛ = σ³·q⃛ₜ + 3·σ·σ̇·q̈ₜ + σ̈·q̇ₜ`: a ramp adds
//! at most [`OVERRIDE_JERK_SHARE`] of every jerk limit through `σ̈·q̇ₜ`, and the cross term;
//! a guarantee within the limit would need a share of the jerk held back in every plan, as
//! the acceleration is.
//!
//! # WaitTime
//!
//! A [`MotionCommandKind::Wait`] in a sequence stands still for its duration (real time,
//! the override does not stretch it) and is then DONE; it never blends. An interrupt pauses
//! its clock: the executor puts it back into its sequence with the time left, and continue
//! makes it ACTIVE again for that time.

use shared_types::config::JointLimitsRad;
use shared_types::ipc::{AXES, JointPoint, MotionCommand, MotionCommandKind};
use shared_types::srci::message::state;

use crate::blend::Overlap;
use crate::brake::PathBrake;
use crate::cartesian_path;
use crate::joint_move::{JointMove, Plan, Timing};
use crate::linear_move::{LinearMove, LinearPlan, TcpLimits};
use crate::path_stop::{PREDICTION_STEP_S, PathStop};
use crate::profile::Profile;
use crate::scale_brake::{COORDINATES, ScaleBrake, TableRates};
use crate::sequences::{Cursor, Holds, Sequence, Sequences};
use crate::time_scale::TimeScale;

/// Wait time (s) left that counts as none, against rounding of the tick sum.
const WAIT_TOLERANCE_S: f64 = 1e-9;
/// Most ticks a slow-down ahead of a blend is followed for (5 s at 1 ms), to bound the
/// decision's time (scheduling a slow-down follows it at most 11 times).
const SLOW_DOWN_TICKS: usize = 5_000;
/// Bisection steps for the time a slow-down ahead of a blend begins, or for the lowest
/// scale it reaches.
const SLOW_DOWN_BISECTIONS: usize = 10;

/// The path of a running move: a straight line in joint space or of the TCP.
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(
    clippy::large_enum_variant,
    reason = "the motion is copied ahead every tick, where boxing would allocate"
)]
pub enum Path {
    /// MoveAxes (and MoveDirect, a joint move to a Cartesian target).
    Joint(JointMove),
    /// MoveLinear and MoveCircular: the TCP on a line or an arc.
    Linear(LinearMove),
}

impl Path {
    /// The time scaling of the move.
    pub fn timing(&self) -> &Timing {
        match self {
            Self::Joint(m) => m.timing(),
            Self::Linear(m) => m.timing(),
        }
    }

    /// Joint position where the move ends.
    pub fn target(&self) -> [f64; AXES] {
        match self {
            Self::Joint(m) => m.target(),
            Self::Linear(m) => m.target(),
        }
    }

    /// The joint point at `(s, ṡ, s̈)`, next to `previous` (the point of the last tick).
    pub fn point(&self, s: f64, sd: f64, sdd: f64, previous: &[f64; AXES]) -> JointPoint {
        match self {
            Self::Joint(m) => m.point(s, sd, sdd),
            Self::Linear(m) => m.point(s, sd, sdd, previous),
        }
    }

    /// The rates of the joints and the TCP along the path (and the TCP's acceleration across
    /// it on an arc) on the unscaled profile at time `tau`, next to `previous`; the jerk is
    /// the change of the acceleration over the following `step` s (the preceding one at the
    /// profile's end, where the profile stands).
    pub fn table_rates(&self, tau: f64, step: f64, previous: &[f64; AXES]) -> TableRates {
        let profile = &self.timing().profile;
        let step = if tau + step <= profile.duration() {
            step
        } else {
            -step
        };
        self.rates(|t| profile.eval(tau + t), step, previous)
    }

    /// The rates as [`table_rates`](Self::table_rates) gives them, of a profile that passes
    /// the path parameter `s` at the constant `speed` (1/s).
    pub fn cruise_rates(
        &self,
        s: f64,
        speed: f64,
        step: f64,
        previous: &[f64; AXES],
    ) -> TableRates {
        self.rates(|t| (s + speed * t, speed, 0.0), step, previous)
    }

    /// The rates of the profile `state` (`(s, ṡ, s̈)` a time after now) now, the jerk over
    /// the following `step` s.
    fn rates(
        &self,
        state: impl Fn(f64) -> (f64, f64, f64),
        step: f64,
        previous: &[f64; AXES],
    ) -> TableRates {
        // |p'| and |p''| of the TCP's path at s.
        let tcp = |s: f64| match self {
            Self::Joint(_) => (0.0, 0.0),
            Self::Linear(m) => m.tcp_path_derivatives(s),
        };
        let at = |t: f64| {
            let (s, sd, sdd) = state(t);
            let point = self.point(s, sd, sdd, previous);
            let (speed, curvature) = tcp(s);
            let mut velocity = [speed * sd; COORDINATES];
            let mut acceleration = [speed * sdd; COORDINATES];
            velocity[..AXES].copy_from_slice(&point.qd);
            acceleration[..AXES].copy_from_slice(&point.qdd);
            let mut normal = [0.0; COORDINATES];
            normal[AXES] = curvature * sd * sd;
            (velocity, acceleration, normal)
        };
        let (velocity, acceleration, normal) = at(0.0);
        let (_, acceleration_next, _) = at(step);
        TableRates {
            jerk: core::array::from_fn(|i| (acceleration_next[i] - acceleration[i]) / step),
            velocity,
            acceleration,
            normal,
        }
    }
}

/// How a move stops on its path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Stop {
    /// A profile planned on constant path limits brakes `s` with them.
    Path(PathBrake),
    /// A time-optimal table brakes its path parameter within the limits at the current
    /// point, as long as that stays slower than the table there ([`PathStop`]).
    OnPath(PathStop),
    /// A time-optimal table brakes its time scale within the limits at the current point.
    TimeScale(ScaleBrake),
}

/// One tick of a [`Stop`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StopTick {
    /// The point commanded.
    pub point: JointPoint,
    /// The profile parameter there (the path position unless a line's table runs on the
    /// joints' pace) and its rates.
    pub position: f64,
    pub rate: (f64, f64),
    /// Whether the arm stands.
    pub stopped: bool,
}

impl Stop {
    /// A stop of `plan` from its state at profile time `tau` under the time scale `scale`,
    /// the point last commanded at `previous`: a table (of a Cartesian path) brakes its path
    /// parameter where that stays below the table and is expected to stand sooner
    /// ([`PathStop`]), else its time scale; a profile on constant bounds brakes `s`.
    pub fn of(plan: &Path, tau: f64, scale: TimeScale, previous: &[f64; AXES]) -> Self {
        let timing = plan.timing();
        // Same (s, ṡ, s̈) as the point last commanded, so the stop is continuous.
        let state = scaled(plan, tau, scale);
        let (Profile::Table(table), Path::Linear(m)) = (&timing.profile, plan) else {
            let limits = timing.stop;
            let (s, sd, sdd) = state;
            return Self::Path(PathBrake::new(s, sd, sdd, limits.braking(), limits.jerk));
        };
        let time_scale = ScaleBrake::new(
            tau,
            scale.sigma,
            scale.rate,
            table.duration(),
            *m.scale_limits(),
        );
        PathStop::new(
            state,
            tau,
            scale.sigma,
            table.peak_velocity(),
            *m.scale_limits(),
        )
        .filter(|stop| {
            let cruise = |s, speed| plan.cruise_rates(s, speed, PREDICTION_STEP_S, previous);
            stop.predicted_duration(&timing.profile, cruise)
                .is_some_and(|took| {
                    // The bounds at the prediction's step: on five of the bench's stops
                    // where the table slowed down, the estimate came out the same at 1 ms.
                    let rates = plan.table_rates(tau, PREDICTION_STEP_S, previous);
                    took < time_scale.expected_duration(&rates, PREDICTION_STEP_S)
                })
        })
        .map_or(Self::TimeScale(time_scale), Self::OnPath)
    }

    /// Advances `dt` seconds of `plan` from the point last commanded at `previous`; a stop
    /// of the time scale keeps `scale` on it.
    pub fn advance(
        &mut self,
        plan: &Path,
        dt: f64,
        scale: &mut TimeScale,
        previous: &[f64; AXES],
    ) -> StopTick {
        let at = |(s, sd, sdd): (f64, f64, f64), stopped: bool| StopTick {
            point: plan.point(s, sd, sdd, previous),
            position: s,
            rate: (sd, sdd),
            stopped,
        };
        match self {
            Self::Path(brake) => {
                brake.advance(dt);
                at((brake.s, brake.v, brake.a), brake.is_stopped())
            }
            Self::OnPath(brake) => {
                brake.advance(dt, |s, speed| plan.cruise_rates(s, speed, dt, previous));
                let tick = at(brake.state(), brake.is_stopped());
                let handover = match plan {
                    Path::Linear(m) => brake.handover(&m.timing().profile, *m.scale_limits()),
                    Path::Joint(_) => None,
                };
                if let Some(handover) = handover {
                    *scale = TimeScale {
                        sigma: handover.sigma(),
                        rate: handover.sigma_rate(),
                    };
                    *self = Self::TimeScale(handover);
                }
                tick
            }
            Self::TimeScale(brake) => {
                let tau = brake.tau();
                brake.advance(dt, || plan.table_rates(tau, dt, previous));
                *scale = TimeScale {
                    sigma: brake.sigma(),
                    rate: brake.sigma_rate(),
                };
                let stopped = brake.is_stopped();
                at(scaled(plan, brake.tau(), *scale), stopped)
            }
        }
    }
}

/// `(s, ṡ, s̈)` of `plan` at profile time `tau` under the time scale `scale`.
fn scaled(plan: &Path, tau: f64, scale: TimeScale) -> (f64, f64, f64) {
    let (s, sd, sdd) = plan.timing().profile.eval(tau);
    (
        s,
        sd * scale.sigma,
        sdd * scale.sigma * scale.sigma + sd * scale.rate,
    )
}

/// What the arm is doing.
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(
    clippy::large_enum_variant,
    reason = "the motion is copied ahead every tick, where boxing would allocate"
)]
pub enum Phase {
    /// Standing still at the commanded position.
    Idle,
    /// Executing one move.
    Running(Running),
    /// Two moves overlapping.
    Blending(Blend),
    /// Stopping on the path of an aborted or interrupted move of `sequence`.
    Braking {
        sequence: Sequence,
        plan: Path,
        stop: Stop,
    },
    /// A WaitTime of the sequence: standing still for `left_s` more of `duration_s` s.
    Waiting {
        active: ActiveMove,
        left_s: f64,
        duration_s: f64,
    },
}

/// A move being executed alone.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Running {
    pub active: ActiveMove,
    pub plan: Path,
    /// The time along its profile.
    pub tau: f64,
    /// What its end leads into.
    pub handover: Handover,
}

/// What the end of a running move leads into.
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(
    clippy::large_enum_variant,
    reason = "the motion is copied ahead every tick, where boxing would allocate"
)]
pub enum Handover {
    /// Not decided yet: the executor decides when the move's blend window begins.
    Undecided,
    /// An exact stop at the end of the move.
    ExactStop,
    /// A blend into the next move of its sequence.
    Blend(PlannedBlend),
}

/// A blend decided for the end of the running move.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlannedBlend {
    /// The move blended into.
    pub next: ActiveMove,
    /// Its path, from where the running move ends.
    pub plan: Path,
    /// When it starts, and the rates of the time scale during the overlap.
    pub overlap: Overlap,
    /// The running move's time from which σ comes down to the overlap's
    /// [`max_scale`](Overlap::max_scale): after the setpoints sent at the decision, in time
    /// for the ramp to arrive before the overlap starts.
    pub slow_down_at: f64,
}

impl PlannedBlend {
    /// The target and the rate bound of the time scale's ramp while the running move, at
    /// its time `tau`, heads into this blend, with the override at `override_target` and
    /// the move's own ramp bounds `ramp` (rate, acceleration). The blend's own (lower) rate
    /// holds from the overlap's start: the rate comes down to it on the way, as gradually
    /// as a ramp changes it (τ advances at most a second per second; the executor plans
    /// the overlap late enough for that). From [`slow_down_at`](Self::slow_down_at) on, σ
    /// heads for the overlap's [`max_scale`](Overlap::max_scale).
    fn ramp_toward(&self, tau: f64, override_target: f64, ramp: (f64, f64)) -> (f64, f64) {
        let (rate, acceleration) = ramp;
        let left = (self.overlap.start - tau).max(0.0);
        let rate = rate.min(self.overlap.override_rate + acceleration * left);
        let target = if tau >= self.slow_down_at {
            override_target.min(self.overlap.max_scale)
        } else {
            override_target
        };
        (target, rate)
    }

    /// Whether the time scale, ramping from `scale` at the running move's time `tau` as
    /// [`Motion`] ramps it (the override at `override_target`, the move's ramp bounds
    /// `ramp`, ticks of `dt`), is at most at the overlap's `max_scale` when the overlap
    /// starts, and does not rise past it. Once it is there after
    /// [`slow_down_at`](Self::slow_down_at) it stays, its target being no higher; one that
    /// takes longer than [`SLOW_DOWN_TICKS`] counts as late.
    fn arrives(
        &self,
        mut scale: TimeScale,
        mut tau: f64,
        override_target: f64,
        ramp: (f64, f64),
        dt: f64,
    ) -> bool {
        for _ in 0..SLOW_DOWN_TICKS {
            let there = scale.sigma.max(scale.rest_point(ramp.1)) <= self.overlap.max_scale;
            if tau >= self.overlap.start || (there && tau >= self.slow_down_at) {
                return there;
            }
            let (target, rate) = self.ramp_toward(tau, override_target, ramp);
            tau += scale.ramp(target, rate, ramp.1, dt);
        }
        false
    }

    /// The [`Blend::ceiling`] of the overlap entered at the time scale `scale`, whose ramp
    /// has σ̈ up to `acceleration`: σ still rising brakes to rest below `max_scale`.
    fn entry_ceiling(&self, scale: TimeScale, acceleration: f64) -> f64 {
        if self.overlap.max_scale < 1.0 && scale.rate > 0.0 {
            self.overlap.max_scale.min(scale.rest_point(acceleration))
        } else {
            self.overlap.max_scale
        }
    }

    /// Schedules the slow-down to the overlap's [`max_scale`](Overlap::max_scale) for the
    /// time scale `scale` at the running move's time `tau`, whatever the override, and the
    /// move's ramp bounds `ramp` (rate, acceleration), in ticks of `dt`: as late as σ
    /// still arrives before the overlap starts, and no earlier than
    /// A's time `earliest` (the end of the setpoints sent). Where even a slow-down from
    /// there on arrives late, the overlap runs at the lowest scale that one reaches (1,
    /// as without a slow-down, where it does not reach one).
    pub fn schedule_slow_down(
        &mut self,
        scale: TimeScale,
        tau: f64,
        earliest: f64,
        ramp: (f64, f64),
        dt: f64,
    ) {
        // For the highest override: one raised after the decision must arrive, too, and a
        // low one costs nothing, σ heading for the lower of the override and the scale.
        let arrives = |blend: &Self| blend.arrives(scale, tau, 1.0, ramp, dt);
        if self.overlap.max_scale >= 1.0 {
            self.slow_down_at = self.overlap.start;
            return;
        }
        self.slow_down_at = earliest;
        if !arrives(self) {
            // The lowest scale it reaches (1 where not even that: as without a slow-down).
            let (mut low, mut high) = (self.overlap.max_scale, 1.0);
            for _ in 0..SLOW_DOWN_BISECTIONS {
                self.overlap.max_scale = 0.5 * (low + high);
                if arrives(self) {
                    high = self.overlap.max_scale;
                } else {
                    low = self.overlap.max_scale;
                }
            }
            self.overlap.max_scale = high;
            return;
        }
        let (mut early, mut late) = (earliest, self.overlap.start);
        for _ in 0..SLOW_DOWN_BISECTIONS {
            self.slow_down_at = 0.5 * (early + late);
            if arrives(self) {
                early = self.slow_down_at;
            } else {
                late = self.slow_down_at;
            }
        }
        self.slow_down_at = early;
    }
}

/// Two moves overlapping: B (active) started while A (outgoing, done) still runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Blend {
    /// The move blended into, now the active one.
    pub active: ActiveMove,
    pub plan: Path,
    /// The time along its profile.
    pub tau: f64,
    /// Its joints at the last tick, without the outgoing move's share.
    joints: [f64; AXES],
    /// The move blended out of, its time and its own joints at the last tick.
    outgoing: Path,
    outgoing_tau: f64,
    outgoing_joints: [f64; AXES],
    overlap: Overlap,
    /// A stop brings the time scale to 0 on the blended path.
    braking: bool,
    /// Highest time scale of the overlap: its `max_scale`, or where σ entered it still
    /// rising, where that rise comes to rest (a slowed overlap never ramps up past it).
    ceiling: f64,
}

/// The running move's job and what its end does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ActiveMove {
    pub job: u32,
    /// The sequence it was taken from.
    pub sequence: Sequence,
    /// Its end holds the primary sequence (StepMode).
    pub hold_after: bool,
}

impl ActiveMove {
    /// The move of `command` taken from `sequence` (StepMode holds primary moves only).
    pub fn of(command: &MotionCommand, sequence: Sequence) -> Self {
        Self {
            job: command.job,
            sequence,
            hold_after: command.hold_after && sequence == Sequence::Primary,
        }
    }
}

/// Limits the moves are planned with.
#[derive(Debug, Clone, Copy)]
pub struct Dynamics {
    /// Joint limits of the robot (rad-based SI units).
    pub limits: JointLimitsRad,
    /// TCP limits of the robot (m-based SI units).
    pub tcp: TcpLimits,
    /// Share of the acceleration limit held back for override changes.
    pub override_reserve: f64,
}

/// Share of every joint's and the TCP's jerk limit that the change of an override ramp's
/// rate takes at most (`σ̈·q̇` in `q⃛ = σ³·q⃛ₜ + 3·σ·σ̇·q̈ₜ + σ̈·q̇ₜ`). With a step of σ̇ instead,
/// a change of the override took the joints' acceleration by `σ̇·q̇ₜ` (up to the override
/// reserve's share of the limit) in one tick: 80 times the jerk limit of the JAKA Zu 7 (40
/// in the positions' third differences).
pub const OVERRIDE_JERK_SHARE: f64 = 0.5;
/// The same share for a stop during a blend, which brings σ to 0 at the blend's stop rate:
/// the whole jerk limit, whatever the moves' JerkRates, so that it stops about as fast as a
/// stop on a single move (from full speed on the JAKA Zu 7, computed: at most `2·√(1/σ̈)`
/// = 0.63 s instead of 0.89 s with the override's share; with a step of σ̇ it took the
/// joints' acceleration to its limit in one tick).
pub const BLEND_STOP_JERK_SHARE: f64 = 1.0;

impl Dynamics {
    /// Largest `|σ̈|` (1/s²) of a ramp of the time scale for which `|σ̈·q̇ₜ|` stays within
    /// `share` of every joint's and the TCP's jerk limit: no coordinate moves faster than
    /// its velocity limit. [`OVERRIDE_JERK_SHARE`] times the moves' JerkRate
    /// ([`Timing::jerk_rate`]; the lower of a blend's two) for override changes,
    /// [`BLEND_STOP_JERK_SHARE`] for a stop during a blend.
    pub fn scale_acceleration(&self, share: f64) -> f64 {
        let (l, tcp) = (&self.limits, &self.tcp);
        let slowest = (0..AXES).fold(tcp.jerk / tcp.velocity, |r, i| {
            r.min(l.jerk[i] / l.velocity[i])
        });
        share * slowest
    }

    /// The bounds of an override ramp during a move of `timing`: `|σ̇|` (1/s, what the
    /// move's acceleration reserve pays for) and `|σ̈|` (1/s², [`OVERRIDE_JERK_SHARE`] of the
    /// move's jerk limits).
    pub fn override_ramp(&self, timing: &Timing) -> (f64, f64) {
        let share = OVERRIDE_JERK_SHARE * timing.jerk_rate;
        (timing.override_rate, self.scale_acceleration(share))
    }
}

/// The commanded joint motion and the time scaling of the override.
#[derive(Debug, Clone, Copy)]
pub struct Motion {
    /// The point commanded for the current tick.
    pub point: JointPoint,
    /// Path position of the running or braking move, 0..1.
    pub path_position: f64,
    /// Path velocity and acceleration `(ṡ, s̈)` of the running or braking move, as
    /// commanded (override included).
    pub path_rate: (f64, f64),
    /// Time scale σ: the running profile advances σ seconds per second.
    scale: TimeScale,
    /// What the arm is doing.
    pub phase: Phase,
    /// The held sequences: a standing arm starts none of their moves.
    pub holds: Holds,
}

/// The servo tick a motion advances to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoTick {
    /// The servo's number of the tick.
    pub number: u64,
    /// Its length, s.
    pub dt: f64,
}

/// What one tick of motion reads besides the motion itself.
struct Tick<'a> {
    dynamics: &'a Dynamics,
    sequences: &'a Sequences,
    cursor: &'a mut Cursor,
    /// The servo tick advanced to.
    number: u64,
    dt: f64,
    override_target: f64,
}

impl Motion {
    /// Standing still at `q`.
    pub fn at_rest(q: [f64; AXES], sigma: f64) -> Self {
        Self {
            point: JointPoint {
                q,
                ..JointPoint::default()
            },
            path_position: 0.0,
            path_rate: (0.0, 0.0),
            scale: TimeScale::at(sigma),
            phase: Phase::Idle,
            holds: Holds::default(),
        }
    }

    /// The running (or waiting) move, if any; during a blend the move blended into.
    pub fn running(&self) -> Option<ActiveMove> {
        match self.phase {
            Phase::Running(Running { active, .. }) | Phase::Waiting { active, .. } => Some(active),
            Phase::Blending(blend) if !blend.braking => Some(blend.active),
            _ => None,
        }
    }

    /// The sequence of the move that runs or brakes, if any.
    pub fn moving_sequence(&self) -> Option<Sequence> {
        match self.phase {
            Phase::Running(Running { active, .. }) => Some(active.sequence),
            Phase::Blending(blend) => Some(blend.active.sequence),
            Phase::Braking { sequence, .. } => Some(sequence),
            Phase::Idle | Phase::Waiting { .. } => None,
        }
    }

    /// How far the running, blending or braking move has travelled along its path, as the
    /// share of the path and its rates `(s, ṡ, s̈)`: [`path_position`](Self::path_position)
    /// and [`path_rate`](Self::path_rate) where the profile runs on the path position itself,
    /// converted where a line's table runs on the joints' pace.
    pub fn travel(&self) -> (f64, f64, f64) {
        let (rd, rdd) = self.path_rate;
        let plan = match &self.phase {
            Phase::Running(running) => &running.plan,
            Phase::Blending(blend) => &blend.plan,
            Phase::Braking { plan, .. } => plan,
            Phase::Idle | Phase::Waiting { .. } => return (self.path_position, rd, rdd),
        };
        match plan {
            Path::Linear(m) => m.travel(self.path_position, rd, rdd),
            Path::Joint(_) => (self.path_position, rd, rdd),
        }
    }

    /// The time scale σ of the override and its rate.
    pub fn time_scale(&self) -> TimeScale {
        self.scale
    }

    /// Whether two moves overlap now (SRCI IsBlending).
    pub fn is_blending(&self) -> bool {
        matches!(self.phase, Phase::Blending(_))
    }

    /// Switches a running move to braking on its path (a blend on the blended path, a wait
    /// ends at once); returns the job that is thereby aborted or interrupted. Braking or
    /// standing motion is left as it is.
    pub fn brake(&mut self) -> Option<u32> {
        match self.phase {
            Phase::Running(Running {
                active, plan, tau, ..
            }) => {
                self.phase = Phase::Braking {
                    sequence: active.sequence,
                    plan,
                    stop: self.stop(&plan, tau),
                };
                Some(active.job)
            }
            Phase::Blending(mut blend) if !blend.braking => {
                blend.braking = true;
                self.phase = Phase::Blending(blend);
                Some(blend.active.job)
            }
            Phase::Waiting { active, .. } => {
                self.phase = Phase::Idle;
                Some(active.job)
            }
            _ => None,
        }
    }

    /// A stop of `plan` from its state at `tau` under the current time scale.
    fn stop(&self, plan: &Path, tau: f64) -> Stop {
        Stop::of(plan, tau, self.scale, &self.point.q)
    }

    /// One tick of a stop of `plan`.
    fn brake_tick(&mut self, sequence: Sequence, plan: Path, mut stop: Stop, dt: f64) {
        let tick = stop.advance(&plan, dt, &mut self.scale, &self.point.q);
        self.point = tick.point;
        self.path_position = tick.position;
        self.path_rate = tick.rate;
        self.phase = if tick.stopped {
            Phase::Idle
        } else {
            Phase::Braking {
                sequence,
                plan,
                stop,
            }
        };
    }

    /// Advances to servo tick `to`. A standing arm starts the next move of `sequences` past
    /// `cursor` (see [`Sequences::next`]) and moves the cursor past it; a linear move only if
    /// it was planned from exactly where the arm stands, else the arm waits for the executor
    /// to plan it from there, and no move before its
    /// [`earliest_start_tick`](crate::queue::QueuedMove::earliest_start_tick). A running
    /// move with a planned blend starts the next move the same way when the overlap begins.
    /// A primary move with `hold_after` holds the primary sequence when it is done.
    /// State changes of jobs go to `report(job, state, code)`. A finished stop leaves the
    /// arm standing for this tick, so a stop's end is observable before the next move starts.
    pub fn advance(
        &mut self,
        dynamics: &Dynamics,
        sequences: &Sequences,
        cursor: &mut Cursor,
        to: ServoTick,
        override_target: f64,
        report: &mut impl FnMut(u32, u8, u16),
    ) {
        let dt = to.dt;
        let mut tick = Tick {
            dynamics,
            sequences,
            cursor,
            number: to.number,
            dt,
            override_target,
        };
        match self.phase {
            Phase::Idle => self.start_next(&mut tick, report),
            Phase::Running(running) => self.run(running, &mut tick, report),
            Phase::Blending(mut blend) => {
                let (incoming, outgoing) = (blend.plan.timing(), blend.outgoing.timing());
                // A stop brakes as fast as the limits allow, whatever the JerkRates.
                let (target, rate, share) = if blend.braking {
                    (0.0, blend.overlap.stop_rate, BLEND_STOP_JERK_SHARE)
                } else {
                    (
                        override_target.min(blend.ceiling),
                        blend.overlap.override_rate,
                        OVERRIDE_JERK_SHARE * incoming.jerk_rate.min(outgoing.jerk_rate),
                    )
                };
                let acceleration = dynamics.scale_acceleration(share);
                let step = self.scale.ramp(target, rate, acceleration, dt);
                blend.tau += step;
                blend.outgoing_tau += step;
                self.overlap(blend);
            }
            Phase::Braking {
                sequence,
                plan,
                stop,
            } => self.brake_tick(sequence, plan, stop, dt),
            Phase::Waiting {
                active,
                left_s,
                duration_s,
            } => self.wait(active, left_s - dt, duration_s, report),
        }
    }

    /// A standing arm starts the next move or wait, if any.
    fn start_next(&mut self, tick: &mut Tick<'_>, report: &mut impl FnMut(u32, u8, u16)) {
        self.stand(tick.override_target);
        let Some((sequence, queued)) = tick.sequences.next(tick.cursor, self.holds) else {
            return;
        };
        if tick.number < queued.earliest_start_tick {
            return;
        }
        let command = &queued.command;
        let active = ActiveMove::of(command, sequence);
        if command.kind == MotionCommandKind::Wait as u8 {
            tick.cursor.pass(sequence);
            report(command.job, state::ACTIVE, 0);
            return self.wait(
                active,
                command.duration_s - tick.dt,
                command.duration_s,
                report,
            );
        }
        let planned = if cartesian_path::is_cartesian(command) {
            match queued.linear {
                Some(plan) if plan.start() == &self.point.q => match plan {
                    LinearPlan::Move(m) => Ok(Some(Path::Linear(m))),
                    LinearPlan::Stationary(_) => Ok(None),
                },
                _ => return,
            }
        } else {
            match JointMove::plan(
                self.point.q,
                command,
                &tick.dynamics.limits,
                tick.dynamics.override_reserve,
            ) {
                Ok(Plan::Move(m)) => Ok(Some(Path::Joint(m))),
                Ok(Plan::Stationary) => Ok(None),
                Err(e) => Err(e.code()),
            }
        };
        tick.cursor.pass(sequence);
        match planned {
            Err(code) => report(command.job, state::ERROR, code),
            Ok(None) => {
                self.point.q = command.joints_rad;
                report(command.job, state::ACTIVE, 0);
                self.finish(active, report);
            }
            Ok(Some(plan)) => {
                report(command.job, state::ACTIVE, 0);
                let running = Running {
                    active,
                    plan,
                    tau: 0.0,
                    handover: Handover::Undecided,
                };
                self.run(running, tick, report);
            }
        }
    }

    fn stand(&mut self, override_target: f64) {
        // Without motion the time scale has no inertia.
        self.scale.sigma = override_target;
        self.scale.rate = 0.0;
        self.point.qd = [0.0; AXES];
        self.point.qdd = [0.0; AXES];
        self.path_position = 0.0;
        self.path_rate = (0.0, 0.0);
    }

    /// One tick of a running move under the override; a planned blend starts the next move
    /// when the overlap begins.
    fn run(
        &mut self,
        mut running: Running,
        tick: &mut Tick<'_>,
        report: &mut impl FnMut(u32, u8, u16),
    ) {
        let ramp = tick.dynamics.override_ramp(running.plan.timing());
        let (target, rate) = match running.handover {
            Handover::Blend(blend) => blend.ramp_toward(running.tau, tick.override_target, ramp),
            _ => (tick.override_target, ramp.0),
        };
        running.tau += self.scale.ramp(target, rate, ramp.1, tick.dt);
        if let Handover::Blend(blend) = running.handover
            && running.tau >= blend.overlap.start
        {
            let next = blend.next;
            let still_next =
                tick.sequences
                    .next(tick.cursor, self.holds)
                    .is_some_and(|(sequence, queued)| {
                        sequence == next.sequence && queued.command.job == next.job
                    });
            if still_next {
                tick.cursor.pass(next.sequence);
                self.finish(running.active, report);
                report(next.job, state::ACTIVE, 0);
                return self.overlap(Blend {
                    active: next,
                    plan: blend.plan,
                    tau: running.tau - blend.overlap.start,
                    joints: running.plan.target(),
                    outgoing: running.plan,
                    outgoing_tau: running.tau,
                    outgoing_joints: self.point.q,
                    overlap: blend.overlap,
                    braking: false,
                    ceiling: blend.entry_ceiling(self.scale, ramp.1),
                });
            }
            // The sequence changed under the plan: end as planned without it.
            running.handover = Handover::ExactStop;
        }
        if running.tau >= running.plan.timing().profile.duration() {
            self.point = running.plan.point(1.0, 0.0, 0.0, &self.point.q);
            self.path_position = 1.0;
            self.path_rate = (0.0, 0.0);
            self.phase = Phase::Idle;
            self.finish(running.active, report);
            return;
        }
        self.place(&running.plan, running.tau);
        self.phase = Phase::Running(running);
    }

    /// Commands the point of `plan` at `tau` under the current time scale.
    fn place(&mut self, plan: &Path, tau: f64) {
        let (point, s, rate) = self.point_of(plan, tau, &self.point.q);
        self.point = point;
        self.path_position = s;
        self.path_rate = rate;
    }

    /// The point of `plan` at `tau` under the current time scale next to `previous`, its
    /// path position and its path rates `(ṡ, s̈)`.
    fn point_of(
        &self,
        plan: &Path,
        tau: f64,
        previous: &[f64; AXES],
    ) -> (JointPoint, f64, (f64, f64)) {
        let (s, sd, sdd) = scaled(plan, tau, self.scale);
        (plan.point(s, sd, sdd, previous), s, (sd, sdd))
    }

    /// Commands the blended point of `blend` at its times; once the outgoing move has ended
    /// the incoming one goes on alone, and a braking blend that stands is over.
    fn overlap(&mut self, mut blend: Blend) {
        if blend.outgoing_tau >= blend.outgoing.timing().profile.duration() {
            // The outgoing move is at its end, where the incoming one started.
            self.point.q = blend.joints;
            self.place(&blend.plan, blend.tau);
            self.phase = if blend.braking {
                Phase::Braking {
                    sequence: blend.active.sequence,
                    plan: blend.plan,
                    stop: self.stop(&blend.plan, blend.tau),
                }
            } else {
                Phase::Running(Running {
                    active: blend.active,
                    plan: blend.plan,
                    tau: blend.tau,
                    handover: Handover::Undecided,
                })
            };
            return;
        }
        let (a, _, _) = self.point_of(&blend.outgoing, blend.outgoing_tau, &blend.outgoing_joints);
        let (b, s, rate) = self.point_of(&blend.plan, blend.tau, &blend.joints);
        let corner = blend.outgoing.target();
        self.point = JointPoint {
            q: core::array::from_fn(|i| a.q[i] + b.q[i] - corner[i]),
            qd: core::array::from_fn(|i| a.qd[i] + b.qd[i]),
            qdd: core::array::from_fn(|i| a.qdd[i] + b.qdd[i]),
        };
        self.path_position = s;
        self.path_rate = rate;
        blend.outgoing_joints = a.q;
        blend.joints = b.q;
        self.phase = if blend.braking && self.scale.sigma <= 0.0 {
            // Stands on the blended path: the stop is over.
            Phase::Idle
        } else {
            Phase::Blending(blend)
        };
    }

    /// One tick of a wait with `left_s` left after it: DONE once no time is left.
    fn wait(
        &mut self,
        active: ActiveMove,
        left_s: f64,
        duration_s: f64,
        report: &mut impl FnMut(u32, u8, u16),
    ) {
        if left_s <= WAIT_TOLERANCE_S {
            self.phase = Phase::Idle;
            self.finish(active, report);
        } else {
            self.phase = Phase::Waiting {
                active,
                left_s,
                duration_s,
            };
        }
    }

    /// Reports a move done; StepMode holds the primary sequence after it.
    fn finish(&mut self, active: ActiveMove, report: &mut impl FnMut(u32, u8, u16)) {
        if active.hold_after {
            self.holds.primary = true;
        }
        report(active.job, state::DONE, 0);
    }
}
