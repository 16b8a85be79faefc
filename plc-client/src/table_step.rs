//! Program steps of any request in the specification's tables, its parameters named as the
//! table names them.
//!
//! ```toml
//! [[step]]
//! call = "MoveLinearAbsolute"
//! position = [450.0, -120.0, 300.0, 180.0, 0.0, 90.0]   # Position.X .. Position.RZ
//! velocity_rate = 50.0                                   # percent; omitted = 0xFFFF (default)
//! blending_mode = 3
//! blending_parameter = [20.0, 0.0]
//! ```
//!
//! Every field of the command's request table is a key, in snake_case (`tool_no`,
//! `ori_mode`, `circ_mode`, `position_turn_number`, ...), and so is every six-value group
//! (`position` for `Position.X` .. `Position.RZ`, `joint_position` for `J1` .. `J6`). Values
//! are in the protocol's own terms: REAL fields as numbers in the specification's units (mm,
//! degrees, ...), integers as integers within their wire type, bits as booleans, arrays as
//! lists of up to their length, strings for CHAR arrays. The UINT percentages (`*_rate`,
//! `override`) are percent as in the typed steps; omitted, they send 0xFFFF (the robot's
//! default). Other fields left out are 0. The header is the client's: `aborting = true` sends a
//! move with AbortingMode ABORT, `execution_mode` sets the mode explicitly.

use shared_types::srci::message::{CommandHeader, Percent, execution_mode};
use shared_types::srci::payload::{Field, FieldTable, Layout, PayloadWriter, WireType};
use shared_types::srci::tables;

use crate::request::{Request, is_move};

/// Fields of the command header, which the client fills in itself.
const HEADER_FIELDS: [&str; 6] = [
    "type",
    "execution_mode",
    "par_seq",
    "priority",
    "emitter_id",
    "listener_id",
];

/// Keys of a table step besides its fields and the common keys.
const HEADER_KEYS: [&str; 2] = ["aborting", "execution_mode"];

/// The request table of the command named `function`, if the specification has one.
pub fn find(function: &str) -> Option<&'static FieldTable> {
    tables::REQUESTS.iter().find(|t| t.function == function)
}

/// The function name of the request table named `function` up to letter case, as the
/// specification spells it (`WriteRobotSWLimits` for `WriteRobotSwLimits`).
pub fn find_ignoring_case(function: &str) -> Option<&'static str> {
    tables::REQUESTS
        .iter()
        .find(|t| t.function.eq_ignore_ascii_case(function))
        .map(|t| t.function)
}

/// Whether the command is of Enable type (GroupJog, ReturnToPrimary, ...): its request has
/// an Enable bit.
pub fn is_enable_type(table: &FieldTable) -> bool {
    table.fields.iter().any(|(name, _)| *name == "enable")
}

/// The keys `table` takes, header keys first.
pub fn parameter_keys(table: &FieldTable) -> Vec<&'static str> {
    let fields = table.fields.iter().map(|(name, _)| *name);
    let groups = table.groups.iter().map(|(name, _)| *name);
    HEADER_KEYS
        .into_iter()
        .chain(groups)
        .chain(fields.filter(|name| !HEADER_FIELDS.contains(name)))
        .collect()
}

/// A parameter of a table step: one field or a six-value group.
enum Parameter {
    Field(Field),
    Group([Field; 6]),
}

fn parameter(table: &FieldTable, key: &str) -> Option<Parameter> {
    if HEADER_FIELDS.contains(&key) {
        return None;
    }
    let field = table.fields.iter().find(|(name, _)| *name == key);
    let group = table.groups.iter().find(|(name, _)| *name == key);
    match (field, group) {
        (Some((_, f)), _) => Some(Parameter::Field(*f)),
        (None, Some((_, g))) => Some(Parameter::Group(*g)),
        (None, None) => None,
    }
}

/// The request of `table` with the step's `keys` (the common keys already taken out);
/// errors name the key.
pub fn request(table: &FieldTable, keys: &toml::Table) -> Result<Request, String> {
    let mut bytes = vec![0u8; table.len.max(CommandHeader::LEN)];
    let mut w = PayloadWriter::new(&mut bytes);
    let mut written: Vec<(&str, Field)> = Vec::new();
    for (name, field) in table.fields {
        if Percent::is_field(name, *field) {
            w.set_u16(*field, Percent::Default.to_wire());
        }
    }
    for (key, value) in keys {
        if HEADER_KEYS.contains(&key.as_str()) {
            continue;
        }
        let at = |message: String| format!("key `{key}`: {message}");
        let fields: Vec<Field> = match parameter(table, key) {
            Some(Parameter::Field(f)) => {
                write_field(&mut w, key, f, value).map_err(at)?;
                vec![f]
            }
            Some(Parameter::Group(group)) => {
                let values = value
                    .as_array()
                    .filter(|v| v.len() == group.len())
                    .ok_or_else(|| at(format!("expected a list of {} numbers", group.len())))?;
                for (f, v) in group.iter().zip(values) {
                    write_field(&mut w, key, *f, v).map_err(at)?;
                }
                group.to_vec()
            }
            None => {
                return Err(format!(
                    "unknown key `{key}`; {} takes: {}",
                    table.function,
                    parameter_keys(table).join(", ")
                ));
            }
        };
        for f in fields {
            if let Some((other, _)) = written.iter().find(|(_, w)| overlaps(*w, f)) {
                return Err(format!("keys `{other}` and `{key}` set the same field"));
            }
            written.push((key.as_str(), f));
        }
    }
    Ok(Request::Raw {
        command_type: table.command_type,
        execution_mode: mode(table, keys)?,
        payload: bytes.split_off(CommandHeader::LEN),
    })
}

