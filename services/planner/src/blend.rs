//! Blending of one move into the next (SRCI BlendingMode): how long the two overlap, and
//! whether the overlap keeps the joint limits.
//!
//! # The blend
//!
//! The BlendingMode of move A says how A blends into the next move B of its sequence. A blend
//! is a superposition in joint space: B starts at A's time `t_s`, before A ends, and while
//! both run the arm follows `q(t) = q_A(t) + q_B(t − t_s) − q_B(0)` with `q_B(0) = q_A(end)`.
//! That serves every pair of joint and Cartesian moves alike (a Cartesian move enters with
//! the joints of its inverse kinematics). The overlap lasts `d = T_A − t_s`: it starts at
//! A's time `T_A − d` and ends when A ends, B then being `d` into its own profile. Both moves
//! share the time scale of the override, so an override change re-times the blend without
//! changing it.
//!
//! The executor decides once per move, when its blend window begins, whether it blends: only
//! into a joint or Cartesian move of the same sequence that is buffered by then, never out of
//! a move whose StepMode holds after it, never across a WaitTime. Job states, stops and
//! interrupts during the overlap are described in [`motion`](crate::motion).
//!
//! # The modes
//!
//! Times are those of the profiles at 100 % override; radii are distances of the TCP (of
//! the move's tool; for a joint move the TCP of the forward kinematics).
//!
//! - 0 EXACT_STOP: no overlap.
//! - 11 RAMP_OVERLAP, `parameter[0]` = fraction `f`: the overlap is `f` times A's
//!   deceleration ramp (1.0: B starts when A starts braking).
//! - 2 DEFINED_VELOCITY, `parameter[0]` = fraction `f`: B starts when A, braking, has slowed
//!   to `f` times its peak path speed.
//! - 3 CORNER_DISTANCE, `parameter[0]` = radius: B starts when A's TCP comes within the radius
//!   of A's end point (the corner).
//! - 4 MAX_CORNER_DEVIATION, `parameter[0]` = distance: the longest overlap whose blended TCP
//!   path passes the corner no farther than the distance (a bisection on the overlap).
//! - 10 CORNER_DISTANCE_2R, parameters = leave and join radius: the overlap starts where A's
//!   TCP is within the leave radius of the corner and ends where B's TCP is the join radius
//!   from it. One overlap cannot honour two different radii, so it is the shorter of the two:
//!   the blended path leaves A no earlier and joins B no later than asked.
//! - 12 CORNER_DISTANCE_1R, `parameter[0]` = radius: as 10 with both radii the same.
//!
//! Fractions above 1 count as 1; negative or non-finite parameters are refused.
//!
//! # Bounds
//!
//! The overlap starts at the earliest halfway through A and ends at the latest halfway
//! through B (the CODESYS rule); a parameter that asks for more is clipped to that, as JAKA
//! falls back to a 100 % ramp overlap for parameters too large. It also starts no earlier
//! than the caller's `earliest_start` (what the servo has been sent already cannot change).
//!
//! The sum must keep the joint limits: positions within the mechanical and SW limits of both
//! commands, velocity within the joint velocity limits, and acceleration with room left for
//! the time scale to change as fast as the moves' own override rate allows (at least at the
//! rate [`MIN_BRAKING_SHARE`] of the acceleration limits pays for at full speed, which a stop
//! on the blended path brakes with): `|q̈| + ω·|q̇| ≤ a` at every point, as each move's own
//! plan keeps it. They are checked at points of the overlap at most [`CHECK_STEP_S`] apart,
//! with margins for what may lie between the samples where both moves move a joint (each
//! move's joint jerk is within the jerk limit, so the sum's within twice that; a joint only
//! one of them moves keeps the limits of that move's own plan). If the sum exceeds a limit,
//! the overlap shrinks (a bisection) down to an exact stop. The smallest free acceleration
//! over the joint speed at any point is the rate at which the override may change (and a
//! stop brake) during the overlap.
//!
//! Where both moves are Cartesian, the speeds of their TCPs add up as well (two lines on in
//! the same direction, B speeding up while A still cruises): the TCP of each, on the
//! blended joints, keeps the higher of the two moves' programmed speeds (their
//! VelocityRates of the TCP limit), sampled at the same points where both move, with a
//! margin for what the TCP jerk of both allows between them; beyond it the overlap shrinks
//! too. Two lines at an angle add their speeds as vectors, so where the first still cruises
//! at its speed the second cannot start: such an overlap begins in the first's braking ramp
//! at the earliest. A joint move keeps no TCP speed (nor does its TCP keep the robot's TCP
//! limit on its own), so a blend with one is bounded by the joint limits alone.
//!
//! The jerks of the two moves add up as well: where both change a joint's acceleration the
//! same way at their jerk limits (A easing its braking while B starts the joint on, say),
//! the sum reaches twice the limit (1.65 times in a joint → line → line → joint sequence).
//! Shrinking the overlap does not help, since the moves' jerk phases lie at A's end and B's
//! start, so the overlap runs slower instead: the jerk of the sum is sampled every [`JERK_STEP_S`], and where it exceeds a joint's jerk limit (of the
//! higher of the two moves' JerkRates) the overlap's time scale is held to
//! [`Overlap::max_scale`], at which `σ³·|q⃛_A + q⃛_B|` keeps it. Velocity and acceleration
//! only fall with σ. The time scale comes down to it before the overlap starts (see
//! [`motion`](crate::motion)).

use nalgebra::{Isometry3, Vector3};
use shared_types::config::JointLimitsRad;
use shared_types::ipc::{AXES, JointPoint, MotionCommand};
use shared_types::srci::message::code;

use crate::kinematics::Kinematics;
use crate::linear_move::TcpLimits;
use crate::motion::Path;

