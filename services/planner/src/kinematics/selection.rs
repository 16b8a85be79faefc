//! The joint target of a Cartesian target: the configuration by the SRCI ConfigMode, the turns
//! by the TurnMode, within the joint limits and nearest to the current joints.
//!
//! 1. Inverse kinematics gives up to eight base solutions (J6's reference where the wrist is
//!    singular is the current J6).
//! 2. Each element (Shoulder, Elbow, Wrist) keeps the branches its [`ConfigMode`] allows.
//! 3. Each joint of a kept branch gets its turn by the [`TurnMode`].
//! 4. Of the candidates inside the joint limits the one nearest to the current joints wins,
//!    by `Σ ((q_i − current_i) / v_max_i)²`: joint distance in seconds at full speed, so a slow
//!    joint's travel weighs more.
//! 5. Without such a candidate the nearest candidate's limit violation is the error; without
//!    any candidate the target is unreachable in the requested configuration.

use core::f64::consts::TAU;

use nalgebra::Isometry3;
use shared_types::config::JointLimitsRad;
use shared_types::ipc::{AXES, RefusalReason};
use shared_types::srci::message::code;

use super::turns::{TurnNumbers, split_turn};
use super::{ArmConfig, ArmConfigElement, ArmGeometry, Elbow, IkError, Shoulder, Wrist};
use crate::joint_move::{MoveError, check_limits};

/// How one element of the arm configuration is chosen (SRCI ConfigMode, one nibble each).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConfigMode<T> {
    /// 0: as in the configuration sent with the target.
    UseConfig,
    /// 1: as in the current joints (the SRCI default).
    Same,
    /// 2: any; the nearest solution decides.
    Free,
    /// 3 (BACK, DOWN, FLIP) or 4 (FRONT, UP, NON_FLIP).
    Fixed(T),
}

impl<T: ArmConfigElement> ConfigMode<T> {
    /// The mode of a wire value, `None` for values the specification does not define.
    pub fn from_wire(value: u8) -> Option<Self> {
        match value {
            0 => Some(Self::UseConfig),
            1 => Some(Self::Same),
            2 => Some(Self::Free),
            3 => Some(Self::Fixed(T::from_bit(true))),
            4 => Some(Self::Fixed(T::from_bit(false))),
            _ => None,
        }
    }

    /// The element a solution must have, `None` for any.
    pub(crate) fn required(self, target: T, current: T) -> Option<T> {
        match self {
            Self::UseConfig => Some(target),
            Self::Same => Some(current),
            Self::Free => None,
            Self::Fixed(element) => Some(element),
        }
    }
}

/// The ConfigMode of the three elements.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ConfigModes {
    pub shoulder: ConfigMode<Shoulder>,
    pub elbow: ConfigMode<Elbow>,
    pub wrist: ConfigMode<Wrist>,
}

impl ConfigModes {
    /// The modes of the wire values of Shoulder, Elbow and Wrist.
    pub fn from_wire([shoulder, elbow, wrist]: [u8; 3]) -> Result<Self, ModeError> {
        Ok(Self {
            shoulder: ConfigMode::from_wire(shoulder).ok_or(ModeError::Shoulder(shoulder))?,
            elbow: ConfigMode::from_wire(elbow).ok_or(ModeError::Elbow(elbow))?,
            wrist: ConfigMode::from_wire(wrist).ok_or(ModeError::Wrist(wrist))?,
        })
    }

    /// The configuration a target must have, element by element, given the one sent with
    /// it and the current one (`None`: any).
    pub(crate) fn required(
        &self,
        target: ArmConfig,
        current: ArmConfig,
    ) -> (Option<Shoulder>, Option<Elbow>, Option<Wrist>) {
        (
            self.shoulder.required(target.shoulder, current.shoulder),
            self.elbow.required(target.elbow, current.elbow),
            self.wrist.required(target.wrist, current.wrist),
        )
    }
}

/// A ConfigMode or TurnMode wire value the specification does not define.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum ModeError {
    #[error("shoulder ConfigMode {0} is not defined")]
    Shoulder(u8),
    #[error("elbow ConfigMode {0} is not defined")]
    Elbow(u8),
    #[error("wrist ConfigMode {0} is not defined")]
    Wrist(u8),
    #[error("TurnMode {0} is not defined")]
    Turn(u8),
}

impl ModeError {
    /// The SRCI message code reported for this error.
    pub fn code(&self) -> u16 {
        match self {
            Self::Shoulder(_) => code::INVALID_CONFIG_MODE_SHOULDER,
            Self::Elbow(_) => code::INVALID_CONFIG_MODE_ELBOW,
            Self::Wrist(_) => code::INVALID_CONFIG_MODE_WRIST,
            Self::Turn(_) => code::INVALID_TURN_MODE,
        }
    }
}

