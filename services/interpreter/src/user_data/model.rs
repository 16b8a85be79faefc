//! The user data sets as the SRCI structures define them (ToolData, FrameData, LoadData,
//! DefaultDynamics, ReferenceDynamics, SWLimits), in the units and number types of the wire, so
//! that what a client writes reads back bit for bit.

use serde::{Deserialize, Serialize};

/// Highest tool, frame and load index; user entries are 1..=15, index 0 is fixed.
pub const HIGHEST_INDEX: u8 = 15;
/// User entries per indexed data set (indices 1..=HIGHEST_INDEX).
pub const USER_ENTRIES: usize = HIGHEST_INDEX as usize;
/// ToolNo/FrameNo/LoadNo -1 on the wire: "the one currently used".
pub const CURRENT_INDEX: u8 = 0xFF;

/// X, Y, Z in mm, then Rx, Ry, Rz in degrees (fixed axes X-Y-Z, R = Rz·Ry·Rx).
pub type Pose = [f32; 6];

/// IEC DATE (days since 1990-01-01) and TIME_OF_DAY (ms since midnight) of an entry, as the
/// client wrote them; 0/0 for data the client never wrote.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Timestamp {
    pub date: u16,
    pub time_of_day_ms: u32,
}

/// One entry of a data set with its synchronisation state.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Entry<T> {
    pub timestamp: Timestamp,
    /// Set when the controller changed the entry itself (a restore, a reset to factory
    /// values), cleared when the client writes it (spec 5.6.7.4.2).
    pub data_changed: bool,
    pub data: T,
}

impl<T> Entry<T> {
    /// Data written by the client: DataChanged is cleared.
    pub fn written(timestamp: Timestamp, data: T) -> Self {
        Self {
            timestamp,
            data_changed: false,
            data,
        }
    }

    /// Data the controller set itself (never written by the client: timestamp 0).
    pub fn controller(data: T, data_changed: bool) -> Self {
        Self {
            timestamp: Timestamp::default(),
            data_changed,
            data,
        }
    }
}

/// A tool: the TCP relative to the flange.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToolData {
    pub pose: Pose,
    /// Client's identifier of the physical tool (not interpreted).
    pub id: u8,
    /// The load the tool carries (0 = none).
    pub load_no: u8,
    /// A stationary tool (the robot carries the work piece); not supported, always false.
    pub external_tcp: bool,
}

/// A user frame relative to `reference_frame` (0 = world).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrameData {
    pub reference_frame: u8,
    pub pose: Pose,
}

/// A load on the flange.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LoadData {
    /// Centre of gravity (X, Y, Z in mm) and orientation of the principal axes of inertia
    /// (Rx, Ry, Rz in degrees), relative to the flange.
    pub centre_of_gravity: Pose,
    pub mass_kg: f32,
    /// Moments of inertia about the principal axes Ix, Iy, Iz, in the client's unit (kept, not
    /// interpreted by this controller).
    pub inertia: [f32; 3],
}

/// Rates a move uses when it leaves its own at "default" (0xFFFF), percent × 100 as on the
/// wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DefaultDynamics {
    pub velocity_rate: u16,
    pub acceleration_rate: u16,
    /// Files written before the deceleration had a rate of its own lack it: they load with
    /// `UNSET_RATE` (0xFFFF), which the loader replaces by the acceleration rate they meant.
    #[serde(default = "unset_rate")]
    pub deceleration_rate: u16,
    pub jerk_rate: u16,
}

/// A rate missing from a stored file.
pub const UNSET_RATE: u16 = 0xFFFF;

fn unset_rate() -> u16 {
    UNSET_RATE
}

/// The TCP dynamics that 100 % of a rate means for Cartesian moves.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReferenceDynamics {
    pub velocity_mm_s: f32,
    pub acceleration_mm_s2: f32,
    pub deceleration_mm_s2: f32,
    pub jerk_mm_s3: f32,
}