/// Largest time step (s) between the points at which the sum is checked against the limits.
pub const CHECK_STEP_S: f64 = 4e-3;
/// Fewest and most intervals of the checked overlap: longer overlaps are checked with
/// wider steps and accordingly wider margins, to bound the planning time.
const CHECK_SAMPLES: core::ops::RangeInclusive<usize> = 16..=32;
/// Relative slack of the limit checks against rounding.
const LIMIT_TOLERANCE: f64 = 1e-9;
/// Intervals of the joint chains that give each path evaluation its neighbouring turn.
const CHAIN_STEPS: usize = 32;
/// Bisection steps for a time on one move (one evaluation of the move per step).
const BISECTION_STEPS: usize = 30;
/// Bisection steps for the longest overlap within the joint limits (each step checks the
/// whole overlap; the result errs on the short side).
const OVERLAP_STEPS: usize = 6;
/// Shorter overlaps (equal shares of the longest within the limits) weighed against a
/// longest one that must slow down for its jerk.
const SHORTER_OVERLAPS: usize = 8;
/// Intervals per share of the grid the shorter overlaps' jerk is sampled on to weigh them
/// (the one taken is sampled in full).
const GRID_PER_SHARE: usize = 8;
/// Intervals of that grid.
const GRID: usize = SHORTER_OVERLAPS * GRID_PER_SHARE;
/// Bisection steps for the longest overlap within the corner deviation (each step samples
/// the whole overlap).
const DEVIATION_STEPS: usize = 10;
/// Time step (s) of the central difference that gives the blended TCP's speed.
const TCP_SPEED_STEP_S: f64 = 1e-4;
/// Overlaps shorter than this (s) are not worth a blend: exact stop.
const MIN_OVERLAP_S: f64 = 2e-3;
/// Share of the acceleration limits kept free for a stop on the blended path, whatever the
/// override reserve.
pub const MIN_BRAKING_SHARE: f64 = 0.1;
/// Time step (s) at which the jerk of the blended joints is sampled (the change of their
/// acceleration over it), at most [`JERK_SAMPLES`] of them over the overlap.
pub const JERK_STEP_S: f64 = 2e-3;
/// Most intervals the blended jerk is sampled in.
const JERK_SAMPLES: usize = 256;
/// Relative margin on a sampled blended jerk over the limit, for what lies between the
/// samples: the sampled change over one step is an average of the jerk over it.
const JERK_MARGIN: f64 = 0.05;
/// The lowest [`Overlap::max_scale`] two moves within their jerk limits give, their jerks
/// adding up to twice the limit: `(2·(1 + JERK_MARGIN))^(-1/3)` = 0.7809, rounded down.
pub const SLOWEST_SCALE: f64 = 0.78;

/// How a move blends into the next one: the SRCI BlendingMode with its parameters (SI
/// units; see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Blending {
    /// 0 EXACT_STOP.
    ExactStop,
    /// 2 DEFINED_VELOCITY: B starts when A has slowed to this fraction of its peak speed.
    DefinedVelocity { fraction: f64 },
    /// 3 CORNER_DISTANCE: B starts when A's TCP is within `radius` m of the corner.
    CornerDistance { radius: f64 },
    /// 4 MAX_CORNER_DEVIATION: the blended TCP passes the corner within `deviation` m.
    MaxCornerDeviation { deviation: f64 },
    /// 10 CORNER_DISTANCE_2R: leave A at `leave` m, join B at `join` m from the corner.
    CornerDistance2R { leave: f64, join: f64 },
    /// 11 RAMP_OVERLAP: this fraction of A's deceleration ramp overlaps B.
    RampOverlap { fraction: f64 },
    /// 12 CORNER_DISTANCE_1R: leave A and join B at `radius` m from the corner.
    CornerDistance1R { radius: f64 },
}

/// Why the blending of a command is refused; [`code`](Self::code) is the SRCI code.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum BlendingError {
    #[error("BlendingMode {0} is not defined")]
    UnknownMode(u8),
    #[error("BlendingParameter {0} is negative or not a number")]
    InvalidParameter(f64),
}

impl BlendingError {
    /// The SRCI message code reported for this error.
    pub fn code(&self) -> u16 {
        match self {
            Self::UnknownMode(_) => code::INVALID_BLENDING_MODE,
            Self::InvalidParameter(_) => code::INVALID_BLENDING_PARAMETER,
        }
    }
}

impl Blending {
    /// The blending of `command` (`blending_mode`, `blending_parameter`).
    pub fn of(command: &MotionCommand) -> Result<Self, BlendingError> {
        let [first, second] = command.blending_parameter;
        let used = match command.blending_mode {
            0 => return Ok(Self::ExactStop),
            10 => [first, second],
            2 | 3 | 4 | 11 | 12 => [first, 0.0],
            mode => return Err(BlendingError::UnknownMode(mode)),
        };
        if let Some(bad) = used.into_iter().find(|p| !(p.is_finite() && *p >= 0.0)) {
            return Err(BlendingError::InvalidParameter(bad));
        }
        Ok(match command.blending_mode {
            2 => Self::DefinedVelocity {
                fraction: first.min(1.0),
            },
            3 => Self::CornerDistance { radius: first },
            4 => Self::MaxCornerDeviation { deviation: first },
            10 => Self::CornerDistance2R {
                leave: first,
                join: second,
            },
            11 => Self::RampOverlap {
                fraction: first.min(1.0),
            },
            _ => Self::CornerDistance1R { radius: first },
        })
    }
}

/// One of the two moves of a blend, as the blend planner sees it. Times `tau` are those of
/// the move's profile at 100 % override.
pub trait Leg {
    /// Duration of the move's profile, s.
    fn duration(&self) -> f64;
    /// Path speed `ṡ` and acceleration `s̈` at `tau`.
    fn path_rate(&self, tau: f64) -> (f64, f64);
    /// The joints and their time derivatives at `tau`, the joints on the turns next to
    /// `previous`.
    fn joints(&self, tau: f64, previous: &[f64; AXES]) -> JointPoint;
    /// The position of the move's TCP (m, base frame) at the joints `q`.
    fn tcp(&self, q: &[f64; AXES]) -> Vector3<f64>;
    /// Largest rate of change of the override (1/s) the move's own reserve pays for.
    fn override_rate(&self) -> f64;
    /// The move's JerkRate: the share of the robot's jerk limits it keeps to.
    fn jerk_rate(&self) -> f64;
    /// The TCP limits a Cartesian move keeps (the robot's times its rates); none for a joint
    /// move.
    fn tcp_limits(&self) -> Option<TcpLimits>;
}

