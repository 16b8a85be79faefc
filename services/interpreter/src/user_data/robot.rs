//! What the user data must respect of the robot: mechanical joint limits, rated payload and
//! the Cartesian maxima, taken from the robot configuration.

use shared_types::config::RobotConfig;

use super::warning::UserDataWarning;

/// Rated payloads in kg of the robots in `config/robots/`, by their `name`. The robot files
/// carry no payload (yet), so it lives here; the numbers are the manufacturers' rated payloads
/// (JAKA Zu N: N kg; UR5e: 5 kg).
const RATED_PAYLOADS_KG: [(&str, f64); 6] = [
    ("JAKA Zu 3", 3.0),
    ("JAKA Zu 5", 5.0),
    ("JAKA Zu 7", 7.0),
    ("JAKA Zu 12", 12.0),
    ("JAKA Zu 18", 18.0),
    ("UR5e", 5.0),
];

/// Payload assumed for a robot the table does not list: the smallest of the supported
/// cobots, so that no load heavier than any of them is accepted.
pub const UNLISTED_ROBOT_PAYLOAD_KG: f64 = 3.0;

/// The robot-given bounds of the user data.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotBounds {
    /// Robot name, stored with the data so that another robot's SW limits are not taken over.
    pub name: String,
    pub joint_min_deg: [f64; 6],
    pub joint_max_deg: [f64; 6],
    pub payload_kg: f64,
    pub max_velocity_mm_s: f64,
    pub max_acceleration_mm_s2: f64,
    pub max_jerk_mm_s3: f64,
}

impl RobotBounds {
    /// The bounds of `robot`, with a warning if its payload is not known and assumed.
    pub fn of(robot: &RobotConfig) -> (Self, Option<UserDataWarning>) {
        let listed = RATED_PAYLOADS_KG
            .iter()
            .find(|(name, _)| *name == robot.name)
            .map(|&(_, kg)| kg);
        let warning = listed.is_none().then(|| UserDataWarning::PayloadUnknown {
            robot: robot.name.clone(),
            assumed_kg: UNLISTED_ROBOT_PAYLOAD_KG,
        });
        let bounds = Self {
            name: robot.name.clone(),
            joint_min_deg: robot.joints.min_deg,
            joint_max_deg: robot.joints.max_deg,
            payload_kg: listed.unwrap_or(UNLISTED_ROBOT_PAYLOAD_KG),
            max_velocity_mm_s: robot.cartesian.max_velocity_mm_s,
            max_acceleration_mm_s2: robot.cartesian.max_acceleration_mm_s2,
            max_jerk_mm_s3: robot.cartesian.max_jerk_mm_s3,
        };
        (bounds, warning)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared_types::config::{Config, EMBEDDED_ROBOTS};

    #[test]
    fn every_embedded_robot_has_a_rated_payload() {
        let mut robot = Config::load(None).unwrap().robot;
        for (file, text) in EMBEDDED_ROBOTS {
            let name = text
                .lines()
                .find_map(|l| l.strip_prefix("name = "))
                .unwrap()
                .trim_matches('"');
            robot.name = name.to_string();
            let (bounds, warning) = RobotBounds::of(&robot);
            assert!(warning.is_none(), "{file}: {name} has no payload");
            assert!(bounds.payload_kg >= UNLISTED_ROBOT_PAYLOAD_KG);
        }
    }

    #[test]
    fn an_unlisted_robot_gets_the_smallest_payload_and_a_warning() {
        let mut robot = Config::load(None).unwrap().robot;
        robot.name = "Custom arm".into();
        let (bounds, warning) = RobotBounds::of(&robot);
        assert_eq!(bounds.payload_kg, UNLISTED_ROBOT_PAYLOAD_KG);
        assert!(matches!(
            warning,
            Some(UserDataWarning::PayloadUnknown { .. })
        ));
    }
}