/// Whether two fields share a bit of the payload.
fn overlaps(a: Field, b: Field) -> bool {
    let bits = |f: Field| match f.layout {
        Layout::Bit(i) => (f.offset * 8 + usize::from(i), 1),
        Layout::LowNibble => (f.offset * 8, 4),
        Layout::HighNibble => (f.offset * 8 + 4, 4),
        _ => (f.offset * 8, f.size() * 8),
    };
    let ((a0, an), (b0, bn)) = (bits(a), bits(b));
    a0 < b0 + bn && b0 < a0 + an
}

/// The ExecutionMode of the step: a move (or a wait) runs on the primary sequence, aborting
/// the others with `aborting = true`; jogging on the secondary; everything else in parallel.
fn mode(table: &FieldTable, keys: &toml::Table) -> Result<u8, String> {
    let sequence = is_move(table.function)
        || table.function == "WaitTime"
        || table.function == "ReturnToPrimary";
    let aborting = match keys.get("aborting") {
        None => false,
        Some(toml::Value::Boolean(b)) => *b,
        Some(other) => {
            return Err(format!(
                "key `aborting`: expected true or false, found {}",
                other.type_str()
            ));
        }
    };
    if aborting && !is_move(table.function) {
        return Err(format!(
            "key `aborting`: {} is not a move; only moves abort the others",
            table.function
        ));
    }
    match keys.get("execution_mode") {
        Some(_) if aborting => {
            Err("keys `aborting` and `execution_mode` both set the execution mode".to_owned())
        }
        Some(v) => {
            let m = v
                .as_integer()
                .and_then(|m| u8::try_from(m).ok())
                .filter(|m| execution_mode::is_defined(*m))
                .ok_or_else(|| {
                    format!("key `execution_mode`: {v} is none of the specification's modes 0, 1, 2, 3, 5, 7, 8, 9")
                })?;
            Ok(m)
        }
        None if aborting => Ok(execution_mode::SEQUENCE_ABORT_OTHERS_PRIMARY),
        None if sequence => Ok(execution_mode::SEQUENCE_PRIMARY),
        None if table.function == "GroupJog" => Ok(execution_mode::SEQUENCE_SECONDARY),
        None => Ok(execution_mode::PARALLEL),
    }
}

/// Writes `value` into `field` (named `name`) as its layout asks.
fn write_field(
    w: &mut PayloadWriter<'_>,
    name: &str,
    field: Field,
    value: &toml::Value,
) -> Result<(), String> {
    match field.layout {
        Layout::Scalar(_) if Percent::is_field(name, field) => {
            let p = number(value)?;
            if !(0.0..=PERCENT_MAX).contains(&p) {
                return Err(format!("{p} is outside 0..={PERCENT_MAX} percent"));
            }
            w.set_u16(field, Percent::Value(p).to_wire());
        }
        Layout::Scalar(t) => write_scalar(w, field, t, value)?,
        Layout::Bit(_) => match value {
            toml::Value::Boolean(b) => w.set_bit(field, *b),
            toml::Value::Integer(i @ (0 | 1)) => w.set_bit(field, *i == 1),
            other => return Err(format!("expected true or false, found {other}")),
        },
        Layout::HighNibble | Layout::LowNibble => w.set_u8(field, integer(value, 0, 15)? as u8),
        Layout::Array(WireType::Char, n) => {
            let text = value
                .as_str()
                .filter(|s| s.is_ascii() && s.len() <= n)
                .ok_or_else(|| format!("expected ASCII text of at most {n} characters"))?;
            w.set_chars(field, text);
        }
        Layout::Array(t, n) => {
            let values = match value {
                toml::Value::Array(values) if values.len() <= n => values,
                _ => return Err(format!("expected a list of at most {n} values")),
            };
            for (i, v) in values.iter().enumerate() {
                write_scalar(w, field.element(i), t, v).map_err(|e| format!("[{i}]: {e}"))?;
            }
        }
    }
    Ok(())
}

