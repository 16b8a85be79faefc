//! The simulated drives of the 6-axis arm: power and enable sequencing, ideal tracking of the
//! planner's setpoints with plausibility checks, and the controlled stop.
//!
//! Pure: time is the servo tick number, nothing here reads a clock, does I/O or allocates.

use shared_types::config::{Config, JointLimitsRad};
use shared_types::ipc::{AXES, DriveState, JointPoint, ServoControl, ServoSetpoint};
use shared_types::srci::message::code;

/// Tolerance of the joint position limit check, so a point planned exactly onto a limit
/// survives floating-point rounding.
const POSITION_EPSILON_RAD: f64 = 1e-6;
/// Factor over the joint velocity limit a setpoint may have before it counts as implausible.
const VELOCITY_TOLERANCE: f64 = 1.05;
/// Slack of the jump check on top of the velocity-limited travel of one tick.
const JUMP_SLACK_RAD: f64 = 1e-6;
/// Largest distance (per joint) between the standing arm and a setpoint that continues from it.
pub const HOLD_CONTINUITY_RAD: f64 = 1e-4;
/// Most state changes one tick can make (control, setpoint, stop completion).
const MAX_TRANSITIONS_PER_TICK: usize = 4;

/// Timing and limits of the simulated drives, in servo ticks and SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriveParams {
    /// Joint limits of the robot.
    pub limits: JointLimitsRad,
    /// Servo period, s.
    pub period_s: f64,
    /// Ticks from a power request to `Powered`.
    pub power_on_ticks: u64,
    /// Ticks from an enable request to `Holding`.
    pub enable_ticks: u64,
    /// Ticks without a fresh setpoint after which a moving arm is stopped (at least 1).
    pub setpoint_timeout_ticks: u64,
}

impl DriveParams {
    /// The parameters of `[servo]` and the robot's joint limits; delays round up to whole ticks.
    pub fn from_config(cfg: &Config) -> Self {
        let servo = &cfg.main.servo;
        let period_us = servo.period_us.max(1);
        let ticks = |ms: u64| ms.saturating_mul(1000).div_ceil(period_us);
        Self {
            limits: cfg.robot.limits_rad(),
            period_s: period_us as f64 * 1e-6,
            power_on_ticks: ticks(servo.power_on_delay_ms),
            enable_ticks: ticks(servo.enable_delay_ms),
            setpoint_timeout_ticks: ticks(servo.setpoint_timeout_ms).max(1),
        }
    }
}

/// Which plausibility check a setpoint failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MotionFault {
    /// The position lies outside the joint limits.
    PositionLimit { joint: usize },
    /// The velocity exceeds the joint velocity limit.
    VelocityLimit { joint: usize },
    /// The position moved further in one tick than the velocity limit allows.
    PositionJump { joint: usize },
}

impl MotionFault {
    /// The SRCI message code the drives report for this fault.
    pub fn code(self) -> u16 {
        code::MOTION_ERROR
    }
}

/// Why the drive state changed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cause {
    /// `ServoControl::power` became true.
    PowerRequested,
    /// The power-on delay elapsed.
    PoweredOn,
    /// `ServoControl::power` became false.
    PowerRemoved,
    /// `ServoControl::enable` became true while powered.
    EnableRequested,
    /// The enable delay elapsed.
    Enabled,
    /// `ServoControl::enable` became false.
    DisableRequested,
    /// A setpoint continuing from the standing arm arrived.
    SetpointAccepted,
    /// No fresh setpoint came within the setpoint timeout.
    SetpointTimeout,
    /// A controlled stop reached standstill.
    Stopped,
    /// A setpoint failed a plausibility check.
    Fault(MotionFault),
    /// The fault was acknowledged by a new `ServoControl::fault_reset`.
    FaultReset,
}

/// One change of the drive state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Transition {
    pub from: DriveState,
    pub to: DriveState,
    pub cause: Cause,
}

/// The state changes of one tick, in order.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Transitions {
    items: [Option<Transition>; MAX_TRANSITIONS_PER_TICK],
}

