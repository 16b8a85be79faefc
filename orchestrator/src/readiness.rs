//! When a service counts as started, so the next one may be spawned.
//!
//! Topics without history lose what is published before a subscriber exists. A service is
//! therefore ready once it has subscribed to the topic its upstream publishes on: the servo to
//! the setpoints, the planner to the motion commands, the interpreter to the PLC telegrams.
//! Starting in that order, the fieldbus (last) only accepts a PLC when every telegram it
//! forwards has a reader.

use core::fmt::Debug;

use iceoryx2::prelude::*;
use iceoryx2::service::port_factory::PortFactory as _;
use iceoryx2::service::port_factory::publish_subscribe::PortFactory;
use shared_types::bus::{Bus, BusError, Ipc};
use shared_types::ipc::{MotionCommand, PlcTelegram, ServoSetpoint, topics};

use crate::service::Service;

/// Watches the subscriber counts of the services' input topics.
pub struct ReadinessProbe {
    setpoint: PortFactory<Ipc, ServoSetpoint, ()>,
    command: PortFactory<Ipc, MotionCommand, ()>,
    p2r: PortFactory<Ipc, PlcTelegram, ()>,
}

impl ReadinessProbe {
    /// Opens the input topics, which [`Bus::create_all`] must have created.
    pub fn new(bus: &Bus) -> Result<Self, BusError> {
        Ok(Self {
            setpoint: open(bus, topics::SERVO_SETPOINT)?,
            command: open(bus, topics::MOTION_COMMAND)?,
            p2r: open(bus, topics::P2R)?,
        })
    }

    /// Whether `service` has subscribed to its input topic. Meant for the first start, when
    /// no other subscriber exists on these topics.
    pub fn is_ready(&self, service: Service) -> bool {
        let subscribers = match service {
            Service::Servo => self.setpoint.dynamic_config().number_of_subscribers(),
            Service::Planner => self.command.dynamic_config().number_of_subscribers(),
            Service::Interpreter => self.p2r.dynamic_config().number_of_subscribers(),
            Service::Fieldbus => return true,
        };
        subscribers > 0
    }
}

/// Opens `topic` as it was created, without asking for any QoS.
fn open<T: Debug + ZeroCopySend>(
    bus: &Bus,
    topic: &str,
) -> Result<PortFactory<Ipc, T, ()>, BusError> {
    let full = bus.service_name(topic);
    let error = |action, detail: String| BusError {
        action,
        service: full.clone(),
        detail,
    };
    let name: ServiceName = full
        .as_str()
        .try_into()
        .map_err(|e| error("name service", format!("{e:?}")))?;
    bus.node()
        .service_builder(&name)
        .publish_subscribe::<T>()
        .open()
        .map_err(|e| error("open", format!("{e:?}")))
}
