//! The robot configurations the tests run on: every embedded robot file.

use shared_types::config::{Config, EMBEDDED_ROBOTS, RobotConfig};

use shared_types::ipc::AXES;

use super::{ArmGeometry, Kinematics};

/// One robot under test.
pub struct Robot {
    pub config: RobotConfig,
    pub kinematics: Kinematics,
    pub geometry: ArmGeometry,
}

/// Every robot of `config/robots`, starting with the one of the default configuration.
pub fn all() -> Vec<Robot> {
    let default = Config::load(None).expect("embedded configuration").robot;
    let embedded = EMBEDDED_ROBOTS
        .iter()
        .map(|(name, text)| toml::from_str::<RobotConfig>(text).expect(name));
    core::iter::once(default)
        .chain(embedded)
        .map(|config| Robot {
            kinematics: Kinematics::new(&config.kinematics),
            geometry: ArmGeometry::new(&config.kinematics).expect(&config.name),
            config,
        })
        .collect()
}

/// The robot of the default configuration (JAKA Zu 7).
pub fn default() -> Robot {
    all().swap_remove(0)
}

/// Joints whose pose has eight regular inverse kinematics branches, for every shipped robot.
pub fn regular(geometry: &ArmGeometry) -> [f64; AXES] {
    [0.3, -0.3 * geometry.a2.signum(), 1.05, -0.7, 1.1, 0.2]
}

/// Joints with the wrist point on the shoulder-singular line and the elbow and wrist regular:
/// θ2 with a2·c2 + a3·c23 = 0 puts J4 over the J1 axis line, θ234 = 0 points J5 (and so d5)
/// vertically, keeping the wrist point there.
pub fn shoulder_singular(geometry: &ArmGeometry) -> [f64; AXES] {
    let (a2, a3) = (geometry.a2, geometry.a3);
    let t3: f64 = 1.0;
    let t2 = (a2 + a3 * t3.cos()).atan2(a3 * t3.sin());
    [0.4, t2, t3, -t2 - t3, 0.9, 0.0]
}