impl Transitions {
    fn push(&mut self, t: Transition) {
        if let Some(slot) = self.items.iter_mut().find(|s| s.is_none()) {
            *slot = Some(t);
        }
    }

    /// The changes in the order they happened.
    pub fn iter(&self) -> impl Iterator<Item = &Transition> {
        self.items.iter().flatten()
    }
}

/// The drives' state after a tick; the shell adds instance, time and overruns for the feedback.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriveStatus {
    /// Actual joint positions, rad.
    pub q: [f64; AXES],
    /// Actual joint velocities, rad/s.
    pub qd: [f64; AXES],
    pub state: DriveState,
    /// SRCI code of the pending fault, 0 = none.
    pub fault_code: u16,
    /// The last `ServoControl::seq` applied.
    pub control_seq: u64,
    /// Ticks while following with no setpoint for them, plus setpoints ignored while holding
    /// because they did not continue from the standing arm.
    pub setpoint_misses: u64,
}

/// What one tick did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TickReport {
    pub status: DriveStatus,
    pub transitions: Transitions,
}

/// Six ideal drives: they follow valid setpoints exactly, stop the arm at the acceleration
/// limit when the setpoints stop or turn implausible, and hold it on brakes while disabled.
///
/// A disable or power-off request while the arm moves first brakes it to a standstill under
/// control (state `Stopping`), then drops to `Powered` or `Off`. A fault is sticky: only a new
/// `fault_reset` value, once the arm stands, leaves it (for `Holding`, `Powered` or `Off`,
/// whatever the request then is). Delays start counting at the tick that sees the request,
/// one state change of the power sequence per tick.
#[derive(Debug, Clone)]
pub struct SimulatedDrives {
    params: DriveParams,
    q: [f64; AXES],
    qd: [f64; AXES],
    state: DriveState,
    /// Tick the running power-on or enable delay started.
    phase_start: u64,
    /// Tick of the last setpoint taken over.
    last_fresh_tick: u64,
    fault_code: u16,
    control_seq: u64,
    fault_reset_seen: u64,
    setpoint_misses: u64,
    transitions: Transitions,
}

impl SimulatedDrives {
    /// Drives switched off, the arm standing at `q` (rad).
    pub fn new(params: DriveParams, q: [f64; AXES]) -> Self {
        Self {
            params,
            q,
            qd: [0.0; AXES],
            state: DriveState::Off,
            phase_start: 0,
            last_fresh_tick: 0,
            fault_code: 0,
            control_seq: 0,
            fault_reset_seen: 0,
            setpoint_misses: 0,
            transitions: Transitions::default(),
        }
    }

    /// The current state, without advancing time.
    pub fn status(&self) -> DriveStatus {
        DriveStatus {
            q: self.q,
            qd: self.qd,
            state: self.state,
            fault_code: self.fault_code,
            control_seq: self.control_seq,
            setpoint_misses: self.setpoint_misses,
        }
    }

    /// Advances the drives by one period to tick `now`, under the latest `control` and the
    /// latest `setpoint` window (which may be stale: only its point for `now` counts).
    pub fn tick(
        &mut self,
        now: u64,
        control: &ServoControl,
        setpoint: Option<&ServoSetpoint>,
    ) -> TickReport {
        self.transitions = Transitions::default();
        self.control_seq = control.seq;
        self.apply_control(now, control);
        self.track(now, control, setpoint);
        TickReport {
            status: self.status(),
            transitions: self.transitions,
        }
    }

    fn enter(&mut self, to: DriveState, cause: Cause) {
        if to != self.state {
            self.transitions.push(Transition {
                from: self.state,
                to,
                cause,
            });
            self.state = to;
        }
    }

