//! The pose convention of the whole controller: `[x, y, z, Rx, Ry, Rz]` with the rotation
//! `R = Rz(Rz)·Ry(Ry)·Rx(Rx)` (fixed-axis X-Y-Z angles). Units are the caller's: the
//! processes use m and rad, the SRCI wire mm and degrees.

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};

/// `cos(Ry)` below which the X and Z axes coincide (gimbal lock) and `Rz` is set to 0.
const GIMBAL_LOCK_COS: f64 = 1e-9;

/// The angles `[Rx, Ry, Rz]` with `R = Rz(Rz)·Ry(Ry)·Rx(Rx)`, `Ry` in [−π/2, π/2]. In gimbal
/// lock (`Ry = ±π/2`) only `Rx ∓ Rz` is defined; `Rz` is then reported as 0.
pub fn rpy_from_matrix(r: &Matrix3<f64>) -> [f64; 3] {
    let cos_ry = r[(0, 0)].hypot(r[(1, 0)]);
    let ry = (-r[(2, 0)]).atan2(cos_ry);
    if cos_ry > GIMBAL_LOCK_COS {
        [r[(2, 1)].atan2(r[(2, 2)]), ry, r[(1, 0)].atan2(r[(0, 0)])]
    } else if r[(2, 0)] < 0.0 {
        // Ry = +π/2: the matrix depends on Rx − Rz only, r12 = sin(Rx − Rz), r22 = cos(…).
        [r[(0, 1)].atan2(r[(1, 1)]), ry, 0.0]
    } else {
        // Ry = −π/2: the matrix depends on Rx + Rz only, r12 = −sin(Rx + Rz), r22 = cos(…).
        [(-r[(0, 1)]).atan2(r[(1, 1)]), ry, 0.0]
    }
}

/// The rotation `Rz(rz)·Ry(ry)·Rx(rx)`.
pub fn rotation_from_rpy(rx: f64, ry: f64, rz: f64) -> Rotation3<f64> {
    Rotation3::from_axis_angle(&Vector3::z_axis(), rz)
        * Rotation3::from_axis_angle(&Vector3::y_axis(), ry)
        * Rotation3::from_axis_angle(&Vector3::x_axis(), rx)
}

/// The isometry of the pose `[x, y, z, Rx, Ry, Rz]` (angles in rad).
pub fn isometry(p: [f64; 6]) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(p[0], p[1], p[2]),
        UnitQuaternion::from_rotation_matrix(&rotation_from_rpy(p[3], p[4], p[5])),
    )
}

/// The pose `[x, y, z, Rx, Ry, Rz]` (angles in rad) of an isometry.
pub fn pose(t: &Isometry3<f64>) -> [f64; 6] {
    let v = t.translation.vector;
    let [rx, ry, rz] = rpy_from_matrix(t.rotation.to_rotation_matrix().matrix());
    [v.x, v.y, v.z, rx, ry, rz]
}