/// What a blend is planned from.
pub struct BlendRequest<'a, A: Leg, B: Leg> {
    /// The move blended out of (A).
    pub outgoing: &'a A,
    /// The move blended into (B); it starts where A ends.
    pub incoming: &'a B,
    /// A's blending.
    pub blending: Blending,
    /// The joints where A ends and B starts (the corner).
    pub corner: [f64; AXES],
    /// A's time before which the overlap must not start.
    pub earliest_start: f64,
    /// The joint limits of the robot, the positions narrowed to the SW limits of both moves.
    pub limits: &'a JointLimitsRad,
}

/// A planned blend: when it starts and how fast the time scale may change during it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Overlap {
    /// A's time at which B starts (`T_A − d`).
    pub start: f64,
    /// Largest rate of change of the override (1/s) during the overlap.
    pub override_rate: f64,
    /// Rate (1/s) at which a stop during the overlap brings the time scale to 0 within the
    /// joint limits.
    pub stop_rate: f64,
    /// Largest time scale σ during the overlap (1 where the blended jerk keeps the limits
    /// at full speed): `σ³·|q⃛_A + q⃛_B|` keeps every joint's jerk limit.
    pub max_scale: f64,
}

/// Plans the overlap of `request`; `None` means an exact stop.
pub fn plan<A: Leg, B: Leg>(request: &BlendRequest<'_, A, B>) -> Option<Overlap> {
    if request.blending == Blending::ExactStop {
        return None;
    }
    let (end_a, end_b) = (request.outgoing.duration(), request.incoming.duration());
    let longest = (0.5 * end_a)
        .min(0.5 * end_b)
        .min(end_a - request.earliest_start);
    // A NaN duration compares false, as too short.
    if longest.partial_cmp(&MIN_OVERLAP_S) != Some(core::cmp::Ordering::Greater) {
        return None;
    }
    let sampler = Sampler::new(request, longest);
    let wanted = sampler.wanted_overlap().clamp(0.0, longest);
    // The longest overlap within the limits (an exact stop always keeps them).
    let longest_kept = longest_within(wanted, OVERLAP_STEPS, |d| sampler.check(d).is_some());
    let planned = |overlap: f64| {
        let stop_rate = sampler.check(overlap)?;
        (overlap >= MIN_OVERLAP_S).then(|| Overlap {
            start: end_a - overlap,
            // Override changes as fast as the moves' own, if the blend allows.
            override_rate: stop_rate
                .min(request.outgoing.override_rate())
                .min(request.incoming.override_rate()),
            stop_rate,
            max_scale: sampler.max_scale(overlap),
        })
    };
    let longer = planned(longest_kept)?;
    if longer.max_scale >= 1.0 {
        return Some(longer);
    }
    // A longer overlap takes in more of both moves' jerk phases: a shorter one that needs
    // less of a slow-down may save more time than the longer one slowed. The time scale
    // ramps at the moves' own override rates.
    let ramp_rate = request
        .outgoing
        .override_rate()
        .min(request.incoming.override_rate());
    let longer_saving = time_saved(longest_kept, longer.max_scale, ramp_rate);
    let (mut best, mut saving) = (longest_kept, longer_saving);
    let scales = sampler.shorter_max_scales(longest_kept);
    for (k, &max_scale) in scales.iter().enumerate().skip(1) {
        let overlap = longest_kept * k as f64 / SHORTER_OVERLAPS as f64;
        let candidate = time_saved(overlap, max_scale, ramp_rate);
        if candidate > saving {
            (best, saving) = (overlap, candidate);
        }
    }
    if best >= longest_kept {
        return Some(longer);
    }
    // The shorter one as sampled in full must still save more.
    match planned(best) {
        Some(shorter) if time_saved(best, shorter.max_scale, ramp_rate) > longer_saving => {
            Some(shorter)
        }
        _ => Some(longer),
    }
}

/// Time (s) an overlap of `length` run at the time scale `max_scale` saves against an exact
/// stop, estimated: its length, less what running it at that scale costs, and the ramps of
/// the time scale down to that and back at `ramp_rate` (1/s; the ramps' own jerk-limited
/// rounding left out).
fn time_saved(length: f64, max_scale: f64, ramp_rate: f64) -> f64 {
    if max_scale >= 1.0 {
        return length;
    }
    let ramps = (1.0 - max_scale).powi(2) / ramp_rate;
    length - length * (1.0 / max_scale - 1.0) - ramps
}

/// Joints along one move at equal time steps, to give each path evaluation a neighbour.
struct Chain {
    first: f64,
    step: f64,
    q: [[f64; AXES]; CHAIN_STEPS + 1],
}

impl Chain {
    /// The joints of `leg` on `[first, first + span]`, followed from `anchor` at the end
    /// `from_end` (backwards) or at the start.
    fn follow(leg: &impl Leg, first: f64, span: f64, anchor: [f64; AXES], from_end: bool) -> Self {
        let mut chain = Self {
            first,
            step: span / CHAIN_STEPS as f64,
            q: [anchor; CHAIN_STEPS + 1],
        };
        let mut previous = anchor;
        for k in 0..=CHAIN_STEPS {
            let index = if from_end { CHAIN_STEPS - k } else { k };
            previous = leg.joints(chain.time(index), &previous).q;
            chain.q[index] = previous;
        }
        chain
    }

    fn time(&self, index: usize) -> f64 {
        self.first + self.step * index as f64
    }

    /// The chained joints nearest `tau`.
    fn near(&self, tau: f64) -> &[f64; AXES] {
        let index = ((tau - self.first) / self.step).round();
        // Saturating float-to-int conversion; NaN gives 0.
        &self.q[(index.max(0.0) as usize).min(CHAIN_STEPS)]
    }
}

