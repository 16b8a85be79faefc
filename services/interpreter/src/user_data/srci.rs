//! The twelve user-data functions on the wire: a request is decoded with the generated field
//! tables, executed against the store and answered with a complete response (every field of
//! the response table filled).

use shared_types::srci::payload::{Field, PayloadReader, PayloadWriter};
use shared_types::srci::tables::{
    read_frame_data as rfd, read_load_data as rld, read_robot_default_dynamics as rdd,
    read_robot_reference_dynamics as rrd, read_robot_sw_limits as rsl, read_tool_data as rtd,
    write_frame_data as wfd, write_load_data as wld, write_robot_default_dynamics as wdd,
    write_robot_reference_dynamics as wrd, write_robot_sw_limits as wsl, write_tool_data as wtd,
};

use super::model::{
    DefaultDynamics, Entry, FrameData, LoadData, ReferenceDynamics, SwLimits, Timestamp, ToolData,
};
use super::store::{DefaultDynamicsRequest, UserData};

/// Command types of the user-data functions.
pub const FUNCTIONS: [u16; 12] = [
    rtd::TYPE,
    wtd::TYPE,
    rfd::TYPE,
    wfd::TYPE,
    rld::TYPE,
    wld::TYPE,
    rdd::TYPE,
    wdd::TYPE,
    rrd::TYPE,
    wrd::TYPE,
    rsl::TYPE,
    wsl::TYPE,
];

/// J1..J6 lower and upper limits of WriteRobotSWLimits.
const WRITE_LOWER: [Field; 6] = [
    wsl::request::J1_LOWER_LIMIT,
    wsl::request::J2_LOWER_LIMIT,
    wsl::request::J3_LOWER_LIMIT,
    wsl::request::J4_LOWER_LIMIT,
    wsl::request::J5_LOWER_LIMIT,
    wsl::request::J6_LOWER_LIMIT,
];
const WRITE_UPPER: [Field; 6] = [
    wsl::request::J1_UPPER_LIMIT,
    wsl::request::J2_UPPER_LIMIT,
    wsl::request::J3_UPPER_LIMIT,
    wsl::request::J4_UPPER_LIMIT,
    wsl::request::J5_UPPER_LIMIT,
    wsl::request::J6_UPPER_LIMIT,
];
/// J1..J6 lower and upper limits of the ReadRobotSWLimits response.
const READ_LOWER: [Field; 6] = [
    rsl::response::J1_LOWER_LIMIT,
    rsl::response::J2_LOWER_LIMIT,
    rsl::response::J3_LOWER_LIMIT,
    rsl::response::J4_LOWER_LIMIT,
    rsl::response::J5_LOWER_LIMIT,
    rsl::response::J6_LOWER_LIMIT,
];
const READ_UPPER: [Field; 6] = [
    rsl::response::J1_UPPER_LIMIT,
    rsl::response::J2_UPPER_LIMIT,
    rsl::response::J3_UPPER_LIMIT,
    rsl::response::J4_UPPER_LIMIT,
    rsl::response::J5_UPPER_LIMIT,
    rsl::response::J6_UPPER_LIMIT,
];
/// The external-axis limits of the ReadRobotSWLimits response. The robot has no external
/// axes, so they are 0. (Table 6-203 names E1's upper limit "E1LowerLimit" a second time;
/// the generated fields have it corrected: `CORRECTIONS` in shared-types/build.rs.)
const READ_EXTERNAL: [Field; 12] = [
    rsl::response::E1_LOWER_LIMIT,
    rsl::response::E1_UPPER_LIMIT,
    rsl::response::E2_LOWER_LIMIT,
    rsl::response::E3_LOWER_LIMIT,
    rsl::response::E4_LOWER_LIMIT,
    rsl::response::E5_LOWER_LIMIT,
    rsl::response::E6_LOWER_LIMIT,
    rsl::response::E2_UPPER_LIMIT,
    rsl::response::E3_UPPER_LIMIT,
    rsl::response::E4_UPPER_LIMIT,
    rsl::response::E5_UPPER_LIMIT,
    rsl::response::E6_UPPER_LIMIT,
];

