//! The user data of the robot controller: tools, frames and loads 1..=15, default and
//! reference dynamics and SW limits, with the client's timestamps, DataChanged flags and
//! ChangeIndex counters of SRCI data synchronisation (spec 5.6.7).
//!
//! [`UserData`] is the pure store; [`srci`] executes the twelve Read/Write functions against
//! it; [`persistence`] keeps it in one file in the data folder and saves it from a thread of
//! its own.

pub mod codes;
mod model;
pub mod persistence;
mod robot;
mod rules;
pub mod srci;
mod store;
mod warning;

pub use model::{
    CURRENT_INDEX, ChangeIndices, DataSet, DefaultDynamics, Entry, FrameData, HIGHEST_INDEX,
    LoadData, Pose, ReferenceDynamics, Stored, SwLimits, Timestamp, ToolData, USER_ENTRIES,
};
pub use persistence::Saver;
pub use robot::{RobotBounds, UNLISTED_ROBOT_PAYLOAD_KG};
pub use store::{DefaultDynamicsRequest, DefaultRates, SwLimitsRad, UserData};
pub use warning::{PersistError, UserDataWarning};