    /// Power and enable sequencing, and fault acknowledgement.
    fn apply_control(&mut self, now: u64, c: &ServoControl) {
        // Outside a fault the counter is only tracked, so that an acknowledgement given while
        // the faulted arm still brakes stays pending until it stands.
        if self.state != DriveState::Fault {
            self.fault_reset_seen = c.fault_reset;
        }
        let elapsed = now.saturating_sub(self.phase_start);
        match self.state {
            DriveState::Off => {
                if c.power {
                    self.phase_start = now;
                    self.enter(DriveState::PoweringOn, Cause::PowerRequested);
                }
            }
            DriveState::PoweringOn => {
                if !c.power {
                    self.enter(DriveState::Off, Cause::PowerRemoved);
                } else if elapsed >= self.params.power_on_ticks {
                    self.enter(DriveState::Powered, Cause::PoweredOn);
                }
            }
            DriveState::Powered => {
                if !c.power {
                    self.enter(DriveState::Off, Cause::PowerRemoved);
                } else if c.enable {
                    self.phase_start = now;
                    self.enter(DriveState::Enabling, Cause::EnableRequested);
                }
            }
            DriveState::Enabling => {
                if !c.power {
                    self.enter(DriveState::Off, Cause::PowerRemoved);
                } else if !c.enable {
                    self.enter(DriveState::Powered, Cause::DisableRequested);
                } else if elapsed >= self.params.enable_ticks {
                    self.last_fresh_tick = now;
                    self.enter(DriveState::Holding, Cause::Enabled);
                }
            }
            DriveState::Following | DriveState::Stopping | DriveState::Holding => {
                if !c.power {
                    self.stop(c, Cause::PowerRemoved);
                } else if !c.enable {
                    self.stop(c, Cause::DisableRequested);
                }
            }
            DriveState::Fault => {
                // Only an acknowledged fault is left, and only once the arm stands still,
                // so the acknowledgement can never skip the controlled stop.
                if c.fault_reset != self.fault_reset_seen && !self.is_moving() {
                    self.fault_reset_seen = c.fault_reset;
                    self.fault_code = 0;
                    self.enter(rest_state(c), Cause::FaultReset);
                }
            }
        }
    }

    /// Setpoint tracking, extrapolation and the controlled stop.
    fn track(&mut self, now: u64, c: &ServoControl, setpoint: Option<&ServoSetpoint>) {
        let point = setpoint.and_then(|s| point_for(now, s));
        match self.state {
            DriveState::Holding => {
                if let Some(p) = point {
                    if self.continues_from_here(p) {
                        self.take_over(now, p);
                    } else {
                        self.setpoint_misses += 1;
                    }
                }
            }
            DriveState::Following => match point {
                Some(p) => self.take_over(now, p),
                None => {
                    self.setpoint_misses += 1;
                    let silent = now.saturating_sub(self.last_fresh_tick);
                    if silent >= self.params.setpoint_timeout_ticks {
                        self.stop(c, Cause::SetpointTimeout);
                    } else {
                        self.extrapolate();
                    }
                }
            },
            _ => {}
        }
        match self.state {
            DriveState::Stopping => {
                self.decelerate();
                if !self.is_moving() {
                    self.enter(rest_state(c), Cause::Stopped);
                }
            }
            DriveState::Fault => self.decelerate(),
            DriveState::Following | DriveState::Holding => {}
            DriveState::Off
            | DriveState::PoweringOn
            | DriveState::Powered
            | DriveState::Enabling => self.qd = [0.0; AXES],
        }
    }

    /// Checks `p` and follows it, or faults.
    fn take_over(&mut self, now: u64, p: &JointPoint) {
        match self.check(p) {
            Ok(()) => {
                self.q = p.q;
                self.qd = p.qd;
                self.last_fresh_tick = now;
                self.enter(DriveState::Following, Cause::SetpointAccepted);
            }
            Err(fault) => {
                self.fault_code = fault.code();
                self.enter(DriveState::Fault, Cause::Fault(fault));
            }
        }
    }

    /// Stops a moving arm under control, or settles at once when it stands still.
    fn stop(&mut self, c: &ServoControl, cause: Cause) {
        if self.is_moving() {
            self.enter(DriveState::Stopping, cause);
        } else {
            self.enter(rest_state(c), cause);
        }
    }

