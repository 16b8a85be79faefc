//! The user data store: reads resolve indices, writes check the rules, keep the client's
//! timestamp, clear DataChanged, count the ChangeIndex and mark the data for saving. Pure: no
//! I/O, no clock, no allocation after construction.

use shared_types::srci::message::code;

use super::codes;
use super::model::{
    CURRENT_INDEX, ChangeIndices, DataSet, DefaultDynamics, Entry, FrameData, HIGHEST_INDEX,
    LoadData, ReferenceDynamics, Stored, SwLimits, Timestamp, ToolData, UNSET_RATE, USER_ENTRIES,
};
use super::robot::RobotBounds;
use super::rules;

/// Default rates of a new controller: half speed and acceleration, full jerk.
const FACTORY_DEFAULT_DYNAMICS: DefaultDynamics = DefaultDynamics {
    velocity_rate: 5_000,
    acceleration_rate: 5_000,
    deceleration_rate: 5_000,
    jerk_rate: rules::FULL_RATE,
};

/// "Use the default" in a percent field: in WriteRobotDefaultDynamics, keep the value.
const KEEP_RATE: u16 = 0xFFFF;

/// Joint limits a motion must stay within, in rad.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SwLimitsRad {
    pub lower: [f64; 6],
    pub upper: [f64; 6],
}

/// The default dynamics in percent (0..=100), for moves that leave a rate at default.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DefaultRates {
    pub velocity: f64,
    pub acceleration: f64,
    /// Always equal to `acceleration`: the planner decelerates as it accelerates.
    pub deceleration: f64,
    pub jerk: f64,
}

/// WriteRobotDefaultDynamics as received: percent × 100, 0xFFFF = keep the current value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DefaultDynamicsRequest {
    pub velocity_rate: u16,
    pub acceleration_rate: u16,
    pub deceleration_rate: u16,
    pub jerk_rate: u16,
}

/// Tools, frames, loads, dynamics and SW limits of the robot, with the tool and frame in use.
#[derive(Debug, Clone)]
pub struct UserData {
    stored: Stored,
    bounds: RobotBounds,
    current_tool: u8,
    current_frame: u8,
    unsaved: bool,
}

/// The values of a new controller for `bounds`: zero tools, frames and loads, SW limits at
/// the mechanical limits, reference dynamics at the robot's maxima.
fn factory(bounds: &RobotBounds) -> Stored {
    Stored {
        change_index: ChangeIndices::default(),
        default_dynamics: Entry::controller(FACTORY_DEFAULT_DYNAMICS, false),
        reference_dynamics: Entry::controller(factory_reference_dynamics(bounds), false),
        sw_limits: Entry::controller(factory_sw_limits(bounds), false),
        tools: [Entry::default(); USER_ENTRIES],
        frames: [Entry::default(); USER_ENTRIES],
        loads: [Entry::default(); USER_ENTRIES],
    }
}

fn factory_sw_limits(bounds: &RobotBounds) -> SwLimits {
    SwLimits {
        lower_deg: bounds.joint_min_deg.map(|v| v as f32),
        upper_deg: bounds.joint_max_deg.map(|v| v as f32),
    }
}

fn factory_reference_dynamics(bounds: &RobotBounds) -> ReferenceDynamics {
    ReferenceDynamics {
        velocity_mm_s: bounds.max_velocity_mm_s as f32,
        acceleration_mm_s2: bounds.max_acceleration_mm_s2 as f32,
        deceleration_mm_s2: bounds.max_acceleration_mm_s2 as f32,
        jerk_mm_s3: bounds.max_jerk_mm_s3 as f32,
    }
}

/// An entry the controller reset to `data`: the client is told with DataChanged.
fn reset<T>(data: T) -> Entry<T> {
    Entry::controller(data, true)
}

/// The code of an invalid index of `set`.
fn invalid_index(set: DataSet) -> u16 {
    match set {
        DataSet::Frame => code::INVALID_FRAME_NO,
        DataSet::Load => codes::INVALID_LOAD_NO,
        _ => code::INVALID_TOOL_NO,
    }
}