/// How the turn of each joint is chosen (SRCI TurnMode).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TurnMode {
    /// 0: the turn numbers sent with the target: `q_i = base_i + 2π·turn_i`.
    UseTurnNumber,
    /// 1: the current joint's turn: the target lies in the same window (−π, π] + 2π·t as the
    /// current joint (a joint at 170° going to a base of −170° turns back by 340°).
    Same,
    /// 2: per joint, the turn inside the joint limits nearest to the current joint (a joint
    /// at 170° going to a base of −170° moves on to 190°, if the limits allow).
    Free,
}

impl TurnMode {
    /// The mode of a wire value.
    pub fn parse(value: u8) -> Result<Self, ModeError> {
        Self::from_wire(value).ok_or(ModeError::Turn(value))
    }

    /// The mode of a wire value, `None` for values the specification does not define.
    pub fn from_wire(value: u8) -> Option<Self> {
        match value {
            0 => Some(Self::UseTurnNumber),
            1 => Some(Self::Same),
            2 => Some(Self::Free),
            _ => None,
        }
    }
}

/// A Cartesian target with what SRCI sends along with it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CartesianTarget {
    /// The flange pose in the base frame.
    pub flange: Isometry3<f64>,
    /// The configuration sent with the target (used by [`ConfigMode::UseConfig`]).
    pub config: ArmConfig,
    /// The turns sent with the target (used by [`TurnMode::UseTurnNumber`]).
    pub turns: TurnNumbers,
    pub config_modes: ConfigModes,
    pub turn_mode: TurnMode,
}

/// Why a Cartesian target has no joint target; [`code`](Self::code) is the SRCI message code.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum SelectionError {
    #[error(transparent)]
    Kinematics(#[from] IkError),
    #[error("the target is out of reach in the requested configuration")]
    NotInConfiguration,
    /// [`MoveError::BelowLowerLimit`] or [`MoveError::AboveUpperLimit`] of the nearest
    /// candidate.
    #[error(transparent)]
    OutsideLimits(MoveError),
}

impl SelectionError {
    /// The SRCI message code reported for this error.
    pub fn code(&self) -> u16 {
        match self {
            Self::Kinematics(_) | Self::NotInConfiguration => code::TARGET_UNREACHABLE,
            Self::OutsideLimits(error) => error.code(),
        }
    }

    /// Why, where the code does not tell.
    pub fn reason(&self) -> RefusalReason {
        match self {
            Self::Kinematics(IkError::Unreachable) => RefusalReason::OutOfReach,
            Self::NotInConfiguration => RefusalReason::NotInConfiguration,
            _ => RefusalReason::None,
        }
    }
}

/// The joint target (rad) for `target` from the current joints `current` (rad).
pub fn select(
    geometry: &ArmGeometry,
    target: &CartesianTarget,
    current: &[f64; AXES],
    limits: &JointLimitsRad,
) -> Result<[f64; AXES], SelectionError> {
    let solutions = geometry.inverse(&target.flange, current[5])?;
    let now = geometry.arm_config(current);
    let required = target.config_modes.required(target.config, now);
    let mut within: Option<(f64, [f64; AXES])> = None;
    let mut outside: Option<(f64, SelectionError)> = None;
    for (config, base) in solutions.iter() {
        let allowed = required.0.is_none_or(|s| s == config.shoulder)
            && required.1.is_none_or(|e| e == config.elbow)
            && required.2.is_none_or(|w| w == config.wrist);
        if !allowed {
            continue;
        }
        let q: [f64; AXES] = core::array::from_fn(|i| {
            let turn = match target.turn_mode {
                TurnMode::UseTurnNumber => f64::from(target.turns.joints[i]),
                // Exact: a joint angle is nowhere near 2^53 turns.
                TurnMode::Same => split_turn(current[i]).1 as f64,
                TurnMode::Free => nearest_turn(base[i], current[i], limits.min[i], limits.max[i]),
            };
            base[i] + TAU * turn
        });
        let cost = (0..AXES)
            .map(|i| ((q[i] - current[i]) / limits.velocity[i]).powi(2))
            .sum::<f64>();
        match limit_violation(&q, limits) {
            None if within.is_none_or(|(best, _)| cost < best) => within = Some((cost, q)),
            Some(error) if outside.is_none_or(|(best, _)| cost < best) => {
                outside = Some((cost, error));
            }
            _ => {}
        }
    }
    match (within, outside) {
        (Some((_, q)), _) => Ok(q),
        (None, Some((_, error))) => Err(error),
        (None, None) => Err(SelectionError::NotInConfiguration),
    }
}