    fn is_moving(&self) -> bool {
        self.qd.iter().any(|v| *v != 0.0)
    }

    fn continues_from_here(&self, p: &JointPoint) -> bool {
        p.q.iter()
            .zip(&self.q)
            .all(|(sp, q)| within(sp - q, HOLD_CONTINUITY_RAD))
    }

    /// Plausibility of a setpoint against the limits and the current position. Every test
    /// is phrased as "inside", so a NaN anywhere fails it.
    fn check(&self, p: &JointPoint) -> Result<(), MotionFault> {
        let l = &self.params.limits;
        let dt = self.params.period_s;
        for joint in 0..AXES {
            let q = p.q[joint];
            let in_range = q >= l.min[joint] - POSITION_EPSILON_RAD
                && q <= l.max[joint] + POSITION_EPSILON_RAD;
            if !in_range {
                return Err(MotionFault::PositionLimit { joint });
            }
            let vmax = VELOCITY_TOLERANCE * l.velocity[joint];
            if !within(p.qd[joint], vmax) {
                return Err(MotionFault::VelocityLimit { joint });
            }
            if !within(q - self.q[joint], vmax * dt + JUMP_SLACK_RAD) {
                return Err(MotionFault::PositionJump { joint });
            }
        }
        Ok(())
    }

    /// Keeps moving at the last velocity for a tick without a setpoint.
    fn extrapolate(&mut self) {
        let dt = self.params.period_s;
        for (q, qd) in self.q.iter_mut().zip(&self.qd) {
            *q += qd * dt;
        }
    }

    /// One period of braking at each joint's acceleration limit, ending exactly at zero
    /// velocity (the position integrates the true ramp, also when it ends inside the period).
    fn decelerate(&mut self) {
        let dt = self.params.period_s;
        for joint in 0..AXES {
            let v0 = self.qd[joint];
            let a = self.params.limits.acceleration[joint];
            let t_stop = v0.abs() / a;
            if t_stop <= dt {
                self.q[joint] += 0.5 * v0 * t_stop;
                self.qd[joint] = 0.0;
            } else {
                let v1 = v0 - (a * dt).copysign(v0);
                self.q[joint] += 0.5 * (v0 + v1) * dt;
                self.qd[joint] = v1;
            }
        }
    }
}

/// The point of `setpoint` meant for tick `now`, if its window covers it.
fn point_for(now: u64, setpoint: &ServoSetpoint) -> Option<&JointPoint> {
    let index = now.checked_sub(setpoint.first_tick)?;
    setpoint.points.get(usize::try_from(index).ok()?)
}

/// |x| <= bound; false for NaN.
fn within(x: f64, bound: f64) -> bool {
    x.abs() <= bound
}