/// A read index: 0..=15, or -1 for the one in use.
fn resolve(index: u8, current: u8, set: DataSet) -> Result<u8, u16> {
    match index {
        CURRENT_INDEX => Ok(current),
        i if i <= HIGHEST_INDEX => Ok(i),
        _ => Err(invalid_index(set)),
    }
}

/// A write index: 1..=15 (0 is fixed, -1 is refused so that no write lands on whatever
/// happens to be in use); returns the slot in the user entries.
fn user_slot(index: u8, set: DataSet) -> Result<usize, u16> {
    match index {
        1..=HIGHEST_INDEX => Ok(usize::from(index) - 1),
        _ => Err(invalid_index(set)),
    }
}

/// Entry `index` (0..=15): index 0 is the fixed zero entry (flange, world, no load).
fn entry<T: Copy + Default>(user: &[Entry<T>; USER_ENTRIES], index: u8) -> Entry<T> {
    match index {
        0 => Entry::default(),
        i => user[usize::from(i) - 1],
    }
}

impl UserData {
    /// The factory values for the robot of `bounds`.
    pub fn factory(bounds: RobotBounds) -> Self {
        Self {
            stored: factory(&bounds),
            bounds,
            current_tool: 0,
            current_frame: 0,
            unsaved: false,
        }
    }

    /// Factory values after the saved data was lost: every entry has DataChanged set and
    /// every ChangeIndex moves on, so a client sees that its copy is no longer the robot's.
    pub(super) fn restored(bounds: RobotBounds) -> Self {
        let mut data = Self::factory(bounds);
        let s = &mut data.stored;
        s.default_dynamics.data_changed = true;
        s.reference_dynamics.data_changed = true;
        s.sw_limits.data_changed = true;
        for e in &mut s.tools {
            e.data_changed = true;
        }
        for e in &mut s.frames {
            e.data_changed = true;
        }
        for e in &mut s.loads {
            e.data_changed = true;
        }
        for set in DataSet::ALL {
            s.change_index.bump(set);
        }
        data.unsaved = true;
        data
    }

    /// Data loaded from a file saved for robot `saved_for`. Entries that break a rule of this
    /// robot (or SW limits saved for another robot) are reset to factory values with
    /// DataChanged set; returns the data sets that were reset.
    pub(super) fn from_stored(
        stored: Stored,
        saved_for: &str,
        bounds: RobotBounds,
    ) -> (Self, Vec<DataSet>) {
        let mut s = stored;
        let mut adjusted = Vec::new();
        let mut mark = |set: DataSet, changes: &mut ChangeIndices| {
            if !adjusted.contains(&set) {
                adjusted.push(set);
                changes.bump(set);
            }
        };
        for i in 0..USER_ENTRIES {
            if rules::check_tool(&s.tools[i].data).is_err() {
                s.tools[i] = reset(ToolData::default());
                mark(DataSet::Tool, &mut s.change_index);
            }
            if rules::check_load(&s.loads[i].data, &bounds).is_err() {
                s.loads[i] = reset(LoadData::default());
                mark(DataSet::Load, &mut s.change_index);
            }
            // Indices 1..=15 fit a u8.
            let index = i as u8 + 1;
            if rules::check_frame(&s.frames, index, &s.frames[i].data).is_err() {
                s.frames[i] = reset(FrameData::default());
                mark(DataSet::Frame, &mut s.change_index);
            }
        }
        let d = &mut s.default_dynamics.data;
        if d.deceleration_rate == UNSET_RATE {
            d.deceleration_rate = d.acceleration_rate;
        }
        if rules::check_default_dynamics(d).is_err() {
            s.default_dynamics = reset(FACTORY_DEFAULT_DYNAMICS);
            mark(DataSet::DefaultDynamics, &mut s.change_index);
        }
        if rules::check_reference_dynamics(&s.reference_dynamics.data, &bounds).is_err() {
            s.reference_dynamics = reset(factory_reference_dynamics(&bounds));
            mark(DataSet::ReferenceDynamics, &mut s.change_index);
        }
        if saved_for != bounds.name || rules::check_sw_limits(&s.sw_limits.data, &bounds).is_err() {
            s.sw_limits = reset(factory_sw_limits(&bounds));
            mark(DataSet::SwLimits, &mut s.change_index);
        }
        let data = Self {
            stored: s,
            bounds,
            current_tool: 0,
            current_frame: 0,
            unsaved: !adjusted.is_empty(),
        };
        (data, adjusted)
    }

