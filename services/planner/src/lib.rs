//! The planner service: joint-space point-to-point and Cartesian straight-line moves for the
//! SRCI controller.
//!
//! Pure cores: [`profile`] (the double-S path profile, with separate acceleration and
//! deceleration), [`joint_move`] (synchronized PTP moves), [`linear_move`] (straight lines
//! of the TCP, followed by the analytic inverse kinematics), [`brake`] (stops on the path),
//! [`motion`] (one tick of commanded motion on either path), [`queue`] (the moves of
//! one sequence), [`sequences`] (the primary and the secondary sequence), [`events`]
//! (paced job events), [`executor`] (the per-tick state machine) and
//! [`kinematics`] (forward kinematics, Jacobian, analytic inverse kinematics, configuration
//! bits and turn numbers). [`service`] is the process loop around them.

pub mod brake;
pub mod events;
pub mod executor;
pub mod joint_move;
pub mod kinematics;
pub mod linear_move;
pub mod motion;
pub mod profile;
pub mod queue;
pub mod safety_filter;
pub mod sequences;
pub mod service;
#[cfg(test)]
mod test_support;

pub use service::{PlannerError, run};
