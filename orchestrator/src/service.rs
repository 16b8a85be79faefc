//! The service processes the orchestrator starts, in their start order.

use core::fmt;
use core::str::FromStr;

/// One service process of the controller (`rc service <name>`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Service {
    /// The interpolation clock and the (simulated) drives.
    Servo,
    /// Kinematics, motion queue and trajectories.
    Planner,
    /// The SRCI server: state machine, commands and responses.
    Interpreter,
    /// The fieldbus transport towards the PLC.
    Fieldbus,
}

impl Service {
    /// Every service in start order: each one's consumers of its topics come up after it, and
    /// the fieldbus comes last so the PLC can only connect to a complete controller.
    /// Shutdown runs in the reverse order.
    pub const START_ORDER: [Service; 4] = [
        Service::Servo,
        Service::Planner,
        Service::Interpreter,
        Service::Fieldbus,
    ];

    /// The name used on the command line (`rc service <name>`), in logs and in the pid file.
    pub const fn name(self) -> &'static str {
        match self {
            Service::Servo => "servo",
            Service::Planner => "planner",
            Service::Interpreter => "interpreter",
            Service::Fieldbus => "fieldbus",
        }
    }
}

impl fmt::Display for Service {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A name that is not one of [`Service::START_ORDER`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown service '{0}' (known: servo, planner, interpreter, fieldbus)")]
pub struct UnknownService(pub String);

impl FromStr for Service {
    type Err = UnknownService;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Service::START_ORDER
            .into_iter()
            .find(|service| service.name() == s)
            .ok_or_else(|| UnknownService(s.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for service in Service::START_ORDER {
            assert_eq!(service.name().parse::<Service>(), Ok(service));
        }
        assert!("robot".parse::<Service>().is_err());
    }
}