    /// The robot the data belongs to.
    pub fn robot(&self) -> &RobotBounds {
        &self.bounds
    }

    /// Tool `index` (0..=15, or -1 = the tool in use) with its number.
    pub fn read_tool(&self, index: u8) -> Result<(u8, Entry<ToolData>), u16> {
        let i = resolve(index, self.current_tool, DataSet::Tool)?;
        Ok((i, entry(&self.stored.tools, i)))
    }

    /// Frame `index` (0..=15, or -1 = the frame in use) with its number.
    pub fn read_frame(&self, index: u8) -> Result<(u8, Entry<FrameData>), u16> {
        let i = resolve(index, self.current_frame, DataSet::Frame)?;
        Ok((i, entry(&self.stored.frames, i)))
    }

    /// Load `index` (0..=15, or -1 = the load of the tool in use) with its number.
    pub fn read_load(&self, index: u8) -> Result<(u8, Entry<LoadData>), u16> {
        let i = resolve(index, self.current_load(), DataSet::Load)?;
        Ok((i, entry(&self.stored.loads, i)))
    }

    /// The tool moves use (0 = flange).
    pub fn current_tool(&self) -> u8 {
        self.current_tool
    }

    /// The frame moves refer to (0 = world).
    pub fn current_frame(&self) -> u8 {
        self.current_frame
    }

    /// The load the tool in use carries (0 = none).
    pub fn current_load(&self) -> u8 {
        entry(&self.stored.tools, self.current_tool).data.load_no
    }

    /// Makes tool `index` (0..=15; -1 keeps the current one) the tool in use; returns it.
    pub fn select_tool(&mut self, index: u8) -> Result<u8, u16> {
        self.current_tool = resolve(index, self.current_tool, DataSet::Tool)?;
        Ok(self.current_tool)
    }

    /// Makes frame `index` (0..=15; -1 keeps the current one) the frame in use; returns it.
    pub fn select_frame(&mut self, index: u8) -> Result<u8, u16> {
        self.current_frame = resolve(index, self.current_frame, DataSet::Frame)?;
        Ok(self.current_frame)
    }

    /// WriteToolData; the tool in use cannot change while the robot moves.
    pub fn write_tool(
        &mut self,
        index: u8,
        timestamp: Timestamp,
        data: ToolData,
        moving: bool,
    ) -> Result<(), u16> {
        let slot = user_slot(index, DataSet::Tool)?;
        if moving && index == self.current_tool {
            return Err(codes::TOOL_IN_MOTION);
        }
        rules::check_tool(&data)?;
        self.stored.tools[slot] = Entry::written(timestamp, data);
        self.changed(DataSet::Tool);
        Ok(())
    }

    /// WriteFrameData; the frame's reference chain must end in the world.
    pub fn write_frame(
        &mut self,
        index: u8,
        timestamp: Timestamp,
        data: FrameData,
    ) -> Result<(), u16> {
        let slot = user_slot(index, DataSet::Frame)?;
        rules::check_frame(&self.stored.frames, index, &data)?;
        self.stored.frames[slot] = Entry::written(timestamp, data);
        self.changed(DataSet::Frame);
        Ok(())
    }

