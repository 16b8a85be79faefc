//! The rules every entry of the user data obeys, with the SRCI code of the first rule broken.
//! Client writes and the check of a loaded file use the same rules, so the store never holds
//! what a client could not have written.

use shared_types::srci::message::code;

use super::codes;
use super::model::{
    DefaultDynamics, Entry, FrameData, HIGHEST_INDEX, LoadData, Pose, ReferenceDynamics, SwLimits,
    ToolData, USER_ENTRIES,
};
use super::robot::RobotBounds;

/// 100 % as percent × 100 on the wire.
pub(super) const FULL_RATE: u16 = 10_000;

/// Limits of the robot are compared in f32, the type of the wire, so that a value read back
/// from the controller can always be written again.
fn wire(v: f64) -> f32 {
    v as f32
}

fn check_pose(p: &Pose) -> Result<(), u16> {
    if p.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(codes::INVALID_POSITION)
    }
}

pub(super) fn check_tool(t: &ToolData) -> Result<(), u16> {
    check_pose(&t.pose)?;
    if t.load_no > HIGHEST_INDEX {
        return Err(codes::INVALID_LOAD_NO);
    }
    if t.external_tcp {
        return Err(codes::EXTERNAL_TCP_NOT_SUPPORTED);
    }
    Ok(())
}

/// Frame `index` (1..=15) may hold `f` if its chain of reference frames ends in the world
/// without passing through `index` itself.
pub(super) fn check_frame(
    frames: &[Entry<FrameData>; USER_ENTRIES],
    index: u8,
    f: &FrameData,
) -> Result<(), u16> {
    check_pose(&f.pose)?;
    let mut reference = f.reference_frame;
    // A chain without cycles has at most USER_ENTRIES links; more means a cycle elsewhere,
    // which only a damaged file can hold.
    for _ in 0..=USER_ENTRIES {
        if reference == 0 {
            return Ok(());
        }
        if reference == index {
            break;
        }
        let Some(next) = frames.get(usize::from(reference) - 1) else {
            break;
        };
        reference = next.data.reference_frame;
    }
    Err(codes::INVALID_REFERENCE_FRAME)
}

pub(super) fn check_load(l: &LoadData, bounds: &RobotBounds) -> Result<(), u16> {
    check_pose(&l.centre_of_gravity)?;
    // NaN fails both comparisons, so it is refused here too.
    if !(l.mass_kg >= 0.0 && l.mass_kg <= wire(bounds.payload_kg)) {
        return Err(codes::MASS_EXCEEDS_PAYLOAD);
    }
    if !l.inertia.iter().all(|i| i.is_finite() && *i >= 0.0) {
        return Err(codes::INDEX_OUT_OF_RANGE);
    }
    Ok(())
}

/// Every rate within 0..=100 %.
pub(super) fn check_default_dynamics(d: &DefaultDynamics) -> Result<(), u16> {
    if d.velocity_rate > FULL_RATE {
        return Err(code::INVALID_VELOCITY_RATE);
    }
    if d.acceleration_rate > FULL_RATE {
        return Err(code::INVALID_ACCELERATION_RATE);
    }
    if d.deceleration_rate > FULL_RATE {
        return Err(code::INVALID_DECELERATION_RATE);
    }
    if d.jerk_rate > FULL_RATE {
        return Err(code::INVALID_JERK_RATE);
    }
    Ok(())
}

pub(super) fn check_reference_dynamics(
    r: &ReferenceDynamics,
    bounds: &RobotBounds,
) -> Result<(), u16> {
    let within = |v: f32, max: f64| v.is_finite() && v > 0.0 && v <= wire(max);
    if !within(r.velocity_mm_s, bounds.max_velocity_mm_s) {
        return Err(codes::INVALID_VELOCITY);
    }
    if !within(r.acceleration_mm_s2, bounds.max_acceleration_mm_s2) {
        return Err(code::INVALID_ACCELERATION_RATE);
    }
    if !within(r.deceleration_mm_s2, bounds.max_acceleration_mm_s2) {
        return Err(code::INVALID_DECELERATION_RATE);
    }
    if !within(r.jerk_mm_s3, bounds.max_jerk_mm_s3) {
        return Err(code::INVALID_JERK_RATE);
    }
    Ok(())
}

