//! Opening the controller's iceoryx2 services with one consistent quality of service.
//!
//! The orchestrator creates every service up front; a service process opens them (or creates
//! them itself when it runs without the orchestrator, e.g. under systemd). Both sides use the
//! same QoS from [`qos`], because an opener asking for more than the creator set fails.

use core::fmt::Debug;
use core::time::Duration;

use iceoryx2::port::listener::{Listener, ListenerWaitError};
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use iceoryx2::service::port_factory::{event, publish_subscribe};

use crate::ipc::{
    MotionCommand, MotionStatus, PlcTelegram, RobotTelegram, ServoControl, ServoFeedback,
    ServoSetpoint, topics,
};

/// The iceoryx2 service variant used throughout (single-threaded ports, no locks).
pub type Ipc = iceoryx2::service::ipc::Service;

/// An iceoryx2 operation failed.
#[derive(Debug, thiserror::Error)]
#[error("iceoryx2: cannot {action} '{service}': {detail}")]
pub struct BusError {
    pub action: &'static str,
    pub service: String,
    pub detail: String,
}

fn bus_error(action: &'static str, service: &str, detail: impl Debug) -> BusError {
    BusError {
        action,
        service: service.to_string(),
        detail: format!("{detail:?}"),
    }
}

/// Capacities of one publish-subscribe topic.
#[derive(Debug, Clone, Copy)]
pub struct Qos {
    /// Samples a (re)connecting subscriber gets at once.
    pub history: usize,
    /// Samples buffered per subscriber before the oldest is overwritten.
    pub buffer: usize,
}

/// The QoS of each topic of [`topics`].
pub fn qos(topic: &str) -> Qos {
    match topic {
        // Latest-state topics: a restarted reader needs the last value at once.
        topics::MOTION_STATUS | topics::SERVO_FEEDBACK | topics::SERVO_CONTROL => Qos {
            history: 1,
            buffer: 4,
        },
        // Commands are acknowledged and re-sent, so a deep buffer only absorbs bursts.
        topics::MOTION_COMMAND => Qos {
            history: 0,
            buffer: 64,
        },
        _ => Qos {
            history: 0,
            buffer: 8,
        },
    }
}

/// Room for a dead process and its restarted successor to overlap, plus tools.
const MAX_NODES: usize = 16;
const MAX_PORTS: usize = 4;

/// One process's connection to the controller's topics.
pub struct Bus {
    node: Node<Ipc>,
    instance: String,
}

impl Bus {
    /// Creates this process's iceoryx2 node. `instance` prefixes every service name so that
    /// several controllers (e.g. parallel tests) never share a topic.
    pub fn new(instance: &str, node_name: &str) -> Result<Self, BusError> {
        let name: NodeName = node_name
            .try_into()
            .map_err(|e| bus_error("name node", node_name, e))?;
        let node = NodeBuilder::new()
            .name(&name)
            .signal_handling_mode(SignalHandlingMode::Disabled)
            .create::<Ipc>()
            .map_err(|e| bus_error("create node", node_name, e))?;
        Ok(Self {
            node,
            instance: instance.to_string(),
        })
    }

    /// The full service name of `topic` for this controller instance.
    pub fn service_name(&self, topic: &str) -> String {
        format!("{}/{}", self.instance, topic)
    }

    /// The iceoryx2 node, for maintenance such as dead-node clean-up.
    pub fn node(&self) -> &Node<Ipc> {
        &self.node
    }

    fn pubsub<T: Debug + ZeroCopySend>(
        &self,
        topic: &str,
    ) -> Result<publish_subscribe::PortFactory<Ipc, T, ()>, BusError> {
        let full = self.service_name(topic);
        let name: ServiceName = full
            .as_str()
            .try_into()
            .map_err(|e| bus_error("name service", &full, e))?;
        let q = qos(topic);
        self.node
            .service_builder(&name)
            .publish_subscribe::<T>()
            .max_publishers(MAX_PORTS)
            .max_subscribers(MAX_PORTS * 2)
            .max_nodes(MAX_NODES)
            .history_size(q.history)
            .subscriber_max_buffer_size(q.buffer)
            .subscriber_max_borrowed_samples(2)
            .enable_safe_overflow(true)
            .open_or_create()
            .map_err(|e| bus_error("open or create", &full, e))
    }

    fn event(&self, topic: &str) -> Result<event::PortFactory<Ipc>, BusError> {
        let full = self.service_name(topic);
        let name: ServiceName = full
            .as_str()
            .try_into()
            .map_err(|e| bus_error("name service", &full, e))?;
        self.node
            .service_builder(&name)
            .event()
            .max_notifiers(MAX_PORTS)
            .max_listeners(MAX_PORTS * 2)
            .max_nodes(MAX_NODES)
            .open_or_create()
            .map_err(|e| bus_error("open or create event", &full, e))
    }

    /// A publisher on `topic`.
    pub fn publisher<T: Debug + ZeroCopySend>(
        &self,
        topic: &str,
    ) -> Result<Publisher<Ipc, T, ()>, BusError> {
        self.pubsub::<T>(topic)?
            .publisher_builder()
            .create()
            .map_err(|e| bus_error("create publisher on", topic, e))
    }