/// What a user-data function answers with DONE.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Reply {
    /// WriteToolData, WriteFrameData, WriteLoadData, WriteRobotSWLimits: no data.
    Written,
    Tool(u8, Entry<ToolData>),
    Frame(u8, Entry<FrameData>),
    Load(u8, Entry<LoadData>),
    DefaultDynamics(Entry<DefaultDynamics>),
    /// WriteRobotDefaultDynamics: the values now in effect.
    DefaultDynamicsWritten(DefaultDynamics),
    ReferenceDynamics(Entry<ReferenceDynamics>),
    /// WriteRobotReferenceDynamics: the values now in effect.
    ReferenceDynamicsWritten(ReferenceDynamics),
    SwLimits(Entry<SwLimits>),
}

fn read_timestamp(r: &PayloadReader, date: Field, time: Field) -> Timestamp {
    Timestamp {
        date: r.u16(date),
        time_of_day_ms: r.u32(time),
    }
}

fn read_f32s<const N: usize>(r: &PayloadReader, fields: [Field; N]) -> [f32; N] {
    fields.map(|f| r.f32(f))
}

fn write_timestamp(w: &mut PayloadWriter, t: Timestamp, date: Field, time: Field) {
    w.set_u16(date, t.date);
    w.set_u32(time, t.time_of_day_ms);
}

/// VelocityRate, AccelerationRate, DecelerationRate, JerkRate.
fn write_rates(w: &mut PayloadWriter, fields: [Field; 4], d: DefaultDynamics) {
    let values = [
        d.velocity_rate,
        d.acceleration_rate,
        d.deceleration_rate,
        d.jerk_rate,
    ];
    for (f, v) in fields.into_iter().zip(values) {
        w.set_u16(f, v);
    }
}

fn reference_values(d: ReferenceDynamics) -> [f32; 4] {
    [
        d.velocity_mm_s,
        d.acceleration_mm_s2,
        d.deceleration_mm_s2,
        d.jerk_mm_s3,
    ]
}

fn write_f32s<const N: usize>(w: &mut PayloadWriter, fields: [Field; N], values: [f32; N]) {
    for (f, v) in fields.into_iter().zip(values) {
        w.set_f32(f, v);
    }
}