    /// WriteLoadData; the load in use cannot change while the robot moves.
    pub fn write_load(
        &mut self,
        index: u8,
        timestamp: Timestamp,
        data: LoadData,
        moving: bool,
    ) -> Result<(), u16> {
        let slot = user_slot(index, DataSet::Load)?;
        if moving && index == self.current_load() {
            return Err(codes::LOAD_IN_MOTION);
        }
        rules::check_load(&data, &self.bounds)?;
        self.stored.loads[slot] = Entry::written(timestamp, data);
        self.changed(DataSet::Load);
        Ok(())
    }

    /// ReadRobotDefaultDynamics.
    pub fn default_dynamics(&self) -> Entry<DefaultDynamics> {
        self.stored.default_dynamics
    }

    /// WriteRobotDefaultDynamics; returns the values now in effect.
    pub fn write_default_dynamics(
        &mut self,
        timestamp: Timestamp,
        request: DefaultDynamicsRequest,
    ) -> Result<DefaultDynamics, u16> {
        let current = self.stored.default_dynamics.data;
        let keep = |wire: u16, current: u16| if wire == KEEP_RATE { current } else { wire };
        let data = DefaultDynamics {
            velocity_rate: keep(request.velocity_rate, current.velocity_rate),
            acceleration_rate: keep(request.acceleration_rate, current.acceleration_rate),
            deceleration_rate: keep(request.deceleration_rate, current.deceleration_rate),
            jerk_rate: keep(request.jerk_rate, current.jerk_rate),
        };
        rules::check_default_dynamics(&data)?;
        self.stored.default_dynamics = Entry::written(timestamp, data);
        self.changed(DataSet::DefaultDynamics);
        Ok(data)
    }

    /// ReadRobotReferenceDynamics.
    pub fn reference_dynamics(&self) -> Entry<ReferenceDynamics> {
        self.stored.reference_dynamics
    }

    /// WriteRobotReferenceDynamics: values below 0 keep the current one ("do not change");
    /// returns the values now in effect.
    pub fn write_reference_dynamics(
        &mut self,
        timestamp: Timestamp,
        request: ReferenceDynamics,
    ) -> Result<ReferenceDynamics, u16> {
        let current = self.stored.reference_dynamics.data;
        let keep = |v: f32, current: f32| if v.is_finite() && v < 0.0 { current } else { v };
        let data = ReferenceDynamics {
            velocity_mm_s: keep(request.velocity_mm_s, current.velocity_mm_s),
            acceleration_mm_s2: keep(request.acceleration_mm_s2, current.acceleration_mm_s2),
            deceleration_mm_s2: keep(request.deceleration_mm_s2, current.deceleration_mm_s2),
            jerk_mm_s3: keep(request.jerk_mm_s3, current.jerk_mm_s3),
        };
        rules::check_reference_dynamics(&data, &self.bounds)?;
        self.stored.reference_dynamics = Entry::written(timestamp, data);
        self.changed(DataSet::ReferenceDynamics);
        Ok(data)
    }

    /// ReadRobotSWLimits (J1..J6; the robot has no external axes).
    pub fn sw_limits(&self) -> Entry<SwLimits> {
        self.stored.sw_limits
    }

    /// WriteRobotSWLimits; `None` (ResetToFactoryDefault) restores the mechanical limits and
    /// sets DataChanged, since the values are the controller's, not the client's.
    pub fn write_sw_limits(
        &mut self,
        timestamp: Timestamp,
        request: Option<SwLimits>,
    ) -> Result<(), u16> {
        let entry = match request {
            Some(limits) => {
                rules::check_sw_limits(&limits, &self.bounds)?;
                Entry::written(timestamp, limits)
            }
            None => Entry {
                timestamp,
                data_changed: true,
                data: factory_sw_limits(&self.bounds),
            },
        };
        self.stored.sw_limits = entry;
        self.changed(DataSet::SwLimits);
        Ok(())
    }