/// The blend's two moves, followed over the longest overlap.
struct Sampler<'a, A: Leg, B: Leg> {
    request: &'a BlendRequest<'a, A, B>,
    end_a: f64,
    longest: f64,
    chain_a: Chain,
    chain_b: Chain,
    corner_tcp: Vector3<f64>,
}

impl<'a, A: Leg, B: Leg> Sampler<'a, A, B> {
    fn new(request: &'a BlendRequest<'a, A, B>, longest: f64) -> Self {
        let end_a = request.outgoing.duration();
        let corner = request.corner;
        Self {
            request,
            end_a,
            longest,
            chain_a: Chain::follow(request.outgoing, end_a - longest, longest, corner, true),
            chain_b: Chain::follow(request.incoming, 0.0, longest, corner, false),
            corner_tcp: request.outgoing.tcp(&corner),
        }
    }

    fn outgoing(&self, tau: f64) -> JointPoint {
        self.request.outgoing.joints(tau, self.chain_a.near(tau))
    }

    fn incoming(&self, tau: f64) -> JointPoint {
        self.request.incoming.joints(tau, self.chain_b.near(tau))
    }

    /// The points of both moves `u` into an overlap of `overlap`.
    fn legs(&self, overlap: f64, u: f64) -> (JointPoint, JointPoint) {
        (self.outgoing(self.end_a - overlap + u), self.incoming(u))
    }

    /// The blended joints `u` into an overlap of `overlap`.
    fn blended(&self, overlap: f64, u: f64) -> [f64; AXES] {
        let (a, b) = self.legs(overlap, u);
        let c = &self.request.corner;
        core::array::from_fn(|i| a.q[i] + b.q[i] - c[i])
    }

    /// The overlap the blending asks for (before the limits; may exceed the longest).
    fn wanted_overlap(&self) -> f64 {
        let first = self.end_a - self.longest;
        let leg = self.request.outgoing;
        match self.request.blending {
            Blending::ExactStop => 0.0,
            Blending::RampOverlap { fraction } => {
                // The deceleration ramp: where s̈ turns negative for good.
                let braking = earliest(first, self.end_a, |t| leg.path_rate(t).1 < 0.0);
                fraction * (self.end_a - braking)
            }
            Blending::DefinedVelocity { fraction } => {
                let peak = (0..=2 * CHAIN_STEPS)
                    .map(|k| {
                        leg.path_rate(self.end_a * k as f64 / (2 * CHAIN_STEPS) as f64)
                            .0
                    })
                    .fold(0.0, f64::max);
                let slowed = earliest(first, self.end_a, |t| leg.path_rate(t).0 <= fraction * peak);
                self.end_a - slowed
            }
            Blending::CornerDistance { radius } => self.leave_overlap(radius),
            Blending::CornerDistance2R { leave, join } => {
                self.leave_overlap(leave).min(self.join_overlap(join))
            }
            Blending::CornerDistance1R { radius } => {
                self.leave_overlap(radius).min(self.join_overlap(radius))
            }
            Blending::MaxCornerDeviation { deviation } => {
                longest_within(self.longest, DEVIATION_STEPS, |d| {
                    self.deviation(d) <= deviation
                })
            }
        }
    }

    /// The overlap that starts where A's TCP comes within `radius` of the corner.
    fn leave_overlap(&self, radius: f64) -> f64 {
        let leg = self.request.outgoing;
        let first = self.end_a - self.longest;
        let within = earliest(first, self.end_a, |t| {
            (leg.tcp(&self.outgoing(t).q) - self.corner_tcp).norm() <= radius
        });
        self.end_a - within
    }

    /// The overlap that ends where B's TCP is `radius` from the corner.
    fn join_overlap(&self, radius: f64) -> f64 {
        let leg = self.request.incoming;
        let corner = leg.tcp(&self.request.corner);
        // The last time B is still inside the radius: when it reaches it.
        longest_within(self.longest, BISECTION_STEPS, |t| {
            (leg.tcp(&self.incoming(t).q) - corner).norm() < radius
        })
    }

