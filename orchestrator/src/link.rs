//! The supervisor's side of the bus: the services' health topics, the control topic, the
//! status topic, and the removal of dead iceoryx2 nodes. Behind a trait so the supervisor can
//! be tested with plain processes and a simulated bus.

use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use shared_types::bus::{self, Bus, BusError, Ipc};
use shared_types::health::{
    SERVICES, Service, ServiceHealth, SupervisionRequest, SupervisionStatus, topics,
};

/// Requests taken per poll (the depth of the control topic's buffer and then some).
const REQUEST_BATCH: usize = 16;

/// What the supervisor hears and says.
pub(crate) trait SupervisionLink {
    /// Appends the newest health sample of each service that published since the last call.
    fn receive_health(&mut self, into: &mut Vec<ServiceHealth>) -> Result<(), BusError>;
    /// Appends the requests that arrived since the last call.
    fn receive_requests(&mut self, into: &mut Vec<SupervisionRequest>) -> Result<(), BusError>;
    /// Publishes the supervision status.
    fn publish_status(&mut self, status: SupervisionStatus) -> Result<(), BusError>;
    /// Removes the iceoryx2 resources of dead processes; returns how many nodes.
    fn remove_dead_nodes(&mut self) -> u64;
}

/// The link over the controller's iceoryx2 topics.
pub(crate) struct BusLink<'a> {
    bus: &'a Bus,
    health: [Subscriber<Ipc, ServiceHealth, ()>; SERVICES],
    control: Subscriber<Ipc, SupervisionRequest, ()>,
    status: Publisher<Ipc, SupervisionStatus, ()>,
}

impl<'a> BusLink<'a> {
    /// Opens (creating them if needed) the health, control and status topics.
    pub(crate) fn open(bus: &'a Bus) -> Result<Self, BusError> {
        let [servo, planner, interpreter, fieldbus] =
            Service::START_ORDER.map(|s| bus.subscriber::<ServiceHealth>(s.health_topic()));
        Ok(Self {
            bus,
            health: [servo?, planner?, interpreter?, fieldbus?],
            control: bus.subscriber::<SupervisionRequest>(topics::SUPERVISION_CONTROL)?,
            status: bus.publisher::<SupervisionStatus>(topics::SUPERVISION_STATUS)?,
        })
    }
}

impl SupervisionLink for BusLink<'_> {
    fn receive_health(&mut self, into: &mut Vec<ServiceHealth>) -> Result<(), BusError> {
        for subscriber in &self.health {
            if let Some(health) = bus::receive_latest(subscriber)? {
                into.push(health);
            }
        }
        Ok(())
    }

    fn receive_requests(&mut self, into: &mut Vec<SupervisionRequest>) -> Result<(), BusError> {
        for _ in 0..REQUEST_BATCH {
            match self.control.receive() {
                Ok(Some(sample)) => into.push(*sample.payload()),
                Ok(None) => break,
                Err(e) => {
                    return Err(BusError {
                        action: "receive on",
                        service: topics::SUPERVISION_CONTROL.to_string(),
                        detail: format!("{e:?}"),
                    });
                }
            }
        }
        Ok(())
    }

    fn publish_status(&mut self, status: SupervisionStatus) -> Result<(), BusError> {
        bus::publish(&self.status, status)
    }

    fn remove_dead_nodes(&mut self) -> u64 {
        self.bus.remove_dead_nodes()
    }
}