    /// The SW limits in rad, never outside the mechanical limits.
    pub fn sw_limits_rad(&self) -> SwLimitsRad {
        let l = self.stored.sw_limits.data;
        let b = &self.bounds;
        SwLimitsRad {
            lower: core::array::from_fn(|j| {
                f64::from(l.lower_deg[j])
                    .max(b.joint_min_deg[j])
                    .to_radians()
            }),
            upper: core::array::from_fn(|j| {
                f64::from(l.upper_deg[j])
                    .min(b.joint_max_deg[j])
                    .to_radians()
            }),
        }
    }

    /// The reference dynamics as shares of the robot's TCP limits (velocity, acceleration,
    /// deceleration, jerk), each in (0, 1]: what 100 % of a rate means for the TCP.
    pub fn reference_shares(&self) -> [f64; 4] {
        let r = self.stored.reference_dynamics.data;
        let b = &self.bounds;
        // The stored values are checked against the bounds; f32 rounding aside.
        let share = |value: f32, max: f64| (f64::from(value) / max).clamp(f64::MIN_POSITIVE, 1.0);
        [
            share(r.velocity_mm_s, b.max_velocity_mm_s),
            share(r.acceleration_mm_s2, b.max_acceleration_mm_s2),
            share(r.deceleration_mm_s2, b.max_acceleration_mm_s2),
            share(r.jerk_mm_s3, b.max_jerk_mm_s3),
        ]
    }

    /// The default dynamics in percent.
    pub fn default_rates(&self) -> DefaultRates {
        let d = self.stored.default_dynamics.data;
        let percent = |v: u16| f64::from(v) / 100.0;
        DefaultRates {
            velocity: percent(d.velocity_rate),
            acceleration: percent(d.acceleration_rate),
            deceleration: percent(d.deceleration_rate),
            jerk: percent(d.jerk_rate),
        }
    }

    /// ChangeIndex of `set` (ExchangeConfiguration).
    pub fn change_index(&self, set: DataSet) -> u8 {
        self.stored.change_index.get(set)
    }

    /// Whether any entry of `set` has DataChanged set, i.e. holds values the client did not
    /// write.
    pub fn data_changed(&self, set: DataSet) -> bool {
        let s = &self.stored;
        match set {
            DataSet::Tool => s.tools.iter().any(|e| e.data_changed),
            DataSet::Frame => s.frames.iter().any(|e| e.data_changed),
            DataSet::Load => s.loads.iter().any(|e| e.data_changed),
            DataSet::SwLimits => s.sw_limits.data_changed,
            DataSet::DefaultDynamics => s.default_dynamics.data_changed,
            DataSet::ReferenceDynamics => s.reference_dynamics.data_changed,
        }
    }

    /// The data to save, once after each change (`None` when the file is current).
    pub fn take_unsaved(&mut self) -> Option<Stored> {
        core::mem::take(&mut self.unsaved).then_some(self.stored)
    }

