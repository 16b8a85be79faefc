//! The planner service: joint-space point-to-point moves for the SRCI controller.
//!
//! Pure cores: [`profile`] (the double-S path profile), [`joint_move`] (synchronized PTP
//! moves), [`brake`] (stops on the path), [`motion`] (one tick of commanded motion),
//! [`queue`] (the primary sequence), [`events`] (paced job events), [`executor`] (the
//! per-tick state machine) and [`kinematics`] (forward kinematics, Jacobian, analytic
//! inverse kinematics, configuration bits and turn numbers). [`service`] is the
//! process loop around them.

pub mod brake;
pub mod events;
pub mod executor;
pub mod joint_move;
pub mod kinematics;
pub mod motion;
pub mod profile;
pub mod queue;
pub mod service;

pub use service::{PlannerError, run};