    /// How close the blended TCP of an overlap of `overlap` passes the corner (m).
    fn deviation(&self, overlap: f64) -> f64 {
        let leg = self.request.outgoing;
        let samples = samples(overlap);
        (0..=samples)
            .map(|k| {
                let q = self.blended(overlap, overlap * k as f64 / samples as f64);
                (leg.tcp(&q) - self.corner_tcp).norm()
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// The largest time scale at which the blended jerk of an overlap of `overlap` keeps
    /// every joint's jerk limit times the higher of the two moves' JerkRates; 1 where it
    /// does at full speed.
    fn max_scale(&self, overlap: f64) -> f64 {
        let wanted = (overlap / JERK_STEP_S).ceil();
        // Saturating float-to-int conversion; NaN gives 0.
        let steps = (wanted.max(1.0) as usize).min(JERK_SAMPLES);
        let h = overlap / steps as f64;
        scale_for_jerk(self.jerk_ratio(steps, h, |k| {
            let (a, b) = self.legs(overlap, h * k as f64);
            core::array::from_fn(|i| a.qdd[i] + b.qdd[i])
        }))
    }

    /// The largest blended jerk over `steps` intervals of `h`, from the summed accelerations
    /// `acceleration(k)` at their ends, over the jerk limits times the higher of the two
    /// moves' JerkRates.
    fn jerk_ratio(&self, steps: usize, h: f64, acceleration: impl Fn(usize) -> [f64; AXES]) -> f64 {
        let jerk_rate = self
            .request
            .outgoing
            .jerk_rate()
            .max(self.request.incoming.jerk_rate());
        let limit = self.request.limits.jerk.map(|j| jerk_rate * j);
        let mut last = acceleration(0);
        let mut ratio = 0.0f64;
        for k in 1..=steps {
            let next = acceleration(k);
            for i in 0..AXES {
                ratio = ratio.max((next[i] - last[i]).abs() / h / limit[i]);
            }
            last = next;
        }
        ratio
    }

    /// [`max_scale`](Self::max_scale) of the overlaps of `k/SHORTER_OVERLAPS` of `longest`
    /// at index `k` (index 0, no overlap, is 1), from each move's accelerations sampled once
    /// on a grid the overlaps share ([`GRID`] intervals over `longest`, coarser than
    /// [`JERK_STEP_S`] for long overlaps; enough to weigh them): an overlap of `d` pairs A at
    /// `T_A − d + u` with B at `u`, both on the grid where `d` is a multiple of its step.
    fn shorter_max_scales(&self, longest: f64) -> [f64; SHORTER_OVERLAPS] {
        let h = longest / GRID as f64;
        let first = self.end_a - longest;
        let a: [[f64; AXES]; GRID + 1] =
            core::array::from_fn(|m| self.outgoing(first + h * m as f64).qdd);
        let b: [[f64; AXES]; GRID + 1] = core::array::from_fn(|m| self.incoming(h * m as f64).qdd);
        core::array::from_fn(|k| {
            let steps = k * GRID_PER_SHARE;
            let start = GRID - steps;
            scale_for_jerk(self.jerk_ratio(steps, h, |n| {
                core::array::from_fn(|i| a[start + n][i] + b[n][i])
            }))
        })
    }

    /// Whether the overlap `overlap` keeps the limits; if so, the rate (1/s) at which the
    /// time scale may change during it.
    fn check(&self, overlap: f64) -> Option<f64> {
        let l = self.request.limits;
        // The rate of σ the overlap must leave room for: the moves' own override rate, and
        // at least what a stop brakes with.
        let floor = (0..AXES).fold(f64::INFINITY, |r, i| {
            r.min(MIN_BRAKING_SHARE * l.acceleration[i] / l.velocity[i])
        });
        let kept_rate = self
            .request
            .outgoing
            .override_rate()
            .min(self.request.incoming.override_rate())
            .max(floor);
        let mut rate = f64::INFINITY;
        let samples = samples(overlap);
        let h = overlap / samples as f64;
        let corner = &self.request.corner;
        let tcp_bound = self.tcp_speed_bound();
        for k in 0..=samples {
            let (a, b) = self.legs(overlap, h * k as f64);
            // Where one move stands, the other's own plan keeps its TCP speed.
            let moving = |p: &JointPoint| p.qd.iter().any(|v| *v != 0.0);
            if let Some((speed, jerk)) = tcp_bound.filter(|_| moving(&a) && moving(&b)) {
                let q = core::array::from_fn(|i| a.q[i] + b.q[i] - corner[i]);
                let qd = core::array::from_fn(|i| a.qd[i] + b.qd[i]);
                // Between samples the speed may rise by what the jerk of both allows.
                let margin = jerk * h * h / 8.0;
                if self.tcp_speed(&q, &qd) + margin > speed * (1.0 + LIMIT_TOLERANCE) {
                    return None;
                }
            }
            for (i, corner) in corner.iter().enumerate() {
                let q = a.q[i] + b.q[i] - corner;
                // Between samples: the chord error of q (|q̈| ≤ a) and, where both move the
                // joint, of q̇ (|q⃛| ≤ 2j) and the change of q̈.
                let q_margin = l.acceleration[i] * h * h / 8.0;
                let both = a.qd[i] != 0.0 && b.qd[i] != 0.0;
                let (v_margin, a_margin) = if both {
                    (l.jerk[i] * h * h / 4.0, l.jerk[i] * h)
                } else {
                    (0.0, 0.0)
                };
                let velocity = (a.qd[i] + b.qd[i]).abs() + v_margin;
                let acceleration = (a.qdd[i] + b.qdd[i]).abs() + a_margin;
                let tolerance = 1.0 + LIMIT_TOLERANCE;
                let ok = q >= l.min[i] + q_margin
                    && q <= l.max[i] - q_margin
                    && velocity <= l.velocity[i] * tolerance
                    && acceleration + kept_rate * velocity <= l.acceleration[i] * tolerance;
                if !ok {
                    return None;
                }
                // |q̈| ≤ σ²·|q̈_sum| + |σ̇|·|q̇_sum| ≤ a while |σ̇| ≤ (a − |q̈_sum|)/|q̇_sum|,
                // with what |q̈_sum| and |q̇_sum| may reach within half a step of the sample
                // (the margins above cover the acceleration of a joint both moves move).
                if velocity > 0.0 {
                    let (legs, jerk_margin) = if both {
                        (2.0, 0.0)
                    } else {
                        (1.0, 0.5 * l.jerk[i] * h)
                    };
                    let room = l.acceleration[i] - acceleration - jerk_margin;
                    let fastest = velocity + legs * 0.5 * l.acceleration[i] * h;
                    rate = rate.min(room.max(0.0) / fastest);
                }
            }
        }
        Some(rate)
    }

    /// The TCP speed (m/s) a blend of two Cartesian moves keeps, the higher of the two
    /// moves' own, and the sum of their TCP jerk limits (m/s³); none where a joint move takes
    /// part (it keeps no TCP speed).
    fn tcp_speed_bound(&self) -> Option<(f64, f64)> {
        let a = self.request.outgoing.tcp_limits()?;
        let b = self.request.incoming.tcp_limits()?;
        Some((a.velocity.max(b.velocity), a.jerk + b.jerk))
    }

    /// The speed (m/s) of either move's TCP at the joints `q` moving at `qd`: the larger.
    fn tcp_speed(&self, q: &[f64; AXES], qd: &[f64; AXES]) -> f64 {
        let along = |dt: f64| core::array::from_fn(|i| q[i] + qd[i] * dt);
        let (before, after) = (along(-TCP_SPEED_STEP_S), along(TCP_SPEED_STEP_S));
        let speed = |leg: &dyn Fn(&[f64; AXES]) -> Vector3<f64>| {
            (leg(&after) - leg(&before)).norm() / (2.0 * TCP_SPEED_STEP_S)
        };
        speed(&|q| self.request.outgoing.tcp(q)).max(speed(&|q| self.request.incoming.tcp(q)))
    }
}

/// The time scale at which a blended jerk of `ratio` times the limit keeps it: one move
/// alone keeps its limit, so only a sum beyond it slows the overlap down (a NaN ratio, of no
/// jerk limit, compares false).
fn scale_for_jerk(ratio: f64) -> f64 {
    if ratio > 1.0 + LIMIT_TOLERANCE {
        (ratio * (1.0 + JERK_MARGIN)).cbrt().recip()
    } else {
        1.0
    }
}

/// Intervals an overlap of `overlap` s is checked in.
fn samples(overlap: f64) -> usize {
    let wanted = (overlap / CHECK_STEP_S).ceil();
    // Saturating float-to-int conversion; NaN gives 0.
    (wanted.max(0.0) as usize).clamp(*CHECK_SAMPLES.start(), *CHECK_SAMPLES.end())
}

/// The earliest time in `[low, high]` from which `holds` is true up to `high` (a predicate
/// true at `low` gives `low`).
fn earliest(low: f64, high: f64, holds: impl Fn(f64) -> bool) -> f64 {
    if holds(low) {
        return low;
    }
    boundary(low, high, BISECTION_STEPS, |t| !holds(t))
}

/// The largest value in `[0, high]` up to which `holds` is true (`high` itself if it holds
/// there), assuming it holds at 0.
fn longest_within(high: f64, steps: usize, holds: impl Fn(f64) -> bool) -> f64 {
    if holds(high) {
        high
    } else {
        boundary(0.0, high, steps, holds)
    }
}

/// Where in `[low, high]` `holds` turns from true to false, by `steps` bisections; the
/// value returned is one at which it was found true (or `low`).
fn boundary(mut low: f64, mut high: f64, steps: usize, holds: impl Fn(f64) -> bool) -> f64 {
    for _ in 0..steps {
        let mid = 0.5 * (low + high);
        if holds(mid) {
            low = mid;
        } else {
            high = mid;
        }
    }
    low
}

/// A planned move as a [`Leg`] of a blend: its path, and the TCP of its tool.
pub struct PathLeg<'a> {
    pub path: &'a Path,
    pub kinematics: &'a Kinematics,
    /// The move's tool (TCP in the flange frame).
    pub tool: Isometry3<f64>,
}

impl Leg for PathLeg<'_> {
    fn duration(&self) -> f64 {
        self.path.timing().profile.duration()
    }

    fn path_rate(&self, tau: f64) -> (f64, f64) {
        let (_, sd, sdd) = self.path.timing().profile.eval(tau);
        (sd, sdd)
    }

    fn joints(&self, tau: f64, previous: &[f64; AXES]) -> JointPoint {
        let (s, sd, sdd) = self.path.timing().profile.eval(tau);
        self.path.point(s, sd, sdd, previous)
    }

    fn tcp(&self, q: &[f64; AXES]) -> Vector3<f64> {
        (self.kinematics.flange(q) * self.tool).translation.vector
    }

    fn override_rate(&self) -> f64 {
        self.path.timing().override_rate
    }

    fn jerk_rate(&self) -> f64 {
        self.path.timing().jerk_rate
    }

    fn tcp_limits(&self) -> Option<TcpLimits> {
        match self.path {
            Path::Joint(_) => None,
            Path::Linear(m) => Some(*m.tcp_limits()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared_types::config::Config;
    use shared_types::ipc::MotionCommandKind;

    use crate::joint_move::{JointMove, Plan};

    const RESERVE: f64 = 0.2;

    fn config() -> Config {
        Config::load(None).expect("embedded configuration")
    }

    fn home() -> [f64; AXES] {
        config().robot.home_deg.map(f64::to_radians)
    }

    fn joint_path(start: [f64; AXES], target: [f64; AXES]) -> Path {
        let mut c = MotionCommand::new(MotionCommandKind::MoveAxes);
        c.joints_rad = target;
        match JointMove::plan(start, &c, &config().robot.limits_rad(), RESERVE) {
            Ok(Plan::Move(m)) => Path::Joint(m),
            other => panic!("{other:?}"),
        }
    }

    fn shifted(q: [f64; AXES], delta: [f64; AXES]) -> [f64; AXES] {
        core::array::from_fn(|i| q[i] + delta[i])
    }

    /// A corner: home → A's end → B's end, the legs moving different joints.
    fn corner() -> (Path, Path) {
        let a_end = shifted(home(), [0.8, 0.0, 0.0, 0.0, 0.0, 0.3]);
        let b_end = shifted(a_end, [0.0, 0.6, 0.9, 0.4, 0.0, 0.0]);
        (joint_path(home(), a_end), joint_path(a_end, b_end))
    }

    /// The overlap `blending` gives the corner of `a` into `b`, with the robot's limits.
    fn overlap(a: &Path, b: &Path, blending: Blending) -> Option<Overlap> {
        overlap_after(a, b, blending, 0.0)
    }

    /// [`overlap`], starting no earlier than `earliest_start`.
    fn overlap_after(
        a: &Path,
        b: &Path,
        blending: Blending,
        earliest_start: f64,
    ) -> Option<Overlap> {
        let cfg = config();
        let kinematics = Kinematics::new(&cfg.robot.kinematics);
        let leg = |path| PathLeg {
            path,
            kinematics: &kinematics,
            tool: Isometry3::identity(),
        };
        plan(&BlendRequest {
            outgoing: &leg(a),
            incoming: &leg(b),
            blending,
            corner: a.target(),
            earliest_start,
            limits: &cfg.robot.limits_rad(),
        })
    }

    fn duration(path: &Path) -> f64 {
        path.timing().profile.duration()
    }

    fn tcp(q: &[f64; AXES]) -> Vector3<f64> {
        Kinematics::new(&config().robot.kinematics)
            .flange(q)
            .translation
            .vector
    }

    fn at(path: &Path, tau: f64) -> [f64; AXES] {
        let (s, _, _) = path.timing().profile.eval(tau);
        path.point(s, 0.0, 0.0, &path.target()).q
    }

    #[test]
    fn modes_and_parameters_are_decoded_and_checked() {
        let mut c = MotionCommand::new(MotionCommandKind::MoveAxes);
        assert_eq!(Blending::of(&c), Ok(Blending::ExactStop));
        c.blending_mode = 11;
        c.blending_parameter = [1.5, -7.0];
        assert_eq!(
            Blending::of(&c),
            Ok(Blending::RampOverlap { fraction: 1.0 })
        );
        c.blending_mode = 10;
        assert_eq!(
            Blending::of(&c).map_err(|e| e.code()),
            Err(code::INVALID_BLENDING_PARAMETER)
        );
        c.blending_parameter = [0.05, 0.02];
        assert_eq!(
            Blending::of(&c),
            Ok(Blending::CornerDistance2R {
                leave: 0.05,
                join: 0.02
            })
        );
        c.blending_mode = 3;
        c.blending_parameter = [f64::NAN, 0.0];
        assert_eq!(
            Blending::of(&c).map_err(|e| e.code()),
            Err(code::INVALID_BLENDING_PARAMETER)
        );
        c.blending_mode = 1;
        assert_eq!(
            Blending::of(&c).map_err(|e| e.code()),
            Err(code::INVALID_BLENDING_MODE)
        );
    }

    #[test]
    fn a_full_ramp_overlap_starts_the_next_move_when_the_first_brakes() {
        let (a, b) = corner();
        let o = overlap(&a, &b, Blending::RampOverlap { fraction: 1.0 }).unwrap();
        let profile = a.timing().profile;
        // Before the start A cruises (or accelerates); after it, it brakes.
        assert!(profile.eval(o.start - 1e-4).2 >= 0.0);
        assert!(profile.eval(o.start + 1e-4).2 < 0.0);
        let half = overlap(&a, &b, Blending::RampOverlap { fraction: 0.5 }).unwrap();
        let ramp = duration(&a) - o.start;
        assert!((duration(&a) - half.start - 0.5 * ramp).abs() < 1e-6);
        assert!(o.override_rate > 0.0 && o.stop_rate > 0.0);
    }

    #[test]
    fn a_defined_velocity_starts_the_next_move_at_that_share_of_the_peak_speed() {
        let (a, b) = corner();
        let o = overlap(&a, &b, Blending::DefinedVelocity { fraction: 0.3 }).unwrap();
        let profile = a.timing().profile;
        let peak = (0..=10_000)
            .map(|k| profile.eval(duration(&a) * k as f64 / 10_000.0).1)
            .fold(0.0, f64::max);
        let speed = profile.eval(o.start).1;
        assert!((speed - 0.3 * peak).abs() < 1e-3 * peak, "{speed} {peak}");
    }

    #[test]
    fn corner_distances_leave_and_join_at_their_radii() {
        let (a, b) = corner();
        let corner_tcp = tcp(&a.target());
        let leave = overlap(&a, &b, Blending::CornerDistance { radius: 0.03 }).unwrap();
        let distance = (tcp(&at(&a, leave.start)) - corner_tcp).norm();
        assert!((distance - 0.03).abs() < 1e-6, "{distance}");
        // Joining at a smaller radius than leaving: the join decides.
        let two = Blending::CornerDistance2R {
            leave: 0.03,
            join: 0.01,
        };
        let joined = overlap(&a, &b, two).unwrap();
        let into_b = duration(&a) - joined.start;
        let distance = (tcp(&at(&b, into_b)) - corner_tcp).norm();
        assert!((distance - 0.01).abs() < 1e-6, "{distance}");
        let one = overlap(&a, &b, Blending::CornerDistance1R { radius: 0.03 }).unwrap();
        assert!(one.start >= leave.start - 1e-9);
    }

    #[test]
    fn the_max_corner_deviation_bounds_how_far_the_blend_passes_the_corner() {
        let (a, b) = corner();
        let o = overlap(&a, &b, Blending::MaxCornerDeviation { deviation: 0.004 }).unwrap();
        let d = duration(&a) - o.start;
        let corner_tcp = tcp(&a.target());
        let closest = (0..=200)
            .map(|k| {
                let u = d * k as f64 / 200.0;
                let (qa, qb) = (at(&a, o.start + u), at(&b, u));
                let q = core::array::from_fn(|i| qa[i] + qb[i] - a.target()[i]);
                (tcp(&q) - corner_tcp).norm()
            })
            .fold(f64::INFINITY, f64::min);
        assert!((closest - 0.004).abs() < 2e-4, "{closest}");
    }

    #[test]
    fn the_overlap_is_clipped_to_half_of_either_move() {
        let (a, _) = corner();
        let short = joint_path(
            a.target(),
            shifted(a.target(), [0.0, 0.0, 0.0, 0.0, 0.0, 0.05]),
        );
        let o = overlap(&a, &short, Blending::RampOverlap { fraction: 1.0 }).unwrap();
        assert!((duration(&a) - o.start - 0.5 * duration(&short)).abs() < 1e-12);
        let wide = overlap(&a, &short, Blending::CornerDistance { radius: 10.0 }).unwrap();
        assert_eq!(wide.start, o.start);
        let (a, b) = corner();
        let o = overlap(&a, &b, Blending::CornerDistance { radius: 10.0 }).unwrap();
        let half = 0.5 * duration(&a).min(duration(&b));
        assert!((duration(&a) - o.start - half).abs() < 1e-12);
    }

    #[test]
    fn a_blend_over_the_limits_shrinks_and_a_late_one_is_dropped() {
        // Joint 0 on, in the same direction at full speed: the speeds would add up.
        let a_end = shifted(home(), [1.5, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let a = joint_path(home(), a_end);
        let b = joint_path(a_end, shifted(a_end, [1.5, 0.0, 0.0, 0.0, 0.0, 0.0]));
        // Asking for half of each move: B would speed up while A still cruises.
        let o = overlap(&a, &b, Blending::CornerDistance { radius: 10.0 }).unwrap();
        let d = duration(&a) - o.start;
        assert!(d > 0.0 && d < 0.5 * duration(&a) - 1e-3, "{d}");
        let limits = config().robot.limits_rad();
        for k in 0..=400 {
            let u = d * k as f64 / 400.0;
            let (s, sd, _) = a.timing().profile.eval(o.start + u);
            let (sb, sdb, _) = b.timing().profile.eval(u);
            let speed = a.point(s, sd, 0.0, &a_end).qd[0] + b.point(sb, sdb, 0.0, &a_end).qd[0];
            assert!(speed <= limits.velocity[0] * (1.0 + 1e-9), "{speed}");
        }
        // Nothing can start before the overlap would end.
        let ramp = Blending::RampOverlap { fraction: 1.0 };
        assert_eq!(overlap_after(&a, &b, ramp, duration(&a) - 1e-3), None);
    }

    /// The blended jerk of an overlap at 100 % override: the largest change over 1 ms of
    /// the summed accelerations of both moves, relative to each joint's jerk limit.
    fn blended_jerk(a: &Path, b: &Path, overlap: &Overlap) -> f64 {
        let limits = config().robot.limits_rad();
        let step = 1e-3;
        let acceleration = |u: f64| -> [f64; AXES] {
            let qdd = |path: &Path, tau: f64| {
                let (s, sd, sdd) = path.timing().profile.eval(tau);
                path.point(s, sd, sdd, &path.target()).qdd
            };
            let (qa, qb) = (qdd(a, overlap.start + u), qdd(b, u));
            core::array::from_fn(|i| qa[i] + qb[i])
        };
        let steps = ((duration(a) - overlap.start) / step) as usize;
        (0..steps)
            .flat_map(|k| {
                let (now, next) = (
                    acceleration(k as f64 * step),
                    acceleration((k + 1) as f64 * step),
                );
                (0..AXES).map(move |i| (next[i] - now[i]).abs() / step / limits.jerk[i])
            })
            .fold(0.0, f64::max)
    }

    /// The rate at which a stop brakes the time scale during an overlap leaves every joint
    /// within its acceleration limit between the check's samples too: checked here every
    /// 0.1 ms (taken at the check's points alone, where a joint one move brakes near its
    /// limit, it came out at 0.839/s in this corner against 0.801/s that keep the limit).
    #[test]
    fn the_stop_rate_keeps_the_acceleration_limit_between_the_samples() {
        let limits = config().robot.limits_rad();
        let (a, b) = corner();
        let o = overlap(&a, &b, Blending::RampOverlap { fraction: 1.0 }).expect("blends");
        let point = |path: &Path, tau: f64| {
            let (s, sd, sdd) = path.timing().profile.eval(tau);
            path.point(s, sd, sdd, &path.target())
        };
        let length = duration(&a) - o.start;
        let steps = (length / 1e-4) as usize;
        let room = (0..=steps)
            .flat_map(|k| {
                let u = length * k as f64 / steps as f64;
                let (pa, pb) = (point(&a, o.start + u), point(&b, u));
                (0..AXES).map(move |i| {
                    let velocity = (pa.qd[i] + pb.qd[i]).abs();
                    let acceleration = (pa.qdd[i] + pb.qdd[i]).abs();
                    (limits.acceleration[i] - acceleration) / velocity
                })
            })
            .fold(f64::INFINITY, f64::min);
        assert!(o.stop_rate <= room, "{} {room}", o.stop_rate);
    }

    /// Two joint moves of a random sweep blended by a corner distance of 90 mm: the longest
    /// overlap within the limits that the distance asks for adds the moves' jerks up to
    /// about twice the limit and would have to run at σ = 0.78; a shorter one keeps the
    /// limit at full speed and saves more time (the overlap taken was 0.181 s at σ = 0.78
    /// before the shorter overlaps were weighed, and the pair took 1300 ticks instead of
    /// 1177 in the executor).
    #[test]
    fn a_shorter_overlap_is_taken_where_the_longest_would_have_to_slow_down() {
        let first = shifted(home(), [0.5168, -0.3301, 0.213, -0.4326, 0.0644, -0.2849]);
        let second = shifted(
            home(),
            [-0.1348, -0.5134, -0.4181, -0.2194, -0.1764, 0.3249],
        );
        let (a, b) = (joint_path(home(), first), joint_path(first, second));
        let o = overlap(&a, &b, Blending::CornerDistance { radius: 0.0902 }).expect("blends");
        assert_eq!(o.max_scale, 1.0);
        assert!(blended_jerk(&a, &b, &o) <= 1.0 + 1e-6);
        let taken = duration(&a) - o.start;
        assert!(taken > 0.1, "{taken}");
        let longer = Overlap {
            start: duration(&a) - 1.15 * taken,
            ..o
        };
        assert!(blended_jerk(&a, &b, &longer) > 1.5);
    }

    /// Where A eases its braking of a joint at its jerk limit while B starts the same joint
    /// at its jerk limit, their jerks add up to twice the limit: the overlap runs at a
    /// scale at which the sum keeps it (not much slower), and a corner whose moves turn
    /// different joints keeps full speed.
    #[test]
    fn jerks_that_add_up_slow_the_overlap_down() {
        let a_end = shifted(home(), [0.8, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let a = joint_path(home(), a_end);
        let b = joint_path(a_end, shifted(a_end, [0.8, 0.0, 0.0, 0.0, 0.0, 0.0]));
        let half_ramp = Blending::RampOverlap { fraction: 0.5 };
        let o = overlap(&a, &b, half_ramp).expect("blends");
        let jerk = blended_jerk(&a, &b, &o);
        assert!(jerk > 1.9, "{jerk}");
        let kept = jerk * o.max_scale.powi(3);
        assert!((0.9..=1.0).contains(&kept), "{} {jerk}", o.max_scale);

        let (a, b) = corner();
        let o = overlap(&a, &b, half_ramp).expect("blends");
        assert!(blended_jerk(&a, &b, &o) <= 1.0 + 1e-9);
        assert_eq!(o.max_scale, 1.0);
    }
}