/// Software joint limits J1..J6 in degrees; always inside the mechanical limits.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SwLimits {
    pub lower_deg: [f32; 6],
    pub upper_deg: [f32; 6],
}

/// The data sets of SRCI data synchronisation that this controller keeps (work areas are not
/// supported).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DataSet {
    Tool,
    Frame,
    Load,
    SwLimits,
    DefaultDynamics,
    ReferenceDynamics,
}

impl DataSet {
    /// Every data set, in the order of the ExchangeConfiguration bits.
    pub const ALL: [DataSet; 6] = [
        DataSet::Tool,
        DataSet::Frame,
        DataSet::Load,
        DataSet::SwLimits,
        DataSet::DefaultDynamics,
        DataSet::ReferenceDynamics,
    ];

    /// Name for messages and logs.
    pub fn name(self) -> &'static str {
        match self {
            DataSet::Tool => "tool data",
            DataSet::Frame => "frame data",
            DataSet::Load => "load data",
            DataSet::SwLimits => "SW limits",
            DataSet::DefaultDynamics => "default dynamics",
            DataSet::ReferenceDynamics => "reference dynamics",
        }
    }
}

/// ChangeIndex of every data set: 0 = unchanged since factory values, then 1..=255 cyclic,
/// one step per change.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChangeIndices {
    pub tool: u8,
    pub frame: u8,
    pub load: u8,
    pub sw_limits: u8,
    pub default_dynamics: u8,
    pub reference_dynamics: u8,
}

impl ChangeIndices {
    /// The ChangeIndex of `set`.
    pub fn get(&self, set: DataSet) -> u8 {
        *self.slot(set)
    }

    /// Counts one change of `set`; after 255 comes 1 (0 only ever means "never changed").
    pub fn bump(&mut self, set: DataSet) {
        let i = self.slot_mut(set);
        *i = if *i == u8::MAX { 1 } else { *i + 1 };
    }

    fn slot(&self, set: DataSet) -> &u8 {
        match set {
            DataSet::Tool => &self.tool,
            DataSet::Frame => &self.frame,
            DataSet::Load => &self.load,
            DataSet::SwLimits => &self.sw_limits,
            DataSet::DefaultDynamics => &self.default_dynamics,
            DataSet::ReferenceDynamics => &self.reference_dynamics,
        }
    }

    fn slot_mut(&mut self, set: DataSet) -> &mut u8 {
        match set {
            DataSet::Tool => &mut self.tool,
            DataSet::Frame => &mut self.frame,
            DataSet::Load => &mut self.load,
            DataSet::SwLimits => &mut self.sw_limits,
            DataSet::DefaultDynamics => &mut self.default_dynamics,
            DataSet::ReferenceDynamics => &mut self.reference_dynamics,
        }
    }
}

/// Everything that is persisted: the user entries 1..=15 of tools, frames and loads (index 0
/// is fixed and never stored), the dynamics, the SW limits and the change indices.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Stored {
    pub change_index: ChangeIndices,
    pub default_dynamics: Entry<DefaultDynamics>,
    pub reference_dynamics: Entry<ReferenceDynamics>,
    pub sw_limits: Entry<SwLimits>,
    pub tools: [Entry<ToolData>; USER_ENTRIES],
    pub frames: [Entry<FrameData>; USER_ENTRIES],
    pub loads: [Entry<LoadData>; USER_ENTRIES],
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn change_index_wraps_from_255_to_1() {
        let mut c = ChangeIndices::default();
        assert_eq!(c.get(DataSet::Load), 0);
        c.bump(DataSet::Load);
        assert_eq!(c.get(DataSet::Load), 1);
        c.load = 254;
        c.bump(DataSet::Load);
        assert_eq!(c.get(DataSet::Load), 255);
        c.bump(DataSet::Load);
        assert_eq!(c.get(DataSet::Load), 1);
        assert_eq!(c.get(DataSet::Tool), 0, "other sets untouched");
    }
}