/// Executes user-data function `command_type` with request `msg`; `moving` tells whether
/// motion is in progress. `None` if `command_type` is not a user-data function, else the
/// reply or the code of the error.
pub fn execute(
    store: &mut UserData,
    command_type: u16,
    msg: &[u8],
    moving: bool,
) -> Option<Result<Reply, u16>> {
    let r = PayloadReader::new(msg);
    Some(match command_type {
        rtd::TYPE => store
            .read_tool(r.u8(rtd::request::TOOL_NO))
            .map(|(i, e)| Reply::Tool(i, e)),
        rfd::TYPE => store
            .read_frame(r.u8(rfd::request::FRAME_NO))
            .map(|(i, e)| Reply::Frame(i, e)),
        rld::TYPE => store
            .read_load(r.u8(rld::request::LOAD_NO))
            .map(|(i, e)| Reply::Load(i, e)),
        rdd::TYPE => Ok(Reply::DefaultDynamics(store.default_dynamics())),
        rrd::TYPE => Ok(Reply::ReferenceDynamics(store.reference_dynamics())),
        rsl::TYPE => Ok(Reply::SwLimits(store.sw_limits())),
        wtd::TYPE => {
            use wtd::request as q;
            let tool = ToolData {
                pose: read_f32s(&r, q::TOOL_DATA_X_RZ),
                id: r.u8(q::TOOL_DATA_ID),
                load_no: r.u8(q::TOOL_DATA_LOAD_NO),
                external_tcp: r.bit(q::TOOL_DATA_EXTERNAL_TCP),
            };
            let t = read_timestamp(&r, q::TOOL_DATA_DATE, q::TOOL_DATA_TIME);
            store
                .write_tool(r.u8(q::TOOL_NO), t, tool, moving)
                .map(|()| Reply::Written)
        }
        wfd::TYPE => {
            use wfd::request as q;
            let frame = FrameData {
                reference_frame: r.u8(q::FRAME_DATA_REFERENCE_FRAME),
                pose: read_f32s(&r, q::FRAME_DATA_X_RZ),
            };
            let t = read_timestamp(&r, q::FRAME_DATA_DATE, q::FRAME_DATA_TIME);
            store
                .write_frame(r.u8(q::FRAME_NO), t, frame)
                .map(|()| Reply::Written)
        }
        wld::TYPE => {
            use wld::request as q;
            let load = LoadData {
                centre_of_gravity: read_f32s(&r, q::LOAD_DATA_X_RZ),
                mass_kg: r.f32(q::LOAD_DATA_MASS),
                inertia: read_f32s(&r, [q::LOAD_DATA_IX, q::LOAD_DATA_IY, q::LOAD_DATA_IZ]),
            };
            let t = read_timestamp(&r, q::LOAD_DATA_DATE, q::LOAD_DATA_TIME);
            store
                .write_load(r.u8(q::LOAD_NO), t, load, moving)
                .map(|()| Reply::Written)
        }
        wdd::TYPE => {
            use wdd::request as q;
            let request = DefaultDynamicsRequest {
                velocity_rate: r.u16(q::VELOCITY_RATE),
                acceleration_rate: r.u16(q::ACCELERATION_RATE),
                deceleration_rate: r.u16(q::DECELERATION_RATE),
                jerk_rate: r.u16(q::JERK_RATE),
            };
            store
                .write_default_dynamics(read_timestamp(&r, q::DATE, q::TIME), request)
                .map(Reply::DefaultDynamicsWritten)
        }
        wrd::TYPE => {
            use wrd::request as q;
            let request = ReferenceDynamics {
                velocity_mm_s: r.f32(q::VELOCITY_REFERENCE),
                acceleration_mm_s2: r.f32(q::ACCELERATION_REFERENCE),
                deceleration_mm_s2: r.f32(q::DECELERATION_REFERENCE),
                jerk_mm_s3: r.f32(q::JERK_REFERENCE),
            };
            store
                .write_reference_dynamics(read_timestamp(&r, q::DATE, q::TIME), request)
                .map(Reply::ReferenceDynamicsWritten)
        }
        wsl::TYPE => {
            use wsl::request as q;
            // The external-axis limits are ignored: the robot has none.
            let limits = (!r.bit(q::RESET_TO_FACTORY_DEFAULT)).then(|| SwLimits {
                lower_deg: read_f32s(&r, WRITE_LOWER),
                upper_deg: read_f32s(&r, WRITE_UPPER),
            });
            store
                .write_sw_limits(read_timestamp(&r, q::DATE, q::TIME), limits)
                .map(|()| Reply::Written)
        }
        _ => return None,
    })
}

