//! The planner service: joint-space point-to-point moves, Cartesian lines and arcs, blends
//! and waits for the SRCI controller.
//!
//! Pure cores: [`profile`] (the double-S path profile, with separate acceleration and
//! deceleration), [`joint_move`] (synchronized PTP moves), [`cartesian_path`] (straight
//! lines and arcs of the TCP), [`linear_move`] (Cartesian paths followed by the analytic
//! inverse kinematics, or with the wrist joints interpolated: [`wrist_interpolation`]),
//! [`topp`] (their time-optimal timing by reachability analysis, with a conic cross-check
//! on clarabel), [`joint_distance`] (the TCP's distance left on a joint move), [`targets`] (relative targets made absolute), [`blend`] (the overlap of
//! two moves for every BlendingMode), [`brake`] (stops on the path with constant bounds), [`scale_brake`] (stops on the time scale of a
//! time-optimal table), [`motion`] (one tick
//! of commanded motion), [`safety_filter`] (the last guard of every point before the
//! servo), [`queue`] (the moves of one sequence), [`refinement`] (time-optimal tables of buffered
//! lines, planned off the tick),
//! [`sequences`] (the primary and the secondary sequence), [`events`] (paced job events),
//! [`executor`] (the per-tick state machine) and [`kinematics`] (forward kinematics,
//! Jacobian, analytic inverse kinematics, configuration bits and turn numbers). [`service`]
//! is the process loop around them.

pub mod blend;
pub mod brake;
pub mod cartesian_path;
pub mod events;
pub mod executor;
pub mod joint_distance;
pub mod joint_move;
pub mod kinematics;
pub mod linear_move;
pub mod motion;
pub mod path_stop;
pub mod path_warp;
pub mod profile;
pub mod queue;
pub mod refinement;
pub mod safety_filter;
pub mod scale_brake;
pub mod sequences;
pub mod service;
pub mod targets;
#[cfg(test)]
mod test_support;
pub mod time_scale;
pub mod topp;
pub mod wrist_interpolation;

pub use service::{PlannerError, run};