    /// A subscriber on `topic` that receives the topic's history at once.
    pub fn subscriber<T: Debug + ZeroCopySend>(
        &self,
        topic: &str,
    ) -> Result<Subscriber<Ipc, T, ()>, BusError> {
        let q = qos(topic);
        self.pubsub::<T>(topic)?
            .subscriber_builder()
            .buffer_size(q.buffer)
            .history_request(q.history)
            .create()
            .map_err(|e| bus_error("create subscriber on", topic, e))
    }

    /// Number of subscribers connected to `topic` now (e.g. whether a consumer process runs).
    pub fn subscriber_count<T: Debug + ZeroCopySend>(
        &self,
        topic: &str,
    ) -> Result<usize, BusError> {
        Ok(self
            .pubsub::<T>(topic)?
            .dynamic_config()
            .number_of_subscribers())
    }

    /// A notifier for the wake-up event of `topic`.
    pub fn notifier(&self, topic: &str) -> Result<Notifier<Ipc>, BusError> {
        self.event(topic)?
            .notifier_builder()
            .create()
            .map_err(|e| bus_error("create notifier on", topic, e))
    }

    /// A listener for the wake-up event of `topic`.
    pub fn listener(&self, topic: &str) -> Result<Listener<Ipc>, BusError> {
        self.event(topic)?
            .listener_builder()
            .create()
            .map_err(|e| bus_error("create listener on", topic, e))
    }

    /// Creates every service of the controller with its full QoS and returns the handles that
    /// keep them alive (the orchestrator holds them for the controller's lifetime).
    pub fn create_all(&self) -> Result<ServiceHandles, BusError> {
        Ok(ServiceHandles {
            _p2r: self.pubsub::<PlcTelegram>(topics::P2R)?,
            _r2p: self.pubsub::<RobotTelegram>(topics::R2P)?,
            _command: self.pubsub::<MotionCommand>(topics::MOTION_COMMAND)?,
            _status: self.pubsub::<MotionStatus>(topics::MOTION_STATUS)?,
            _setpoint: self.pubsub::<ServoSetpoint>(topics::SERVO_SETPOINT)?,
            _feedback: self.pubsub::<ServoFeedback>(topics::SERVO_FEEDBACK)?,
            _control: self.pubsub::<ServoControl>(topics::SERVO_CONTROL)?,
            _events: topics::WITH_WAKEUP
                .iter()
                .map(|t| self.event(t))
                .collect::<Result<_, _>>()?,
        })
    }

    /// Removes the resources of processes of this machine that died without cleaning up.
    /// Returns the number of dead nodes removed.
    pub fn remove_dead_nodes(&self) -> u64 {
        self.node.try_cleanup_dead_nodes().cleanups
    }
}

/// Keeps the controller's services alive while held.
pub struct ServiceHandles {
    _p2r: publish_subscribe::PortFactory<Ipc, PlcTelegram, ()>,
    _r2p: publish_subscribe::PortFactory<Ipc, RobotTelegram, ()>,
    _command: publish_subscribe::PortFactory<Ipc, MotionCommand, ()>,
    _status: publish_subscribe::PortFactory<Ipc, MotionStatus, ()>,
    _setpoint: publish_subscribe::PortFactory<Ipc, ServoSetpoint, ()>,
    _feedback: publish_subscribe::PortFactory<Ipc, ServoFeedback, ()>,
    _control: publish_subscribe::PortFactory<Ipc, ServoControl, ()>,
    _events: Vec<event::PortFactory<Ipc>>,
}

/// Takes every waiting sample and keeps the newest, for latest-value topics.
/// Bounded by the subscriber's buffer plus borrowed samples.
pub fn receive_latest<T: Debug + ZeroCopySend + Copy>(
    subscriber: &Subscriber<Ipc, T, ()>,
) -> Result<Option<T>, BusError> {
    let mut latest = None;
    for _ in 0..64 {
        match subscriber.receive() {
            Ok(Some(sample)) => latest = Some(*sample.payload()),
            Ok(None) => break,
            Err(e) => return Err(bus_error("receive on", "subscriber", e)),
        }
    }
    Ok(latest)
}

/// Waits up to `timeout` for a wake-up on `listener`; returns whether one came. A signal
/// (e.g. SIGTERM asking the process to stop) ends the wait early without an error, so the
/// caller's loop can look at its shutdown flag.
pub fn wait_for_wakeup(listener: &Listener<Ipc>, timeout: Duration) -> Result<bool, BusError> {
    let mut woken = false;
    match listener.timed_wait(|_| woken = true, timeout) {
        Ok(_) | Err(ListenerWaitError::InterruptSignal) => Ok(woken),
        Err(e) => Err(bus_error("wait on", "listener", e)),
    }
}

/// Publishes `value` on `publisher`.
pub fn publish<T: Debug + ZeroCopySend>(
    publisher: &Publisher<Ipc, T, ()>,
    value: T,
) -> Result<(), BusError> {
    let sample = publisher
        .loan_uninit()
        .map_err(|e| bus_error("loan on", "publisher", e))?;
    sample
        .write_payload(value)
        .send()
        .map_err(|e| bus_error("send on", "publisher", e))?;
    Ok(())
}