impl Reply {
    /// Writes the response data into `b`, a response buffer of the function's full length.
    pub fn encode(&self, b: &mut [u8]) {
        let mut w = PayloadWriter::new(b);
        match *self {
            Reply::Written => {}
            Reply::Tool(index, e) => {
                use rtd::response as p;
                write_timestamp(&mut w, e.timestamp, p::TOOL_DATA_DATE, p::TOOL_DATA_TIME);
                write_f32s(&mut w, p::TOOL_DATA_X_RZ, e.data.pose);
                w.set_u8(p::TOOL_DATA_ID, e.data.id);
                w.set_u8(p::TOOL_DATA_LOAD_NO, e.data.load_no);
                w.set_bit(p::TOOL_DATA_EXTERNAL_TCP, e.data.external_tcp);
                w.set_u8(p::TOOL_NO, index);
                w.set_bit(p::DATA_CHANGED, e.data_changed);
            }
            Reply::Frame(index, e) => {
                use rfd::response as p;
                write_timestamp(&mut w, e.timestamp, p::FRAME_DATA_DATE, p::FRAME_DATA_TIME);
                w.set_u8(p::FRAME_DATA_REFERENCE_FRAME, e.data.reference_frame);
                write_f32s(&mut w, p::FRAME_DATA_X_RZ, e.data.pose);
                w.set_u8(p::FRAME_NO, index);
                w.set_bit(p::DATA_CHANGED, e.data_changed);
            }
            Reply::Load(index, e) => {
                use rld::response as p;
                write_timestamp(&mut w, e.timestamp, p::LOAD_DATA_DATE, p::LOAD_DATA_TIME);
                write_f32s(&mut w, p::LOAD_DATA_X_RZ, e.data.centre_of_gravity);
                w.set_f32(p::LOAD_DATA_MASS, e.data.mass_kg);
                write_f32s(
                    &mut w,
                    [p::LOAD_DATA_IX, p::LOAD_DATA_IY, p::LOAD_DATA_IZ],
                    e.data.inertia,
                );
                w.set_u8(p::LOAD_NO, index);
                w.set_bit(p::DATA_CHANGED, e.data_changed);
            }
            Reply::DefaultDynamics(e) => {
                use rdd::response as p;
                write_timestamp(&mut w, e.timestamp, p::DATE, p::TIME);
                let rates = [
                    p::VELOCITY_RATE,
                    p::ACCELERATION_RATE,
                    p::DECELERATION_RATE,
                    p::JERK_RATE,
                ];
                write_rates(&mut w, rates, e.data);
                w.set_bit(p::DATA_CHANGED, e.data_changed);
            }
            Reply::DefaultDynamicsWritten(d) => {
                use wdd::response as p;
                let rates = [
                    p::VELOCITY_RATE,
                    p::ACCELERATION_RATE,
                    p::DECELERATION_RATE,
                    p::JERK_RATE,
                ];
                write_rates(&mut w, rates, d);
            }
            Reply::ReferenceDynamics(e) => {
                use rrd::response as p;
                write_timestamp(&mut w, e.timestamp, p::DATE, p::TIME);
                let fields = [
                    p::VELOCITY_REFERENCE,
                    p::ACCELERATION_REFERENCE,
                    p::DECELERATION_REFERENCE,
                    p::JERK_REFERENCE,
                ];
                write_f32s(&mut w, fields, reference_values(e.data));
                w.set_bit(p::DATA_CHANGED, e.data_changed);
            }
            Reply::ReferenceDynamicsWritten(d) => {
                use wrd::response as p;
                let fields = [
                    p::VELOCITY_REFERENCE,
                    p::ACCELERATION_REFERENCE,
                    p::DECELERATION_REFERENCE,
                    p::JERK_REFERENCE,
                ];
                write_f32s(&mut w, fields, reference_values(d));
            }
            Reply::SwLimits(e) => {
                use rsl::response as p;
                write_timestamp(&mut w, e.timestamp, p::DATE, p::TIME);
                write_f32s(&mut w, READ_LOWER, e.data.lower_deg);
                write_f32s(&mut w, READ_UPPER, e.data.upper_deg);
                write_f32s(&mut w, READ_EXTERNAL, [0.0; 12]);
                w.set_bit(p::DATA_CHANGED, e.data_changed);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::user_data::{RobotBounds, codes};
    use shared_types::srci::message::{CommandHeader, code};
    use shared_types::srci::tables::read_actual_position as rap;

    fn store() -> UserData {
        let robot = shared_types::config::Config::load(None).unwrap().robot;
        UserData::factory(RobotBounds::of(&robot).0)
    }

    /// A request of `command_type`, `len` bytes, with the fields `edit` sets.
    fn request(command_type: u16, len: usize, edit: impl FnOnce(&mut PayloadWriter)) -> Vec<u8> {
        let mut b = vec![0u8; len];
        CommandHeader {
            command_type,
            execution_mode: 2,
            par_seq: 0,
            priority: 0,
        }
        .encode(&mut b);
        edit(&mut PayloadWriter::new(&mut b));
        b
    }

    /// Executes and encodes the reply into a response of `len` bytes.
    fn run(s: &mut UserData, msg: &[u8], len: usize, moving: bool) -> Result<Vec<u8>, u16> {
        let command_type = CommandHeader::decode(msg).command_type;
        let reply = execute(s, command_type, msg, moving).expect("a user-data function")?;
        let mut b = vec![0u8; len];
        reply.encode(&mut b);
        Ok(b)
    }

    const POSE: [f32; 6] = [12.5, -3.25, 150.0, 0.5, -90.0, 180.0];

    #[test]
    fn tool_data_reads_back_as_written() {
        let mut s = store();
        let write = request(wtd::TYPE, wtd::request::LEN, |w| {
            use wtd::request as q;
            w.set_u16(q::TOOL_DATA_DATE, 0x2B67);
            w.set_u32(q::TOOL_DATA_TIME, 3_600_000);
            write_f32s(w, q::TOOL_DATA_X_RZ, POSE);
            w.set_u8(q::TOOL_DATA_ID, 42);
            w.set_u8(q::TOOL_DATA_LOAD_NO, 3);
            w.set_u8(q::TOOL_NO, 5);
        });
        let done = run(&mut s, &write, wtd::response::LEN, false).unwrap();
        assert_eq!(done, vec![0; wtd::response::LEN], "header only");
        let read = request(rtd::TYPE, rtd::request::LEN, |w| {
            w.set_u8(rtd::request::TOOL_NO, 5)
        });
        let b = run(&mut s, &read, rtd::response::LEN, false).unwrap();
        let r = PayloadReader::new(&b);
        use rtd::response as p;
        assert_eq!(r.u16(p::TOOL_DATA_DATE), 0x2B67);
        assert_eq!(r.u32(p::TOOL_DATA_TIME), 3_600_000);
        assert_eq!(read_f32s(&r, p::TOOL_DATA_X_RZ), POSE);
        assert_eq!(r.u8(p::TOOL_DATA_ID), 42);
        assert_eq!(r.u8(p::TOOL_DATA_LOAD_NO), 3);
        assert!(!r.bit(p::TOOL_DATA_EXTERNAL_TCP));
        assert_eq!(r.u8(p::TOOL_NO), 5);
        assert!(!r.bit(p::DATA_CHANGED));
    }

    #[test]
    fn frame_and_load_data_read_back_as_written() {
        let mut s = store();
        let frame = request(wfd::TYPE, wfd::request::LEN, |w| {
            use wfd::request as q;
            w.set_u16(q::FRAME_DATA_DATE, 11_000);
            w.set_u8(q::FRAME_DATA_REFERENCE_FRAME, 0);
            write_f32s(w, q::FRAME_DATA_X_RZ, POSE);
            w.set_u8(q::FRAME_NO, 15);
        });
        run(&mut s, &frame, wfd::response::LEN, false).unwrap();
        let read = request(rfd::TYPE, rfd::request::LEN, |w| {
            w.set_u8(rfd::request::FRAME_NO, 15)
        });
        let b = run(&mut s, &read, rfd::response::LEN, false).unwrap();
        let r = PayloadReader::new(&b);
        assert_eq!(r.u16(rfd::response::FRAME_DATA_DATE), 11_000);
        assert_eq!(read_f32s(&r, rfd::response::FRAME_DATA_X_RZ), POSE);
        assert_eq!(r.u8(rfd::response::FRAME_NO), 15);

        let load = request(wld::TYPE, wld::request::LEN, |w| {
            use wld::request as q;
            write_f32s(w, q::LOAD_DATA_X_RZ, POSE);
            w.set_f32(q::LOAD_DATA_MASS, 4.5);
            write_f32s(
                w,
                [q::LOAD_DATA_IX, q::LOAD_DATA_IY, q::LOAD_DATA_IZ],
                [0.1, 0.2, 0.3],
            );
            w.set_u8(q::LOAD_NO, 1);
        });
        run(&mut s, &load, wld::response::LEN, false).unwrap();
        let read = request(rld::TYPE, rld::request::LEN, |w| {
            w.set_u8(rld::request::LOAD_NO, 1)
        });
        let b = run(&mut s, &read, rld::response::LEN, false).unwrap();
        let r = PayloadReader::new(&b);
        use rld::response as p;
        assert_eq!(read_f32s(&r, p::LOAD_DATA_X_RZ), POSE);
        assert_eq!(r.f32(p::LOAD_DATA_MASS), 4.5);
        assert_eq!(
            read_f32s(&r, [p::LOAD_DATA_IX, p::LOAD_DATA_IY, p::LOAD_DATA_IZ]),
            [0.1, 0.2, 0.3]
        );
        assert_eq!(r.u8(p::LOAD_NO), 1);
    }

    /// Offsets from the specification text (tables 6-150, 6-190, 6-196, 6-203), typed here by
    /// hand on purpose: an independent check of the generated tables and of this codec.
    #[test]
    fn wire_positions_match_the_specification() {
        let mut s = store();
        let mut write = vec![0u8; 39];
        write[0..2].copy_from_slice(&5205u16.to_be_bytes());
        write[10..14].copy_from_slice(&1.5f32.to_be_bytes()); // X
        write[35] = 2; // LoadNo
        write[38] = 7; // ToolNo
        run(&mut s, &write, 4, false).unwrap();
        let read = [0x13, 0xF3, 2, 0, 7]; // ReadToolData 5107, ToolNo 7
        let b = run(&mut s, &read, 40, false).unwrap();
        assert_eq!(&b[10..14], &1.5f32.to_be_bytes());
        assert_eq!((b[35], b[38], b[39]), (2, 7, 0));

        s.write_sw_limits(Timestamp::default(), None).unwrap();
        let b = run(&mut s, &[0x13, 0xF2, 2, 0], 107, false).unwrap(); // ReadRobotSWLimits 5106
        let j1_upper = f32::from_be_bytes([b[38], b[39], b[40], b[41]]);
        assert_eq!(j1_upper, s.sw_limits().data.upper_deg[0]);
        assert_eq!(
            &b[62..66],
            &[0; 4],
            "E1 upper limit (named E1LowerLimit in 6-203)"
        );
        assert_eq!(
            b[106] & 1,
            1,
            "DataChanged after the reset to factory values"
        );
    }

    #[test]
    fn a_trimmed_write_without_tool_no_is_refused() {
        // Unpatched PLC libraries drop trailing parameters; ToolNo sits at the end.
        let mut s = store();
        let write = request(wtd::TYPE, 36, |w| {
            write_f32s(w, wtd::request::TOOL_DATA_X_RZ, POSE)
        });
        assert_eq!(
            run(&mut s, &write, wtd::response::LEN, false),
            Err(code::INVALID_TOOL_NO)
        );
    }

    #[test]
    fn reads_of_minus_1_report_the_index_in_use() {
        let mut s = store();
        let read = request(rld::TYPE, rld::request::LEN, |w| {
            w.set_u8(rld::request::LOAD_NO, 0xFF)
        });
        let b = run(&mut s, &read, rld::response::LEN, false).unwrap();
        assert_eq!(PayloadReader::new(&b).u8(rld::response::LOAD_NO), 0);
        let read = request(rfd::TYPE, rfd::request::LEN, |w| {
            w.set_u8(rfd::request::FRAME_NO, 16)
        });
        assert_eq!(
            run(&mut s, &read, rfd::response::LEN, false),
            Err(code::INVALID_FRAME_NO)
        );
    }

    #[test]
    fn the_tool_in_use_is_not_written_during_motion() {
        let mut s = store();
        s.write_tool(2, Timestamp::default(), ToolData::default(), false)
            .unwrap();
        s.select_tool(2).unwrap();
        let write = request(wtd::TYPE, wtd::request::LEN, |w| {
            w.set_u8(wtd::request::TOOL_NO, 2)
        });
        assert_eq!(
            run(&mut s, &write, wtd::response::LEN, true),
            Err(codes::TOOL_IN_MOTION)
        );
        assert!(run(&mut s, &write, wtd::response::LEN, false).is_ok());
    }

    #[test]
    fn default_dynamics_answer_the_values_in_effect() {
        let mut s = store();
        let write = request(wdd::TYPE, wdd::request::LEN, |w| {
            use wdd::request as q;
            w.set_u16(q::VELOCITY_RATE, 7_500);
            w.set_u16(q::ACCELERATION_RATE, 2_000);
            w.set_u16(q::DECELERATION_RATE, 0xFFFF);
            w.set_u16(q::JERK_RATE, 0xFFFF);
        });
        let b = run(&mut s, &write, wdd::response::LEN, false).unwrap();
        let r = PayloadReader::new(&b);
        use wdd::response as p;
        assert_eq!(
            [
                p::VELOCITY_RATE,
                p::ACCELERATION_RATE,
                p::DECELERATION_RATE,
                p::JERK_RATE
            ]
            .map(|f| r.u16(f)),
            [7_500, 2_000, 5_000, 10_000]
        );
        let read = request(rdd::TYPE, rdd::request::LEN, |_| {});
        let b = run(&mut s, &read, rdd::response::LEN, false).unwrap();
        let r = PayloadReader::new(&b);
        assert_eq!(r.u16(rdd::response::DECELERATION_RATE), 5_000);
        assert!(!r.bit(rdd::response::DATA_CHANGED));
    }

    #[test]
    fn reference_dynamics_answer_the_values_in_effect() {
        let mut s = store();
        let factory = s.reference_dynamics().data;
        let write = request(wrd::TYPE, wrd::request::LEN, |w| {
            use wrd::request as q;
            w.set_f32(q::VELOCITY_REFERENCE, 800.0);
            w.set_f32(q::ACCELERATION_REFERENCE, -1.0);
            w.set_f32(q::DECELERATION_REFERENCE, -1.0);
            w.set_f32(q::JERK_REFERENCE, -1.0);
        });
        let b = run(&mut s, &write, wrd::response::LEN, false).unwrap();
        let r = PayloadReader::new(&b);
        assert_eq!(r.f32(wrd::response::VELOCITY_REFERENCE), 800.0);
        assert_eq!(
            r.f32(wrd::response::JERK_REFERENCE),
            factory.jerk_mm_s3,
            "-1: not changed"
        );
        let read = request(rrd::TYPE, rrd::request::LEN, |_| {});
        let b = run(&mut s, &read, rrd::response::LEN, false).unwrap();
        let r = PayloadReader::new(&b);
        assert_eq!(r.f32(rrd::response::VELOCITY_REFERENCE), 800.0);
        assert_eq!(
            r.f32(rrd::response::ACCELERATION_REFERENCE),
            factory.acceleration_mm_s2
        );
    }

    #[test]
    fn sw_limits_read_back_and_reset_to_factory() {
        let mut s = store();
        let factory = s.sw_limits().data;
        let mut lower = factory.lower_deg;
        lower[3] = -10.0;
        let write = request(wsl::TYPE, wsl::request::LEN, |w| {
            write_f32s(w, WRITE_LOWER, lower);
            write_f32s(w, WRITE_UPPER, factory.upper_deg);
            w.set_f32(wsl::request::E1_UPPER_LIMIT, 1e9);
        });
        let b = run(&mut s, &write, wsl::response::LEN, false).unwrap();
        assert!(!PayloadReader::new(&b).bit(wsl::response::RESTART_REQUESTED));
        let read = request(rsl::TYPE, rsl::request::LEN, |_| {});
        let b = run(&mut s, &read, rsl::response::LEN, false).unwrap();
        let r = PayloadReader::new(&b);
        assert_eq!(read_f32s(&r, READ_LOWER), lower);
        assert_eq!(read_f32s(&r, READ_UPPER), factory.upper_deg);
        assert_eq!(read_f32s(&r, READ_EXTERNAL), [0.0; 12], "no external axes");
        assert!(!r.bit(rsl::response::DATA_CHANGED));

        let reset = request(wsl::TYPE, wsl::request::LEN, |w| {
            w.set_bit(wsl::request::RESET_TO_FACTORY_DEFAULT, true)
        });
        run(&mut s, &reset, wsl::response::LEN, false).unwrap();
        let b = run(&mut s, &read, rsl::response::LEN, false).unwrap();
        let r = PayloadReader::new(&b);
        assert_eq!(read_f32s(&r, READ_LOWER), factory.lower_deg);
        assert!(r.bit(rsl::response::DATA_CHANGED));
    }

    #[test]
    fn other_functions_are_not_handled() {
        let mut s = store();
        let msg = request(rap::TYPE, rap::request::LEN, |_| {});
        assert_eq!(execute(&mut s, rap::TYPE, &msg, false), None);
        assert_eq!(FUNCTIONS.len(), 12);
        assert!(!FUNCTIONS.contains(&rap::TYPE));
    }
}