/// Largest percentage a UINT percent×100 field carries.
pub const PERCENT_MAX: f64 = 655.34;

fn write_scalar(
    w: &mut PayloadWriter<'_>,
    field: Field,
    t: WireType,
    value: &toml::Value,
) -> Result<(), String> {
    match t {
        WireType::F32 => {
            let v = number(value)?;
            if !(v.is_finite() && v.abs() <= f64::from(f32::MAX)) {
                return Err(format!("{v} is not a finite REAL"));
            }
            w.set_f32(field, v as f32);
        }
        WireType::U8 | WireType::Char => w.set_u8(field, integer(value, 0, 255)? as u8),
        WireType::I8 => w.set_i8(field, integer(value, -128, 127)? as i8),
        WireType::U16 => w.set_u16(field, integer(value, 0, 65_535)? as u16),
        WireType::I16 => w.set_i16(field, integer(value, -32_768, 32_767)? as i16),
        WireType::U32 => w.set_u32(field, integer(value, 0, i64::from(u32::MAX))? as u32),
    }
    Ok(())
}

fn number(value: &toml::Value) -> Result<f64, String> {
    match value {
        toml::Value::Float(f) => Ok(*f),
        toml::Value::Integer(i) => Ok(*i as f64),
        other => Err(format!("expected a number, found {other}")),
    }
}