/// The turn `t` putting `base + 2π·t` inside `[min, max]` nearest to `current`; the nearest
/// turn regardless of the limits if no turn fits.
fn nearest_turn(base: f64, current: f64, min: f64, max: f64) -> f64 {
    let nearest = ((current - base) / TAU).round();
    let lowest = ((min - base) / TAU).ceil();
    let highest = ((max - base) / TAU).floor();
    if lowest <= highest {
        // The distance is convex in t, so the nearest turn inside is the clamped one.
        nearest.clamp(lowest, highest)
    } else {
        nearest
    }
}

/// The first joint of `q` outside its limits.
fn limit_violation(q: &[f64; AXES], limits: &JointLimitsRad) -> Option<SelectionError> {
    (0..AXES)
        .find_map(|axis| check_limits(axis, q[axis], limits, 0.0).err())
        .map(SelectionError::OutsideLimits)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::test_robots::{self, Robot};
    use crate::kinematics::turns::{base_angle, with_turns};
    use proptest::prelude::*;

    const FREE: ConfigModes = ConfigModes {
        shoulder: ConfigMode::Free,
        elbow: ConfigMode::Free,
        wrist: ConfigMode::Free,
    };
    const USE_CONFIG: ConfigModes = ConfigModes {
        shoulder: ConfigMode::UseConfig,
        elbow: ConfigMode::UseConfig,
        wrist: ConfigMode::UseConfig,
    };
    const SAME: ConfigModes = ConfigModes {
        shoulder: ConfigMode::Same,
        elbow: ConfigMode::Same,
        wrist: ConfigMode::Same,
    };

    /// The robot's limits widened to ±2 turns on every joint.
    fn wide_limits(robot: &Robot) -> JointLimitsRad {
        JointLimitsRad {
            min: [-2.0 * TAU; AXES],
            max: [2.0 * TAU; AXES],
            ..robot.config.limits_rad()
        }
    }

    fn target_of(
        robot: &Robot,
        q: &[f64; AXES],
        modes: ConfigModes,
        turn_mode: TurnMode,
    ) -> CartesianTarget {
        CartesianTarget {
            flange: robot.kinematics.flange(q),
            config: robot.geometry.arm_config(q),
            turns: TurnNumbers::of_joints(q).unwrap(),
            config_modes: modes,
            turn_mode,
        }
    }

    fn fixed(config: ArmConfig) -> ConfigModes {
        ConfigModes {
            shoulder: ConfigMode::Fixed(config.shoulder),
            elbow: ConfigMode::Fixed(config.elbow),
            wrist: ConfigMode::Fixed(config.wrist),
        }
    }

    fn assert_joints(a: &[f64; AXES], b: &[f64; AXES]) {
        for (x, y) in a.iter().zip(b) {
            assert!((x - y).abs() < 1e-9, "{a:?} != {b:?}");
        }
    }

    /// The modes of one wire value for Shoulder, Elbow and Wrist.
    fn modes_of(value: u8) -> ConfigModes {
        let modes = (
            ConfigMode::from_wire(value),
            ConfigMode::from_wire(value),
            ConfigMode::from_wire(value),
        );
        ConfigModes {
            shoulder: modes.0.unwrap(),
            elbow: modes.1.unwrap(),
            wrist: modes.2.unwrap(),
        }
    }

    #[test]
    fn wire_values_map_to_the_modes() {
        assert_eq!(modes_of(0), USE_CONFIG);
        assert_eq!(modes_of(1), SAME);
        assert_eq!(modes_of(2), FREE);
        let back_down_flip = ArmConfig {
            shoulder: Shoulder::Back,
            elbow: Elbow::Down,
            wrist: Wrist::Flip,
        };
        assert_eq!(modes_of(3), fixed(back_down_flip));
        let front_up_non_flip = ArmConfig {
            shoulder: Shoulder::Front,
            elbow: Elbow::Up,
            wrist: Wrist::NonFlip,
        };
        assert_eq!(modes_of(4), fixed(front_up_non_flip));
        assert_eq!(ConfigMode::<Wrist>::from_wire(5), None);
        assert_eq!(
            [0, 1, 2, 3].map(TurnMode::from_wire),
            [
                Some(TurnMode::UseTurnNumber),
                Some(TurnMode::Same),
                Some(TurnMode::Free),
                None
            ]
        );
    }

    #[test]
    fn explicit_configuration_is_honoured_for_every_branch() {
        for robot in test_robots::all() {
            let q = test_robots::regular(&robot.geometry);
            let limits = wide_limits(&robot);
            for bits in 0..8 {
                let config = ArmConfig::from_bits(bits);
                let target = target_of(&robot, &q, fixed(config), TurnMode::Free);
                let chosen = select(&robot.geometry, &target, &q, &limits).unwrap();
                assert_eq!(
                    robot.geometry.arm_config(&chosen),
                    config,
                    "{}",
                    robot.config.name
                );
                let reached = robot.kinematics.flange(&chosen);
                assert!(
                    (reached.translation.vector - target.flange.translation.vector).norm() < 1e-9
                );
                assert!(reached.rotation.angle_to(&target.flange.rotation) < 1e-9);
            }
        }
    }

    #[test]
    fn use_config_takes_the_target_bits_and_same_the_current_ones() {
        for robot in test_robots::all() {
            let limits = wide_limits(&robot);
            let current = test_robots::regular(&robot.geometry);
            let now = robot.geometry.arm_config(&current);
            let solutions = robot
                .geometry
                .inverse(&robot.kinematics.flange(&current), current[5])
                .unwrap();
            // A target in the opposite configuration of every element.
            let other = ArmConfig::from_bits(now.bits() ^ 0b111);
            let q = *solutions.get(other).unwrap();
            let mut target = target_of(&robot, &q, USE_CONFIG, TurnMode::Free);
            let chosen = select(&robot.geometry, &target, &current, &limits).unwrap();
            assert_eq!(robot.geometry.arm_config(&chosen), other);
            target.config_modes = SAME;
            let chosen = select(&robot.geometry, &target, &current, &limits).unwrap();
            assert_eq!(robot.geometry.arm_config(&chosen), now);
            // Mixed: the shoulder as sent, the elbow kept, the wrist fixed to NON_FLIP.
            target.config_modes = ConfigModes {
                shoulder: ConfigMode::UseConfig,
                elbow: ConfigMode::Same,
                wrist: ConfigMode::Fixed(Wrist::NonFlip),
            };
            let chosen = select(&robot.geometry, &target, &current, &limits).unwrap();
            let expected = ArmConfig {
                shoulder: other.shoulder,
                elbow: now.elbow,
                wrist: Wrist::NonFlip,
            };
            assert_eq!(
                robot.geometry.arm_config(&chosen),
                expected,
                "{}",
                robot.config.name
            );
        }
    }

    #[test]
    fn free_configuration_takes_the_nearest_branch() {
        for robot in test_robots::all() {
            let q = test_robots::regular(&robot.geometry);
            let mut current = q;
            current[1] += 0.05;
            current[4] -= 0.05;
            let target = target_of(&robot, &q, FREE, TurnMode::Free);
            let chosen = select(
                &robot.geometry,
                &target,
                &current,
                &robot.config.limits_rad(),
            )
            .unwrap();
            assert_joints(&chosen, &q);
        }
    }

    #[test]
    fn turn_modes_place_j6() {
        for robot in test_robots::all() {
            let limits = wide_limits(&robot);
            let mut q = test_robots::regular(&robot.geometry);
            q[5] = -3.0;
            let mut current = q;
            current[5] = 3.0;
            let mut target = target_of(&robot, &q, SAME, TurnMode::Free);
            let chosen = select(&robot.geometry, &target, &current, &limits).unwrap();
            assert!(
                (chosen[5] - (TAU - 3.0)).abs() < 1e-9,
                "free: {}",
                chosen[5]
            );
            target.turn_mode = TurnMode::Same;
            let chosen = select(&robot.geometry, &target, &current, &limits).unwrap();
            assert!((chosen[5] + 3.0).abs() < 1e-9, "same: {}", chosen[5]);
            current[5] = 3.0 - TAU;
            let chosen = select(&robot.geometry, &target, &current, &limits).unwrap();
            assert!(
                (chosen[5] + 3.0 + TAU).abs() < 1e-9,
                "same, turn −1: {}",
                chosen[5]
            );
            target.turn_mode = TurnMode::UseTurnNumber;
            target.turns.joints = [0, 0, 0, 0, 0, 1];
            let chosen = select(&robot.geometry, &target, &current, &limits).unwrap();
            assert!(
                (chosen[5] - (TAU - 3.0)).abs() < 1e-9,
                "turn 1: {}",
                chosen[5]
            );
            assert_joints(
                &chosen,
                &with_turns(&q.map(base_angle), &target.turns.joints),
            );
        }
    }

    #[test]
    fn free_turn_stays_inside_the_limits() {
        let robot = test_robots::default();
        let limits = robot.config.limits_rad();
        let mut q = test_robots::regular(&robot.geometry);
        q[0] = 1.0;
        let mut current = q;
        // 344°: the nearest turn of 1 rad is 1 + 2π = 417°, beyond the limit of 359°.
        current[0] = 6.0;
        let target = target_of(&robot, &q, SAME, TurnMode::Free);
        let chosen = select(&robot.geometry, &target, &current, &limits).unwrap();
        assert_joints(&chosen, &q);
    }

    #[test]
    fn a_target_outside_the_limits_names_the_limit() {
        let robot = test_robots::default();
        let limits = robot.config.limits_rad();
        for (q3, code) in [(3.08, code::SW_LIMIT_UPPER), (-3.08, code::SW_LIMIT_LOWER)] {
            let q = [0.3, 1.2, q3, 0.6, 1.1, 0.2];
            assert!(
                !robot
                    .geometry
                    .singularity_measures(&q)
                    .singularities()
                    .any()
            );
            for turn_mode in [TurnMode::Free, TurnMode::Same, TurnMode::UseTurnNumber] {
                let target = target_of(&robot, &q, USE_CONFIG, turn_mode);
                let error = select(&robot.geometry, &target, &q, &limits).unwrap_err();
                assert_eq!(error.code(), code, "{error}");
                assert!(matches!(
                    error,
                    SelectionError::OutsideLimits(
                        MoveError::AboveUpperLimit { axis: 2, .. }
                            | MoveError::BelowLowerLimit { axis: 2, .. }
                    )
                ));
            }
            // With the configuration free another branch keeps J3 inside.
            let target = target_of(&robot, &q, FREE, TurnMode::Free);
            let chosen = select(&robot.geometry, &target, &q, &limits).unwrap();
            assert!(chosen[2].abs() < limits.max[2]);
        }
    }

    #[test]
    fn a_configuration_that_cannot_reach_is_unreachable() {
        for robot in test_robots::all() {
            let limits = wide_limits(&robot);
            let q = [0.3, 0.7, 1.2, 0.6, 1.1, 0.2];
            let flange = robot.kinematics.flange(&q);
            let solutions = robot.geometry.inverse(&flange, q[5]).unwrap();
            for bits in 0..8 {
                let config = ArmConfig::from_bits(bits);
                let target = target_of(&robot, &q, fixed(config), TurnMode::Free);
                let result = select(&robot.geometry, &target, &q, &limits);
                match solutions.get(config) {
                    Some(_) => assert!(result.is_ok()),
                    None => {
                        assert_eq!(result, Err(SelectionError::NotInConfiguration));
                        assert_eq!(result.unwrap_err().code(), code::TARGET_UNREACHABLE);
                    }
                }
            }
            let mut far = target_of(&robot, &q, FREE, TurnMode::Free);
            far.flange.translation.vector.x += 3.0;
            let error = select(&robot.geometry, &far, &q, &limits).unwrap_err();
            assert_eq!(error, SelectionError::Kinematics(IkError::Unreachable));
            assert_eq!(error.code(), code::TARGET_UNREACHABLE);
        }
    }

    proptest! {
        #[test]
        fn the_sent_configuration_and_turns_give_back_the_joints(
            fraction in prop::array::uniform6(0.0f64..1.0),
        ) {
            for robot in test_robots::all() {
                let limits = robot.config.limits_rad();
                let q: [f64; AXES] = core::array::from_fn(|i| {
                    limits.min[i] + fraction[i] * (limits.max[i] - limits.min[i])
                });
                if robot.geometry.singularity_measures(&q).singularities().any() {
                    continue;
                }
                let current = [0.0; AXES];
                let target = target_of(&robot, &q, USE_CONFIG, TurnMode::UseTurnNumber);
                let chosen = select(&robot.geometry, &target, &current, &limits).unwrap();
                for (a, b) in chosen.iter().zip(&q) {
                    prop_assert!((a - b).abs() < 1e-9, "{}: {chosen:?} != {q:?}", robot.config.name);
                }
                // From the joints themselves, SAME and FREE find them again.
                for (modes, turn_mode) in [(SAME, TurnMode::Same), (FREE, TurnMode::Free)] {
                    let target = target_of(&robot, &q, modes, turn_mode);
                    let chosen = select(&robot.geometry, &target, &q, &limits).unwrap();
                    for (a, b) in chosen.iter().zip(&q) {
                        prop_assert!((a - b).abs() < 1e-9, "{}: {chosen:?} != {q:?}", robot.config.name);
                    }
                }
            }
        }
    }
}