    fn changed(&mut self, set: DataSet) {
        self.stored.change_index.bump(set);
        self.unsaved = true;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn bounds() -> RobotBounds {
        let robot = shared_types::config::Config::load(None).unwrap().robot;
        RobotBounds::of(&robot).0
    }

    fn data() -> UserData {
        UserData::factory(bounds())
    }

    const STAMP: Timestamp = Timestamp {
        date: 12_000,
        time_of_day_ms: 45_296_789,
    };

    fn tool(load_no: u8) -> ToolData {
        ToolData {
            pose: [10.0, 0.0, 120.5, 0.0, 0.0, 45.0],
            id: 3,
            load_no,
            external_tcp: false,
        }
    }

    #[test]
    fn index_0_is_fixed_and_minus_1_is_the_one_in_use() {
        let mut d = data();
        assert_eq!(d.read_tool(0), Ok((0, Entry::default())));
        assert_eq!(d.read_frame(0), Ok((0, Entry::default())));
        assert_eq!(d.read_load(0), Ok((0, Entry::default())));
        d.write_tool(4, STAMP, tool(2), false).unwrap();
        assert_eq!(d.read_tool(CURRENT_INDEX).unwrap().0, 0, "flange in use");
        assert_eq!(d.select_tool(4), Ok(4));
        assert_eq!(d.select_tool(CURRENT_INDEX), Ok(4), "-1 keeps the tool");
        assert_eq!(d.read_tool(CURRENT_INDEX).unwrap().1.data, tool(2));
        assert_eq!(d.read_load(CURRENT_INDEX).unwrap().0, 2, "the tool's load");
        assert_eq!(d.select_frame(7), Ok(7));
        assert_eq!(d.read_frame(CURRENT_INDEX).unwrap().0, 7);
        assert_eq!(d.select_frame(16), Err(code::INVALID_FRAME_NO));
        assert_eq!(d.current_frame(), 7, "a refused selection changes nothing");
    }

    #[test]
    fn invalid_indices_have_the_code_of_their_data_set() {
        let mut d = data();
        for index in [16, 200] {
            assert_eq!(d.read_tool(index), Err(code::INVALID_TOOL_NO));
            assert_eq!(d.read_frame(index), Err(code::INVALID_FRAME_NO));
            assert_eq!(d.read_load(index), Err(codes::INVALID_LOAD_NO));
        }
        // Writing index 0 (fixed), -1 or beyond 15 is refused.
        for index in [0, CURRENT_INDEX, 16] {
            assert_eq!(
                d.write_tool(index, STAMP, tool(1), false),
                Err(code::INVALID_TOOL_NO)
            );
            assert_eq!(
                d.write_frame(index, STAMP, FrameData::default()),
                Err(code::INVALID_FRAME_NO)
            );
            assert_eq!(
                d.write_load(index, STAMP, LoadData::default(), false),
                Err(codes::INVALID_LOAD_NO)
            );
        }
        assert_eq!(d.take_unsaved(), None, "nothing was written");
        assert_eq!(d.change_index(DataSet::Tool), 0);
    }

    #[test]
    fn a_write_keeps_the_timestamp_clears_data_changed_and_counts() {
        let mut d = UserData::restored(bounds());
        assert!(d.read_tool(9).unwrap().1.data_changed);
        assert!(d.take_unsaved().is_some());
        d.write_tool(9, STAMP, tool(1), false).unwrap();
        let (i, e) = d.read_tool(9).unwrap();
        assert_eq!((i, e), (9, Entry::written(STAMP, tool(1))));
        assert!(!e.data_changed);
        assert_eq!(d.change_index(DataSet::Tool), 2);
        assert!(
            d.data_changed(DataSet::Tool),
            "the other tools are still the robot's"
        );
        let saved = d.take_unsaved().expect("a write is saved");
        assert_eq!(saved.tools[8].data, tool(1));
        assert_eq!(d.take_unsaved(), None, "once");
    }

    #[test]
    fn change_index_runs_1_to_255_and_wraps() {
        let mut d = data();
        for n in 1..=256u32 {
            d.write_frame(1, STAMP, FrameData::default()).unwrap();
            let expected = if n == 256 { 1 } else { n as u8 };
            assert_eq!(d.change_index(DataSet::Frame), expected);
        }
        assert_eq!(d.change_index(DataSet::Tool), 0);
    }

    #[test]
    fn tool_and_load_in_use_cannot_change_while_moving() {
        let mut d = data();
        d.write_tool(3, STAMP, tool(2), false).unwrap();
        d.select_tool(3).unwrap();
        assert_eq!(
            d.write_tool(3, STAMP, tool(5), true),
            Err(codes::TOOL_IN_MOTION)
        );
        assert_eq!(
            d.write_load(2, STAMP, LoadData::default(), true),
            Err(codes::LOAD_IN_MOTION)
        );
        // Data not in use can change during motion, the data in use at standstill.
        assert_eq!(d.write_tool(4, STAMP, tool(5), true), Ok(()));
        assert_eq!(d.write_load(5, STAMP, LoadData::default(), true), Ok(()));
        assert_eq!(d.write_tool(3, STAMP, tool(5), false), Ok(()));
        assert_eq!(d.write_load(2, STAMP, LoadData::default(), false), Ok(()));
    }

    #[test]
    fn tool_rules() {
        let mut d = data();
        let mut t = tool(16);
        assert_eq!(
            d.write_tool(1, STAMP, t, false),
            Err(codes::INVALID_LOAD_NO)
        );
        t.load_no = 0;
        assert_eq!(
            d.write_tool(1, STAMP, t, false),
            Ok(()),
            "a tool without load"
        );
        t.external_tcp = true;
        assert_eq!(
            d.write_tool(1, STAMP, t, false),
            Err(codes::EXTERNAL_TCP_NOT_SUPPORTED)
        );
        t.external_tcp = false;
        t.pose[4] = f32::NEG_INFINITY;
        assert_eq!(
            d.write_tool(1, STAMP, t, false),
            Err(codes::INVALID_POSITION)
        );
        assert_eq!(
            d.change_index(DataSet::Tool),
            1,
            "only the valid write counted"
        );
    }

    #[test]
    fn frames_refuse_cycles() {
        let mut d = data();
        let on = |reference_frame| FrameData {
            reference_frame,
            pose: [100.0, 0.0, 0.0, 0.0, 0.0, 90.0],
        };
        d.write_frame(1, STAMP, on(0)).unwrap();
        d.write_frame(2, STAMP, on(1)).unwrap();
        d.write_frame(3, STAMP, on(2)).unwrap();
        assert_eq!(
            d.write_frame(1, STAMP, on(3)),
            Err(codes::INVALID_REFERENCE_FRAME)
        );
        assert_eq!(
            d.write_frame(2, STAMP, on(2)),
            Err(codes::INVALID_REFERENCE_FRAME)
        );
        assert_eq!(d.read_frame(1).unwrap().1.data, on(0), "unchanged");
    }

    #[test]
    fn loads_up_to_the_payload() {
        let mut d = data();
        let payload = d.robot().payload_kg as f32;
        let load = |mass_kg| LoadData {
            centre_of_gravity: [0.0, 0.0, 50.0, 0.0, 0.0, 0.0],
            mass_kg,
            inertia: [0.01, 0.01, 0.02],
        };
        assert_eq!(d.write_load(1, STAMP, load(payload), false), Ok(()));
        assert_eq!(
            d.write_load(1, STAMP, load(payload * 1.01), false),
            Err(codes::MASS_EXCEEDS_PAYLOAD)
        );
        assert_eq!(
            d.write_load(1, STAMP, load(-1.0), false),
            Err(codes::MASS_EXCEEDS_PAYLOAD)
        );
        assert_eq!(d.read_load(1).unwrap().1.data, load(payload));
    }

    #[test]
    fn default_dynamics_keep_what_is_left_at_default() {
        let mut d = data();
        let keep = KEEP_RATE;
        let request = |v, a, dec, j| DefaultDynamicsRequest {
            velocity_rate: v,
            acceleration_rate: a,
            deceleration_rate: dec,
            jerk_rate: j,
        };
        let written = d
            .write_default_dynamics(STAMP, request(8_000, keep, keep, 2_500))
            .unwrap();
        assert_eq!(
            written,
            DefaultDynamics {
                velocity_rate: 8_000,
                acceleration_rate: FACTORY_DEFAULT_DYNAMICS.acceleration_rate,
                deceleration_rate: FACTORY_DEFAULT_DYNAMICS.deceleration_rate,
                jerk_rate: 2_500,
            }
        );
        assert_eq!(d.default_dynamics(), Entry::written(STAMP, written));
        assert_eq!(
            d.default_rates(),
            DefaultRates {
                velocity: 80.0,
                acceleration: 50.0,
                deceleration: 50.0,
                jerk: 25.0,
            }
        );
        // The deceleration has a rate of its own.
        d.write_default_dynamics(STAMP, request(keep, 3_000, 4_000, keep))
            .unwrap();
        assert_eq!(
            (
                d.default_rates().acceleration,
                d.default_rates().deceleration
            ),
            (30.0, 40.0)
        );
        assert_eq!(
            d.write_default_dynamics(STAMP, request(keep, keep, 10_001, keep)),
            Err(code::INVALID_DECELERATION_RATE)
        );
        assert_eq!(
            d.write_default_dynamics(STAMP, request(10_001, keep, keep, keep)),
            Err(code::INVALID_VELOCITY_RATE)
        );
        assert_eq!(
            d.default_rates().acceleration,
            30.0,
            "refused writes change nothing"
        );
    }

    #[test]
    fn reference_dynamics_below_zero_are_not_changed() {
        let mut d = data();
        let factory = d.reference_dynamics().data;
        let written = d
            .write_reference_dynamics(
                STAMP,
                ReferenceDynamics {
                    velocity_mm_s: 1000.0,
                    acceleration_mm_s2: -1.0,
                    deceleration_mm_s2: 2000.0,
                    jerk_mm_s3: -1.0,
                },
            )
            .unwrap();
        assert_eq!(
            written,
            ReferenceDynamics {
                velocity_mm_s: 1000.0,
                acceleration_mm_s2: factory.acceleration_mm_s2,
                deceleration_mm_s2: 2000.0,
                jerk_mm_s3: factory.jerk_mm_s3,
            }
        );
        let too_fast = ReferenceDynamics {
            velocity_mm_s: factory.velocity_mm_s * 2.0,
            ..written
        };
        assert_eq!(
            d.write_reference_dynamics(STAMP, too_fast),
            Err(codes::INVALID_VELOCITY)
        );
        let minus_infinity = ReferenceDynamics {
            jerk_mm_s3: f32::NEG_INFINITY,
            ..written
        };
        assert_eq!(
            d.write_reference_dynamics(STAMP, minus_infinity),
            Err(code::INVALID_JERK_RATE)
        );
    }

    #[test]
    fn sw_limits_write_and_reset_to_factory() {
        let mut d = data();
        let factory = d.sw_limits().data;
        let mut narrow = factory;
        narrow.lower_deg[0] = -90.0;
        narrow.upper_deg[0] = 90.0;
        d.write_sw_limits(STAMP, Some(narrow)).unwrap();
        assert_eq!(d.sw_limits(), Entry::written(STAMP, narrow));
        let rad = d.sw_limits_rad();
        assert!((rad.lower[0] + core::f64::consts::FRAC_PI_2).abs() < 1e-9);
        assert!((rad.upper[0] - core::f64::consts::FRAC_PI_2).abs() < 1e-9);
        let mut wide = narrow;
        wide.upper_deg[1] += 1_000.0;
        assert_eq!(
            d.write_sw_limits(STAMP, Some(wide)),
            Err(code::SW_LIMIT_UPPER)
        );
        d.write_sw_limits(STAMP, None).unwrap();
        let reset = d.sw_limits();
        assert_eq!(reset.data, factory);
        assert!(reset.data_changed, "the robot's values, not the client's");
        assert_eq!(reset.timestamp, STAMP);
        assert_eq!(d.change_index(DataSet::SwLimits), 2);
    }

    proptest! {
        /// Whatever a client writes, the limits the planner gets stay mechanical.
        #[test]
        fn sw_limits_rad_never_leave_the_mechanical_limits(
            writes in proptest::collection::vec(
                (proptest::array::uniform6(-720.0f32..720.0),
                 proptest::array::uniform6(-720.0f32..720.0)),
                1..8,
            ),
        ) {
            let mut d = data();
            for (lower_deg, upper_deg) in writes {
                let _ = d.write_sw_limits(STAMP, Some(SwLimits { lower_deg, upper_deg }));
                let rad = d.sw_limits_rad();
                let b = d.robot();
                for j in 0..6 {
                    prop_assert!(rad.lower[j] >= b.joint_min_deg[j].to_radians());
                    prop_assert!(rad.upper[j] <= b.joint_max_deg[j].to_radians());
                    prop_assert!(rad.lower[j] < rad.upper[j]);
                }
            }
        }
    }
}