pub(super) fn check_sw_limits(l: &SwLimits, bounds: &RobotBounds) -> Result<(), u16> {
    for j in 0..6 {
        let (lower, upper) = (l.lower_deg[j], l.upper_deg[j]);
        if !lower.is_finite() || !upper.is_finite() {
            return Err(codes::INDEX_OUT_OF_RANGE);
        }
        if lower < wire(bounds.joint_min_deg[j]) {
            return Err(code::SW_LIMIT_LOWER);
        }
        if upper > wire(bounds.joint_max_deg[j]) {
            return Err(code::SW_LIMIT_UPPER);
        }
        if lower >= upper {
            return Err(codes::INDEX_OUT_OF_RANGE);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn bounds() -> RobotBounds {
        let robot = shared_types::config::Config::load(None).unwrap().robot;
        RobotBounds::of(&robot).0
    }

    fn frames(references: &[(u8, u8)]) -> [Entry<FrameData>; USER_ENTRIES] {
        let mut f = [Entry::<FrameData>::default(); USER_ENTRIES];
        for &(index, reference) in references {
            f[usize::from(index) - 1].data.reference_frame = reference;
        }
        f
    }

    fn frame(reference: u8) -> FrameData {
        FrameData {
            reference_frame: reference,
            pose: [0.0; 6],
        }
    }

    #[test]
    fn frame_chains_must_end_in_the_world() {
        // 2 → 1 → world; 3 → 2.
        let f = frames(&[(1, 0), (2, 1), (3, 2)]);
        assert_eq!(check_frame(&f, 4, &frame(3)), Ok(()));
        assert_eq!(check_frame(&f, 1, &frame(0)), Ok(()));
        let cycle = Err(codes::INVALID_REFERENCE_FRAME);
        assert_eq!(check_frame(&f, 4, &frame(4)), cycle, "itself");
        assert_eq!(check_frame(&f, 1, &frame(3)), cycle, "1 → 3 → 2 → 1");
        assert_eq!(check_frame(&f, 4, &frame(16)), cycle, "no frame 16");
        assert_eq!(check_frame(&f, 4, &frame(0xFF)), cycle);
        // A damaged file with a cycle 5 ↔ 6 that does not pass through the frame checked.
        let damaged = frames(&[(5, 6), (6, 5)]);
        assert_eq!(check_frame(&damaged, 1, &frame(5)), cycle);
    }

    #[test]
    fn loads_are_limited_by_the_payload() {
        let b = bounds();
        let load = |mass_kg: f32| LoadData {
            mass_kg,
            ..LoadData::default()
        };
        assert_eq!(check_load(&load(0.0), &b), Ok(()));
        assert_eq!(check_load(&load(b.payload_kg as f32), &b), Ok(()));
        for bad in [-0.1, b.payload_kg as f32 + 0.01, f32::NAN, f32::INFINITY] {
            assert_eq!(
                check_load(&load(bad), &b),
                Err(codes::MASS_EXCEEDS_PAYLOAD),
                "{bad}"
            );
        }
        let mut l = load(1.0);
        l.inertia[2] = -1.0;
        assert_eq!(check_load(&l, &b), Err(codes::INDEX_OUT_OF_RANGE));
        l.inertia[2] = 0.0;
        l.centre_of_gravity[1] = f32::NAN;
        assert_eq!(check_load(&l, &b), Err(codes::INVALID_POSITION));
    }

    #[test]
    fn default_dynamics_rates_up_to_100_percent() {
        let d = DefaultDynamics {
            velocity_rate: 10_000,
            acceleration_rate: 2_000,
            deceleration_rate: 3_000,
            jerk_rate: 0,
        };
        assert_eq!(check_default_dynamics(&d), Ok(()));
        let too_fast = DefaultDynamics {
            deceleration_rate: 10_001,
            ..d
        };
        assert_eq!(
            check_default_dynamics(&too_fast),
            Err(code::INVALID_DECELERATION_RATE)
        );
        let cases = [
            (10_001, 0, 0, code::INVALID_VELOCITY_RATE),
            (0, 10_001, 0, code::INVALID_ACCELERATION_RATE),
            (0, 0, 10_001, code::INVALID_JERK_RATE),
        ];
        for (v, a, j, expected) in cases {
            let d = DefaultDynamics {
                velocity_rate: v,
                acceleration_rate: a,
                deceleration_rate: a,
                jerk_rate: j,
            };
            assert_eq!(check_default_dynamics(&d), Err(expected));
        }
    }

    #[test]
    fn reference_dynamics_within_the_robot() {
        let b = bounds();
        let max = ReferenceDynamics {
            velocity_mm_s: b.max_velocity_mm_s as f32,
            acceleration_mm_s2: b.max_acceleration_mm_s2 as f32,
            deceleration_mm_s2: b.max_acceleration_mm_s2 as f32,
            jerk_mm_s3: b.max_jerk_mm_s3 as f32,
        };
        assert_eq!(check_reference_dynamics(&max, &b), Ok(()));
        type Edit = fn(&mut ReferenceDynamics);
        let cases: [(Edit, u16); 5] = [
            (|r| r.velocity_mm_s *= 1.01, codes::INVALID_VELOCITY),
            (|r| r.velocity_mm_s = 0.0, codes::INVALID_VELOCITY),
            (
                |r| r.acceleration_mm_s2 = f32::NAN,
                code::INVALID_ACCELERATION_RATE,
            ),
            (
                |r| r.deceleration_mm_s2 = f32::INFINITY,
                code::INVALID_DECELERATION_RATE,
            ),
            (|r| r.jerk_mm_s3 *= 2.0, code::INVALID_JERK_RATE),
        ];
        for (edit, expected) in cases {
            let mut r = max;
            edit(&mut r);
            assert_eq!(check_reference_dynamics(&r, &b), Err(expected));
        }
    }

    fn mechanical(b: &RobotBounds) -> SwLimits {
        SwLimits {
            lower_deg: b.joint_min_deg.map(wire),
            upper_deg: b.joint_max_deg.map(wire),
        }
    }

    #[test]
    fn sw_limits_inside_the_mechanical_limits() {
        let b = bounds();
        let m = mechanical(&b);
        assert_eq!(check_sw_limits(&m, &b), Ok(()));
        let mut l = m;
        l.lower_deg[1] -= 1.0;
        assert_eq!(check_sw_limits(&l, &b), Err(code::SW_LIMIT_LOWER));
        let mut l = m;
        l.upper_deg[5] += 1.0;
        assert_eq!(check_sw_limits(&l, &b), Err(code::SW_LIMIT_UPPER));
        let mut l = m;
        l.lower_deg[2] = 10.0;
        l.upper_deg[2] = 10.0;
        assert_eq!(check_sw_limits(&l, &b), Err(codes::INDEX_OUT_OF_RANGE));
        let mut l = m;
        l.upper_deg[0] = f32::NAN;
        assert_eq!(check_sw_limits(&l, &b), Err(codes::INDEX_OUT_OF_RANGE));
    }

    proptest! {
        #[test]
        fn accepted_sw_limits_are_inside_the_mechanical_limits(
            lower in proptest::array::uniform6(-800.0f32..800.0),
            upper in proptest::array::uniform6(-800.0f32..800.0),
        ) {
            let b = bounds();
            let l = SwLimits { lower_deg: lower, upper_deg: upper };
            if check_sw_limits(&l, &b).is_ok() {
                for j in 0..6 {
                    prop_assert!(f64::from(lower[j]) >= f64::from(wire(b.joint_min_deg[j])));
                    prop_assert!(f64::from(upper[j]) <= f64::from(wire(b.joint_max_deg[j])));
                    prop_assert!(lower[j] < upper[j]);
                }
            }
        }
    }
}