fn integer(value: &toml::Value, lowest: i64, highest: i64) -> Result<i64, String> {
    match value {
        toml::Value::Integer(i) if (lowest..=highest).contains(i) => Ok(*i),
        toml::Value::Integer(i) => Err(format!("{i} is outside {lowest}..={highest}")),
        other => Err(format!("expected an integer, found {other}")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::request::MoveAxesAbsolute;
    use crate::request::tests::encoded;
    use shared_types::srci::payload::PayloadReader;
    use tables::move_linear_absolute::request as mla;

    fn keys(text: &str) -> toml::Table {
        toml::from_str(text).expect("test keys")
    }

    fn request_of(function: &str, text: &str) -> Result<Request, String> {
        request(find(function).expect("a request table"), &keys(text))
    }

    #[test]
    fn a_step_by_field_names_encodes_as_the_typed_request() {
        let typed = Request::MoveAxesAbsolute(MoveAxesAbsolute {
            velocity_rate: Some(50.0),
            jerk_rate: Some(12.5),
            time_ms: 1500,
            blending_mode: 11,
            blending_parameter: [100.0, 0.0],
            tool: 2,
            ..MoveAxesAbsolute::to([1.0, -2.0, 3.5, 4.0, 5.0, -6.25])
        });
        let by_name = request_of(
            "MoveAxesAbsolute",
            "joint_position = [1.0, -2.0, 3.5, 4, 5, -6.25]\nvelocity_rate = 50\n\
             jerk_rate = 12.5\ntime = 1500\nblending_mode = 11\n\
             blending_parameter = [100.0]\ntool_no = 2\n",
        )
        .unwrap();
        assert_eq!(encoded(&by_name), encoded(&typed));
    }

    #[test]
    fn fields_land_at_their_table_offsets() {
        let r = request_of(
            "MoveLinearAbsolute",
            "position = [450.0, -120.5, 300, 180, 0, 90]\nvelocity_rate = 50.0\n\
             config_mode = [0x11, 0x01]\nshoulder = true\nwrist = 1\nturn_mode = 1\n\
             ori_mode = 1\nblending_mode = 3\nblending_parameter = [20.0, 5.0]\n",
        )
        .unwrap();
        assert_eq!(r.command_type(), tables::move_linear_absolute::TYPE);
        assert_eq!(r.execution_mode(), execution_mode::SEQUENCE_PRIMARY);
        let bytes = encoded(&r);
        assert_eq!(bytes.len(), mla::LEN);
        let p = PayloadReader::new(&bytes);
        let position = mla::POSITION_X_RZ.map(|f| p.f32(f));
        assert_eq!(position, [450.0, -120.5, 300.0, 180.0, 0.0, 90.0]);
        assert_eq!(p.u16(mla::VELOCITY_RATE), 5000);
        // Rates left out are "the robot's default".
        for f in [
            mla::ACCELERATION_RATE,
            mla::DECELERATION_RATE,
            mla::JERK_RATE,
        ] {
            assert_eq!(p.u16(f), 0xFFFF);
        }
        assert_eq!(bytes[mla::CONFIG_MODE.offset..][..2], [0x11, 0x01]);
        assert_eq!(
            bytes[mla::SHOULDER.offset],
            0b101,
            "Shoulder and Wrist bits"
        );
        assert_eq!(p.u8(mla::TURN_MODE), 1);
        assert_eq!(p.f32(mla::BLENDING_PARAMETER.element(1)), 5.0);
        assert_eq!(p.u16(mla::TIME), 0, "fields left out are 0");
    }

    /// Table 6-357's ConfigMode[1] and ReferenceType, which it lists as bits of one byte,
    /// land where the server reads them (the correction in shared-types/build.rs).
    #[test]
    fn a_relative_circle_takes_its_config_mode_and_reference_type_as_the_server_reads_them() {
        use tables::move_circular_relative::request as mcr;
        let r = request_of(
            "MoveCircularRelative",
            "config_mode = [0x11, 0x01]\nreference_type = 1\nturn_mode = 2\n",
        )
        .unwrap();
        let bytes = encoded(&r);
        assert_eq!(mcr::CONFIG_MODE.offset, 110);
        assert_eq!(bytes[110..114], [0x11, 0x01, 1, 2]);
        assert_eq!(PayloadReader::new(&bytes).u8(mcr::REFERENCE_TYPE), 1);
    }

    #[test]
    fn the_execution_mode_follows_the_command() {
        let mode =
            |function: &str, text: &str| request_of(function, text).map(|r| r.execution_mode());
        assert_eq!(
            mode("WaitTime", "time = 200"),
            Ok(execution_mode::SEQUENCE_PRIMARY)
        );
        assert_eq!(
            mode("MoveLinearRelative", "aborting = true"),
            Ok(execution_mode::SEQUENCE_ABORT_OTHERS_PRIMARY)
        );
        assert_eq!(
            mode("ReadToolData", "tool_no = 1"),
            Ok(execution_mode::PARALLEL)
        );
        assert_eq!(mode("GroupJog", ""), Ok(execution_mode::SEQUENCE_SECONDARY));
        assert!(is_enable_type(find("GroupJog").unwrap()));
        assert!(
            request_of("GroupJog", "enable = true")
                .unwrap()
                .is_enable_type()
        );
        assert!(!is_enable_type(find("MoveLinearAbsolute").unwrap()));
        assert_eq!(
            mode("MoveDirectAbsolute", "execution_mode = 7"),
            Ok(execution_mode::SEQUENCE_SECONDARY)
        );
        let wait = request_of("WaitTime", "time = 70000").unwrap();
        let t = tables::wait_time::request::TIME;
        assert_eq!(PayloadReader::new(&encoded(&wait)).u32(t), 70_000);
    }

    #[test]
    fn bad_parameters_are_named_with_what_they_must_be() {
        let error = |function: &str, text: &str| request_of(function, text).unwrap_err();
        let e = error("MoveLinearAbsolute", "positon = [0, 0, 0, 0, 0, 0]");
        assert!(e.starts_with("unknown key `positon`; MoveLinearAbsolute takes: aborting, execution_mode, position,"), "{e}");
        assert!(
            !e.contains("par_seq"),
            "header fields are the client's: {e}"
        );
        let e = error("MoveLinearAbsolute", "position = [0, 0, 0]");
        assert_eq!(e, "key `position`: expected a list of 6 numbers");
        let e = error(
            "MoveLinearAbsolute",
            "position = [0, 0, 0, 0, 0, 0]\nposition_z = 1.0",
        );
        assert!(e.contains("set the same field"), "{e}");
        let e = error("MoveLinearAbsolute", "tool_no = 300");
        assert_eq!(e, "key `tool_no`: 300 is outside 0..=255");
        let e = error("MoveLinearAbsolute", "velocity_rate = 700.0");
        assert_eq!(e, "key `velocity_rate`: 700 is outside 0..=655.34 percent");
        let e = error("MoveLinearAbsolute", "blending_parameter = [1.0, 2.0, 3.0]");
        assert_eq!(
            e,
            "key `blending_parameter`: expected a list of at most 2 values"
        );
        let e = error("MoveLinearAbsolute", "position_x = \"far\"");
        assert_eq!(e, "key `position_x`: expected a number, found \"far\"");
        let e = error("MoveLinearAbsolute", "position_x = 1e39");
        assert!(e.contains("is not a finite REAL"), "{e}");
        let e = error("MoveLinearAbsolute", "shoulder = 2");
        assert_eq!(e, "key `shoulder`: expected true or false, found 2");
        let e = error("ReadToolData", "aborting = true");
        assert!(e.contains("ReadToolData is not a move"), "{e}");
        let e = error("MoveLinearAbsolute", "execution_mode = 4");
        assert!(e.contains("none of the specification's modes"), "{e}");
        let e = error("MoveLinearAbsolute", "aborting = true\nexecution_mode = 0");
        assert!(e.contains("both set the execution mode"), "{e}");
        let e = error("MoveLinearAbsolute", "type = 2101");
        assert!(e.starts_with("unknown key `type`"), "{e}");
    }
}