/// The state an arm standing still settles in under control `c`.
fn rest_state(c: &ServoControl) -> DriveState {
    if !c.power {
        DriveState::Off
    } else if !c.enable {
        DriveState::Powered
    } else {
        DriveState::Holding
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use shared_types::ipc::SETPOINT_WINDOW;

    const PERIOD_S: f64 = 0.001;

    fn params() -> DriveParams {
        let cfg = Config::load(None).expect("embedded config");
        let mut p = DriveParams::from_config(&cfg);
        p.period_s = PERIOD_S;
        p.power_on_ticks = 30;
        p.enable_ticks = 20;
        p.setpoint_timeout_ticks = 10;
        p
    }

    fn home() -> [f64; AXES] {
        [0.0, 1.5, 1.5, 1.5, -1.5, 0.0]
    }

    fn control(power: bool, enable: bool) -> ServoControl {
        ServoControl {
            seq: 7,
            power,
            enable,
            ..ServoControl::default()
        }
    }

    fn window(first_tick: u64, p: JointPoint) -> ServoSetpoint {
        ServoSetpoint {
            planner_instance: 1,
            first_tick,
            points: [p; SETPOINT_WINDOW],
        }
    }

    fn point(q: [f64; AXES], qd: [f64; AXES]) -> JointPoint {
        JointPoint {
            q,
            qd,
            qdd: [0.0; AXES],
        }
    }

    /// Drives enabled and holding at `home()`; returns them and the next tick.
    fn enabled() -> (SimulatedDrives, u64) {
        let mut d = SimulatedDrives::new(params(), home());
        let on = control(true, true);
        for t in 0..100 {
            if d.tick(t, &on, None).status.state == DriveState::Holding {
                return (d, t + 1);
            }
        }
        panic!("drives never enabled");
    }

    /// Follows a constant-velocity ramp for `ticks` ticks; returns the next tick.
    fn follow_ramp(d: &mut SimulatedDrives, start: u64, ticks: u64, qd: [f64; AXES]) -> u64 {
        let on = control(true, true);
        for t in start..start + ticks {
            let mut q = d.status().q;
            if t > start {
                for j in 0..AXES {
                    q[j] += qd[j] * PERIOD_S;
                }
            }
            let sp = window(t, point(q, if t > start { qd } else { [0.0; AXES] }));
            let r = d.tick(t, &on, Some(&sp));
            assert_eq!(r.status.state, DriveState::Following, "tick {t}");
        }
        start + ticks
    }

    #[test]
    fn power_and_enable_take_their_delays() {
        let mut d = SimulatedDrives::new(params(), home());
        let mut states = Vec::new();
        for t in 0..60 {
            let r = d.tick(t, &control(true, t >= 40), None);
            states.push(r.status.state);
            assert_eq!(r.status.control_seq, 7);
        }
        assert_eq!(states[0], DriveState::PoweringOn);
        assert_eq!(states[29], DriveState::PoweringOn);
        assert_eq!(states[30], DriveState::Powered);
        assert_eq!(states[39], DriveState::Powered);
        assert_eq!(states[40], DriveState::Enabling);
        assert_eq!(states[59], DriveState::Enabling);
        let r = d.tick(60, &control(true, true), None);
        assert_eq!(r.status.state, DriveState::Holding);
        let t: Vec<_> = r.transitions.iter().collect();
        assert_eq!(t.len(), 1);
        assert_eq!(t[0].cause, Cause::Enabled);
    }

    #[test]
    fn withdrawn_requests_abort_the_delays() {
        let mut d = SimulatedDrives::new(params(), home());
        d.tick(0, &control(true, false), None);
        let r = d.tick(1, &control(false, false), None);
        assert_eq!(r.status.state, DriveState::Off);
        for t in 2..40 {
            d.tick(t, &control(true, true), None);
        }
        assert_eq!(d.status().state, DriveState::Enabling);
        let r = d.tick(40, &control(true, false), None);
        assert_eq!(r.status.state, DriveState::Powered);
    }

    #[test]
    fn disabled_drives_hold_position_and_ignore_setpoints() {
        let mut d = SimulatedDrives::new(params(), home());
        let mut q = home();
        q[0] += 0.5e-4;
        let sp = window(0, point(q, [0.0; AXES]));
        for t in 0..40 {
            let r = d.tick(t, &control(true, false), Some(&sp));
            assert_eq!(r.status.q, home());
            assert_eq!(r.status.qd, [0.0; AXES]);
            assert_eq!(r.status.setpoint_misses, 0);
        }
    }

    #[test]
    fn holding_accepts_only_points_that_continue_from_the_arm() {
        let (mut d, t) = enabled();
        let on = control(true, true);
        let mut far = home();
        far[2] += 2e-4;
        let r = d.tick(t, &on, Some(&window(t, point(far, [0.0; AXES]))));
        assert_eq!(r.status.state, DriveState::Holding);
        assert_eq!(r.status.q, home());
        assert_eq!(r.status.setpoint_misses, 1);

        let mut near = home();
        near[2] += 0.9e-4;
        let r = d.tick(t + 1, &on, Some(&window(t + 1, point(near, [0.0; AXES]))));
        assert_eq!(r.status.state, DriveState::Following);
        assert_eq!(r.status.q, near);
        assert_eq!(r.status.setpoint_misses, 1);
    }

    #[test]
    fn a_point_outside_the_window_is_no_point() {
        let (mut d, t) = enabled();
        let on = control(true, true);
        let stale = window(
            t.saturating_sub(SETPOINT_WINDOW as u64),
            point(home(), [0.0; AXES]),
        );
        let future = window(t + 1, point(home(), [0.0; AXES]));
        assert_eq!(
            d.tick(t, &on, Some(&stale)).status.state,
            DriveState::Holding
        );
        assert_eq!(
            d.tick(t + 1, &on, Some(&future)).status.state,
            DriveState::Following
        );
    }

    #[test]
    fn a_jump_faults_with_motion_error_and_stops_under_control() {
        let (mut d, t) = enabled();
        let qd = [0.5; AXES];
        let t = follow_ramp(&mut d, t, 50, qd);
        let before = d.status();
        let mut q = before.q;
        q[3] += 0.1;
        let r = d.tick(t, &control(true, true), Some(&window(t, point(q, qd))));
        assert_eq!(r.status.state, DriveState::Fault);
        assert_eq!(r.status.fault_code, 0x6C02);
        let t0: Vec<_> = r.transitions.iter().collect();
        assert_eq!(
            t0[0].cause,
            Cause::Fault(MotionFault::PositionJump { joint: 3 })
        );
        // The bad point was not taken over: the arm brakes from where it was.
        assert!((r.status.q[3] - before.q[3]).abs() < 1e-3);
        assert!(r.status.qd[3] < before.qd[3]);
    }

    #[test]
    fn implausible_velocity_and_position_fault() {
        let (mut d, t) = enabled();
        let on = control(true, true);
        let mut qd = [0.0; AXES];
        qd[1] = 10.0;
        let r = d.tick(t, &on, Some(&window(t, point(home(), qd))));
        assert_eq!(r.status.state, DriveState::Fault);
        assert_eq!(
            r.transitions.iter().next().map(|x| x.cause),
            Some(Cause::Fault(MotionFault::VelocityLimit { joint: 1 }))
        );

        let near_limit = params().limits.max[5] - 0.2e-4;
        let mut d = SimulatedDrives::new(params(), [0.0, 1.5, 1.5, 1.5, -1.5, near_limit]);
        let on = control(true, true);
        let mut t = 0;
        while d.tick(t, &on, None).status.state != DriveState::Holding {
            t += 1;
        }
        t += 1;
        let mut q = d.status().q;
        q[5] += 0.5e-4;
        let r = d.tick(t, &on, Some(&window(t, point(q, [0.0; AXES]))));
        assert_eq!(
            r.transitions.iter().next().map(|x| x.cause),
            Some(Cause::Fault(MotionFault::PositionLimit { joint: 5 }))
        );
    }

    #[test]
    fn fault_reset_returns_to_holding_or_powered() {
        let (mut d, t) = enabled();
        let mut qd = [0.0; AXES];
        qd[0] = 10.0;
        let on = control(true, true);
        d.tick(t, &on, Some(&window(t, point(home(), qd))));
        assert_eq!(d.status().state, DriveState::Fault);
        // Without an acknowledgement the fault stays, whatever else comes.
        for k in 1..20 {
            let r = d.tick(t + k, &on, Some(&window(t + k, point(home(), [0.0; AXES]))));
            assert_eq!(r.status.state, DriveState::Fault);
        }
        let ack = ServoControl {
            fault_reset: 1,
            ..on
        };
        let r = d.tick(t + 20, &ack, None);
        assert_eq!(r.status.state, DriveState::Holding);
        assert_eq!(r.status.fault_code, 0);

        let (mut d, t) = enabled();
        d.tick(t, &on, Some(&window(t, point(home(), qd))));
        let ack_disabled = ServoControl {
            fault_reset: 5,
            ..control(true, false)
        };
        let r = d.tick(t + 1, &ack_disabled, None);
        assert_eq!(r.status.state, DriveState::Powered);
    }

    #[test]
    fn a_reset_given_while_braking_applies_at_standstill() {
        let (mut d, t) = enabled();
        let on = control(true, true);
        let t = follow_ramp(&mut d, t, 50, [0.5; AXES]);
        let mut q = d.status().q;
        q[0] += 0.1;
        d.tick(t, &on, Some(&window(t, point(q, [0.5; AXES]))));
        let ack = ServoControl {
            fault_reset: 1,
            ..on
        };
        let r = d.tick(t + 1, &ack, None);
        assert_eq!(r.status.state, DriveState::Fault, "still braking");
        let mut k = t + 2;
        while d.tick(k, &ack, None).status.state == DriveState::Fault {
            assert!(k < t + 1000, "reset never applied");
            k += 1;
        }
        assert_eq!(d.status().state, DriveState::Holding);
        assert_eq!(d.status().qd, [0.0; AXES]);
    }

    #[test]
    fn stale_setpoints_extrapolate_then_stop_within_the_acceleration_limit() {
        let (mut d, t) = enabled();
        let limits = params().limits;
        let qd: [f64; AXES] = core::array::from_fn(|j| 0.9 * limits.velocity[j]);
        let silent_from = follow_ramp(&mut d, t, 200, qd);
        let on = control(true, true);
        let mut prev = d.status();
        let mut saw_stopping = false;
        for t in silent_from..silent_from + 5000 {
            let r = d.tick(t, &on, None);
            assert_accel_within(&prev.qd, &r.status.qd, &limits);
            assert!(
                r.status.qd.iter().all(|v| *v >= 0.0),
                "velocity overshot zero"
            );
            saw_stopping |= r.status.state == DriveState::Stopping;
            prev = r.status;
            if r.status.state == DriveState::Holding {
                break;
            }
        }
        assert!(saw_stopping);
        assert_eq!(prev.state, DriveState::Holding);
        assert_eq!(prev.qd, [0.0; AXES]);
        assert!(prev.setpoint_misses >= 10);
    }

    #[test]
    fn disable_while_moving_stops_first() {
        let (mut d, t) = enabled();
        let t = follow_ramp(&mut d, t, 20, [0.3; AXES]);
        let r = d.tick(t, &control(true, false), None);
        assert_eq!(r.status.state, DriveState::Stopping);
        let mut k = t + 1;
        while d.tick(k, &control(true, false), None).status.state == DriveState::Stopping {
            k += 1;
        }
        assert_eq!(d.status().state, DriveState::Powered);
    }

    fn assert_accel_within(before: &[f64; AXES], after: &[f64; AXES], l: &JointLimitsRad) {
        for j in 0..AXES {
            let a = (after[j] - before[j]).abs() / PERIOD_S;
            assert!(
                a <= l.acceleration[j] * (1.0 + 1e-9),
                "joint {j}: {a} > {}",
                l.acceleration[j]
            );
        }
    }

    proptest! {
        #[test]
        fn stopping_never_exceeds_the_acceleration_limit(
            fractions in proptest::array::uniform6(-1.0f64..1.0),
        ) {
            let limits = params().limits;
            let mut d = SimulatedDrives::new(params(), home());
            d.state = DriveState::Stopping;
            d.qd = core::array::from_fn(|j| fractions[j] * limits.velocity[j]);
            let start = d.qd;
            let on = control(true, true);
            let mut prev = d.qd;
            for t in 0..10_000 {
                let r = d.tick(t, &on, None);
                assert_accel_within(&prev, &r.status.qd, &limits);
                for (v, v0) in r.status.qd.iter().zip(&start) {
                    prop_assert!(v * v0 >= 0.0, "velocity overshot zero");
                }
                prev = r.status.qd;
                if r.status.state == DriveState::Holding {
                    break;
                }
            }
            prop_assert_eq!(d.status().state, DriveState::Holding);
            // Each joint travelled exactly its braking distance v²/(2a).
            for (j, v0) in start.iter().enumerate() {
                let expected = v0 * v0.abs() / (2.0 * limits.acceleration[j]);
                prop_assert!((d.q[j] - home()[j] - expected).abs() < 1e-9);
            }
        }
    }
}
