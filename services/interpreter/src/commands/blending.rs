//! BlendingMode and BlendingParameter[0..1] of a move: how it passes into the next move of
//! its sequence, checked and converted to the planner's SI units.

use shared_types::srci::message::code;

/// EXACT_STOP: the move ends at rest; its parameters mean nothing.
const EXACT_STOP: u8 = 0;
/// DEFINED_VELOCITY and RAMP_OVERLAP: parameters in percent.
const PERCENT_MODES: [u8; 2] = [2, 11];
/// CORNER_DISTANCE, MAX_CORNER_DEVIATION, CORNER_DISTANCE_2R, CORNER_DISTANCE_1R:
/// parameters in mm.
const DISTANCE_MODES: [u8; 4] = [3, 4, 10, 12];

/// A checked blending request: the wire mode and its parameters in SI units (fractions for
/// the percent modes, metres for the distance modes, zero for exact stop).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Blending {
    pub mode: u8,
    pub parameter: [f64; 2],
}

/// Checks `mode` (0x8D03 for values the specification does not define) and `parameter`
/// (0x8D04 when one is negative, not a number, or a percentage above 100).
pub fn decode(mode: u8, parameter: [f32; 2]) -> Result<Blending, u16> {
    let (scale, max) = if mode == EXACT_STOP {
        return Ok(Blending {
            mode,
            parameter: [0.0; 2],
        });
    } else if PERCENT_MODES.contains(&mode) {
        (0.01, 100.0)
    } else if DISTANCE_MODES.contains(&mode) {
        (0.001, f64::INFINITY)
    } else {
        return Err(code::INVALID_BLENDING_MODE);
    };
    let mut si = [0.0; 2];
    for (out, &wire) in si.iter_mut().zip(&parameter) {
        let value = f64::from(wire);
        if !value.is_finite() || !(0.0..=max).contains(&value) {
            return Err(code::INVALID_BLENDING_PARAMETER);
        }
        *out = value * scale;
    }
    Ok(Blending {
        mode,
        parameter: si,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn modes_of_the_specification_are_accepted_in_si_units() {
        assert_eq!(
            decode(0, [f32::NAN, -3.0]),
            Ok(Blending {
                mode: 0,
                parameter: [0.0; 2]
            })
        );
        let percent = decode(11, [50.0, 100.0]).unwrap();
        assert_eq!(percent.parameter, [0.5, 1.0]);
        let radius = decode(3, [25.0, 0.0]).unwrap();
        assert!((radius.parameter[0] - 0.025).abs() < 1e-12);
        for mode in [2, 4, 10, 12] {
            assert_eq!(decode(mode, [10.0, 0.0]).unwrap().mode, mode);
        }
    }

    #[test]
    fn undefined_modes_and_bad_parameters_are_refused_with_their_codes() {
        for mode in [1, 5, 9, 13, 255] {
            assert_eq!(decode(mode, [0.0; 2]), Err(code::INVALID_BLENDING_MODE));
        }
        for parameter in [
            [-1.0, 0.0],
            [f32::NAN, 0.0],
            [0.0, f32::INFINITY],
            [0.0, -0.5],
        ] {
            assert_eq!(decode(3, parameter), Err(code::INVALID_BLENDING_PARAMETER));
        }
        assert_eq!(
            decode(2, [100.5, 0.0]),
            Err(code::INVALID_BLENDING_PARAMETER)
        );
        assert!(
            decode(3, [1000.0, 0.0]).is_ok(),
            "a distance has no upper bound"
        );
    }

    proptest! {
        #[test]
        fn accepted_parameters_are_finite_and_not_negative(
            mode in any::<u8>(),
            p in prop::array::uniform2(any::<f32>()),
        ) {
            if let Ok(b) = decode(mode, p) {
                prop_assert!(b.parameter.iter().all(|v| v.is_finite() && *v >= 0.0));
                prop_assert!(
                    !PERCENT_MODES.contains(&mode) || b.parameter.iter().all(|v| *v <= 1.0)
                );
            }
        }
    }
}
