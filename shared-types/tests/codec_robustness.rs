//! Robustness of the SRCI codec against any input (issue 3, item 6): the telegram headers,
//! sequences and fragments, the command and response headers and the table-driven payload
//! reader and writer neither panic nor read or write out of range, whatever the bytes, and
//! what the encoders write decodes to what was encoded.
//!
//! The normal test suite runs a bounded number of cases per property (proptest's default,
//! 256). A long fuzzing run sets `PROPTEST_CASES`:
//!
//! ```sh
//! PROPTEST_CASES=100000 cargo test --release -p shared-types --test codec_robustness
//! ```
//!
//! Failures are not persisted to regression files: proptest prints the shrunk input, which
//! belongs in a named unit test instead.

use proptest::collection::vec;
use proptest::prelude::*;
use proptest::test_runner::Config as ProptestConfig;

use shared_types::srci::message::{CommandHeader, ResponseHeader};
use shared_types::srci::payload::{Field, Layout, PayloadReader, PayloadWriter, WireType};
use shared_types::srci::tables::PAYLOAD_LENGTHS;
use shared_types::srci::telegram::{
    Control, FOOTER_LEN, FRAGMENT_HEADER_LEN, FragmentAction, MAX_TELEGRAM_LEN, MIN_TELEGRAM_LEN,
    PLC_HEADER_LEN, PlcHeader, ROBOT_HEADER_LEN, RobotHeader, SEQUENCE_HEADER_LEN, Sequence,
    SequenceWriter, SrciVersion, TelegramError, sequence_areas,
};

/// Proptest's default configuration (so `PROPTEST_CASES` applies) without regression files.
fn config() -> ProptestConfig {
    ProptestConfig {
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

/// Every scalar wire type.
const WIRE_TYPES: [WireType; 7] = [
    WireType::U8,
    WireType::I8,
    WireType::U16,
    WireType::I16,
    WireType::U32,
    WireType::F32,
    WireType::Char,
];

/// Every layout a generated field can have at one offset: each scalar, both nibbles, each bit
/// of a byte, and arrays of every wire type (`count` elements).
fn layouts(count: usize) -> impl Iterator<Item = Layout> {
    WIRE_TYPES
        .into_iter()
        .map(Layout::Scalar)
        .chain([Layout::HighNibble, Layout::LowNibble])
        .chain((0..8).map(Layout::Bit))
        .chain(WIRE_TYPES.into_iter().map(move |t| Layout::Array(t, count)))
}

fn any_layout() -> impl Strategy<Value = Layout> {
    prop_oneof![
        proptest::sample::select(WIRE_TYPES.to_vec()).prop_map(Layout::Scalar),
        Just(Layout::HighNibble),
        Just(Layout::LowNibble),
        (0u8..8).prop_map(Layout::Bit),
        (proptest::sample::select(WIRE_TYPES.to_vec()), 0usize..40)
            .prop_map(|(t, n)| Layout::Array(t, n)),
    ]
}

/// Every value a reader can produce for `f`, as raw bits (so NaN payloads compare exactly).
fn read_all(r: &PayloadReader, f: Field) -> [u32; 7] {
    [
        u32::from(r.u8(f)),
        u32::from(r.i8(f) as u8),
        u32::from(r.bit(f)),
        u32::from(r.u16(f)),
        u32::from(r.i16(f) as u16),
        r.u32(f),
        r.f32(f).to_bits(),
    ]
}

/// Checks what a decoded sequence yields against the bytes of its area: the body is exactly
/// PayloadLength bytes after the sequence header, fragments tile the body in order, each
/// carries exactly its PayloadLength bytes, and the iterator stops for good after an error.
fn check_sequence(area: &[u8]) {
    let seq = match Sequence::decode(area) {
        Ok(seq) => seq,
        Err(TelegramError::SequenceLength { length, available }) => {
            if area.len() < SEQUENCE_HEADER_LEN {
                assert_eq!((length, available), (0, area.len()));
            } else {
                assert_eq!(length, usize::from(u16::from_be_bytes([area[2], area[3]])));
                assert_eq!(available, area.len() - SEQUENCE_HEADER_LEN);
                assert!(length > available);
            }
            return;
        }
        Err(e) => panic!("unexpected sequence error {e:?}"),
    };
    let declared = usize::from(u16::from_be_bytes([area[2], area[3]]));
    assert_eq!(seq.seq_ack, u16::from_be_bytes([area[0], area[1]]));
    assert_eq!(
        seq.body,
        &area[SEQUENCE_HEADER_LEN..SEQUENCE_HEADER_LEN + declared]
    );
    let mut at = 0;
    let mut fragments = seq.fragments();
    for item in fragments.by_ref() {
        let rest = &seq.body[at..];
        match item {
            Ok((h, data)) => {
                let len = usize::from(h.length);
                assert_eq!(h.cmd_id, u16::from_be_bytes([rest[0], rest[1]]));
                assert_eq!(h.action, FragmentAction(rest[3]));
                assert_eq!(h.pointer, u16::from_be_bytes([rest[4], rest[5]]));
                assert_eq!(len, usize::from(u16::from_be_bytes([rest[6], rest[7]])));
                assert_eq!(data, &rest[FRAGMENT_HEADER_LEN..FRAGMENT_HEADER_LEN + len]);
                at += FRAGMENT_HEADER_LEN + len;
            }
            Err(TelegramError::FragmentLength { cmd_id, length }) => {
                assert_eq!(cmd_id, u16::from_be_bytes([rest[0], rest[1]]));
                assert!(FRAGMENT_HEADER_LEN + length > rest.len());
                assert!(fragments.next().is_none(), "fragments after an error");
                return;
            }
            Err(e) => panic!("unexpected fragment error {e:?}"),
        }
    }
    // Without an error the iterator only leaves bytes too few for another fragment header.
    assert!(seq.body.len() - at < FRAGMENT_HEADER_LEN);
}

/// Decodes everything a telegram of these bytes could hold, in both directions and with one
/// or two sequences, and checks the invariants of each part.
fn check_telegram(t: &[u8]) {
    let in_range = (MIN_TELEGRAM_LEN..=MAX_TELEGRAM_LEN).contains(&t.len());
    match PlcHeader::decode(t) {
        Ok(h) => {
            assert!(in_range);
            assert!(h.fast_stop < 16 && h.lifesign < 16 && h.axes_group < 16);
            assert_eq!(Control::from_nibble(h.control.to_nibble()), h.control);
            // Every defined field survives a decode/encode round: only the reserved byte 7
            // and the footer are rewritten.
            let mut again = t.to_vec();
            h.encode(&mut again).unwrap();
            assert_eq!(again[..7], t[..7]);
            assert_eq!(again[8..PLC_HEADER_LEN], t[8..PLC_HEADER_LEN]);
            assert_eq!(PlcHeader::decode(&again), Ok(h));
            assert!(PlcHeader::is_consistent(&again));
        }
        Err(e) => {
            assert!(!in_range);
            assert_eq!(e, TelegramError::Length(t.len()));
        }
    }
    match RobotHeader::decode(t) {
        Ok(h) => {
            assert!(in_range);
            let mut again = t.to_vec();
            h.encode(&mut again).unwrap();
            assert_eq!(again[0], t[0]);
            assert_eq!(again[1] >> 4, t[1] >> 4);
            assert_eq!(again[3..ROBOT_HEADER_LEN], t[3..ROBOT_HEADER_LEN]);
            assert_eq!(RobotHeader::decode(&again), Ok(h));
            assert!(RobotHeader::is_consistent(&again));
        }
        Err(e) => assert_eq!(e, TelegramError::Length(t.len())),
    }
    // Consistency checks look at both ends, so they must cope with any length.
    let _ = PlcHeader::is_consistent(t);
    let _ = RobotHeader::is_consistent(t);
    for header_len in [PLC_HEADER_LEN, ROBOT_HEADER_LEN] {
        for two in [false, true] {
            let (areas, n) = sequence_areas(t.len(), header_len, 0, two);
            for &(start, len) in &areas[..n] {
                if in_range {
                    // The areas lie between header and footer of every valid telegram.
                    assert!(start >= header_len && start + len + FOOTER_LEN <= t.len());
                }
                if let Some(area) = t.get(start..start + len) {
                    check_sequence(area);
                }
            }
        }
    }
}

/// One fragment to write: CmdID, FragmentAction, PayloadPointer, payload.
type FragmentSpec = (u16, u8, u16, Vec<u8>);

fn fragment_spec(max_data: usize) -> impl Strategy<Value = FragmentSpec> {
    (
        any::<u16>(),
        any::<u8>(),
        any::<u16>(),
        vec(any::<u8>(), 0..max_data),
    )
}

/// Pushes `fragments` into `area` one by one, checking that each push is accepted exactly
/// when it fits and that a refused one adds nothing; returns the accepted ones.
fn write_sequence(area: &mut [u8], seq_ack: u16, fragments: &[FragmentSpec]) -> Vec<FragmentSpec> {
    let area_len = area.len();
    let mut accepted = Vec::new();
    let mut used = 0;
    let mut w = SequenceWriter::new(area, seq_ack);
    for (cmd_id, action, pointer, data) in fragments {
        let fits = SEQUENCE_HEADER_LEN + used + FRAGMENT_HEADER_LEN + data.len() <= area_len;
        assert_eq!(
            w.room(),
            area_len.saturating_sub(SEQUENCE_HEADER_LEN + used + FRAGMENT_HEADER_LEN)
        );
        let before = w.payload_length();
        let pushed = w.push(*cmd_id, *action, *pointer, data);
        assert_eq!(
            pushed,
            fits,
            "push of {} bytes with {used} used",
            data.len()
        );
        if pushed {
            used += FRAGMENT_HEADER_LEN + data.len();
            accepted.push((*cmd_id, *action, *pointer, data.clone()));
        }
        assert_eq!(w.payload_length(), if pushed { used } else { before });
    }
    accepted
}

/// Decodes `area` and checks it holds exactly `seq_ack` and `expected`.
fn assert_sequence_holds(area: &[u8], seq_ack: u16, expected: &[FragmentSpec]) {
    let seq = Sequence::decode(area).unwrap();
    assert_eq!(seq.seq_ack, seq_ack);
    let got: Vec<FragmentSpec> = seq
        .fragments()
        .map(|f| {
            let (h, data) = f.unwrap();
            assert_eq!(usize::from(h.length), data.len());
            (h.cmd_id, h.action.0, h.pointer, data.to_vec())
        })
        .collect();
    assert_eq!(got, expected);
}

/// A PLC header with every field in its wire range.
fn plc_header(len: usize) -> impl Strategy<Value = PlcHeader> {
    (
        (0u8..8, 0u8..32, 0u8..16, 0u8..16),
        (any::<u16>(), any::<u16>(), 0u8..16, 0u8..16),
        (any::<u16>(), any::<u16>(), any::<u16>(), any::<u32>()),
    )
        .prop_map(
            move |(
                (major, minor, fast_stop, lifesign),
                (l1, l2, group, control),
                (n1, n2, d, t),
            )| {
                PlcHeader {
                    version: SrciVersion { major, minor },
                    fast_stop,
                    lifesign,
                    length_plc_to_rob: if l1 % 2 == 0 { len as u16 } else { l1 },
                    length_rob_to_plc: l2,
                    axes_group: group,
                    control: Control::from_nibble(control),
                    telegram_number_plc_to_rob: n1,
                    telegram_number_rob_to_plc: n2,
                    client_date: d,
                    client_time: t,
                }
            },
        )
}

/// A corruption of a telegram: flip bits of some bytes, then cut or extend it.
#[derive(Debug, Clone)]
struct Corruption {
    flips: Vec<(usize, u8)>,
    new_len: Option<usize>,
}

fn corruption() -> impl Strategy<Value = Corruption> {
    (
        vec((any::<usize>(), 1u8..=255), 0..8),
        proptest::option::weighted(0.3, 0usize..300),
    )
        .prop_map(|(flips, new_len)| Corruption { flips, new_len })
}

proptest! {
    #![proptest_config(config())]

    /// Any bytes of any length: no decoder panics and every decoded part matches its bytes.
    #[test]
    fn arbitrary_bytes_decode_without_panic(bytes in vec(any::<u8>(), 0..300)) {
        check_telegram(&bytes);
        check_sequence(&bytes);
        for cut in [0, 1, 2, 3, 4, 5] {
            let p = &bytes[..cut.min(bytes.len())];
            let mut padded = [0u8; 4];
            padded[..p.len().min(4)].copy_from_slice(&p[..p.len().min(4)]);
            // Missing header bytes read as zero.
            prop_assert_eq!(CommandHeader::decode(p), CommandHeader::decode(&padded));
            prop_assert_eq!(ResponseHeader::decode(p), ResponseHeader::decode(&padded));
        }
        let c = CommandHeader::decode(&bytes);
        prop_assert!(c.execution_mode < 16 && c.par_seq < 16 && c.priority < 16);
        let r = ResponseHeader::decode(&bytes);
        prop_assert!(r.par_seq < 16 && r.state < 16);
    }

    /// Well-formed telegrams with one or two sequences of fragments, then corrupted: decoding
    /// never panics and keeps every invariant; uncorrupted, it returns what was written.
    #[test]
    fn corrupted_telegrams_decode_without_panic(
        (len, header) in (MIN_TELEGRAM_LEN..=MAX_TELEGRAM_LEN)
            .prop_flat_map(|len| (Just(len), plc_header(len))),
        two in any::<bool>(),
        seq_acks in any::<[u16; 2]>(),
        fragments in [vec(fragment_spec(80), 0..6), vec(fragment_spec(80), 0..6)],
        damage in corruption(),
    ) {
        let mut t = vec![0u8; len];
        header.encode(&mut t).unwrap();
        let (areas, n) = sequence_areas(len, PLC_HEADER_LEN, 0, two);
        let mut written = Vec::new();
        for (i, &(start, area_len)) in areas[..n].iter().enumerate() {
            let area = &mut t[start..start + area_len];
            written.push(write_sequence(area, seq_acks[i], &fragments[i]));
        }
        prop_assert!(PlcHeader::is_consistent(&t));
        prop_assert_eq!(PlcHeader::decode(&t), Ok(header));
        for (i, &(start, area_len)) in areas[..n].iter().enumerate() {
            assert_sequence_holds(&t[start..start + area_len], seq_acks[i], &written[i]);
        }
        check_telegram(&t);
        for &(at, mask) in &damage.flips {
            let i = at % len;
            t[i] ^= mask;
        }
        if let Some(new_len) = damage.new_len {
            t.resize(new_len, 0xA5);
        }
        check_telegram(&t);
    }

    /// Robot headers round-trip through their encoding with any field values.
    #[test]
    fn robot_header_round_trips(
        len in MIN_TELEGRAM_LEN..=MAX_TELEGRAM_LEN,
        version in (0u8..8, 0u8..32),
        lifesign in 0u8..16,
        telegram_state in any::<u8>(),
        status in any::<u32>(),
        override_centi in any::<u16>(),
        garbage in any::<u8>(),
    ) {
        let h = RobotHeader {
            version: SrciVersion { major: version.0, minor: version.1 },
            lifesign,
            telegram_state,
            status,
            override_centi,
        };
        let mut t = vec![garbage; len];
        h.encode(&mut t).unwrap();
        prop_assert_eq!(RobotHeader::decode(&t), Ok(h));
        prop_assert!(RobotHeader::is_consistent(&t));
    }

    /// Encoding refuses buffers outside 64..=256 bytes without touching them.
    #[test]
    fn encoders_refuse_wrong_lengths(
        len in prop_oneof![0usize..MIN_TELEGRAM_LEN, MAX_TELEGRAM_LEN + 1..400],
        header in plc_header(64),
    ) {
        let mut t = vec![0x5Au8; len];
        prop_assert_eq!(header.encode(&mut t), Err(TelegramError::Length(len)));
        let robot = RobotHeader {
            version: SrciVersion::CURRENT,
            lifesign: 1,
            telegram_state: 255,
            status: 0,
            override_centi: 0,
        };
        prop_assert_eq!(robot.encode(&mut t), Err(TelegramError::Length(len)));
        prop_assert!(t.iter().all(|&b| b == 0x5A));
    }

    /// Command and response headers round-trip with every field in its wire range.
    #[test]
    fn message_headers_round_trip(
        command_type in any::<u16>(),
        nibbles in [0u8..16, 0u8..16, 0u8..16],
        severity in any::<i8>(),
        code in any::<u16>(),
        tail in vec(any::<u8>(), 0..8),
    ) {
        let c = CommandHeader {
            command_type,
            execution_mode: nibbles[0],
            par_seq: nibbles[1],
            priority: nibbles[2],
        };
        let mut p = vec![0u8; CommandHeader::LEN];
        p.extend_from_slice(&tail);
        c.encode(&mut p);
        prop_assert_eq!(CommandHeader::decode(&p), c);
        let r = ResponseHeader { par_seq: nibbles[0], state: nibbles[1], severity, code };
        r.encode(&mut p);
        prop_assert_eq!(ResponseHeader::decode(&p), r);
        prop_assert_eq!(&p[ResponseHeader::LEN..], &tail[..]);
    }

    /// SequenceWriter → Sequence: what was pushed is what is read back, in order, and a
    /// fragment that does not fit is refused whole.
    #[test]
    fn written_sequences_read_back(
        area_len in 0usize..250,
        seq_ack in any::<u16>(),
        fragments in vec(fragment_spec(120), 0..10),
        dirt in any::<u8>(),
    ) {
        let mut area = vec![dirt; area_len];
        let accepted = write_sequence(&mut area, seq_ack, &fragments);
        if area_len < SEQUENCE_HEADER_LEN {
            prop_assert!(accepted.is_empty());
            prop_assert!(Sequence::decode(&area).is_err());
        } else {
            assert_sequence_holds(&area, seq_ack, &accepted);
            let used: usize = accepted.iter().map(|f| FRAGMENT_HEADER_LEN + f.3.len()).sum();
            // Everything after the fragments is zero: the writer clears stale bytes.
            prop_assert!(area[SEQUENCE_HEADER_LEN + used..].iter().all(|&b| b == 0));
        }
    }

    /// Reading any field of any table from a payload cut short (down to empty) gives what a
    /// zero-padded payload gives: missing bytes read as zero, nothing panics.
    #[test]
    fn payload_reader_pads_short_payloads_with_zeros(
        table in 0..PAYLOAD_LENGTHS.len(),
        response in any::<bool>(),
        bytes in vec(any::<u8>(), 256),
        cut in any::<proptest::sample::Index>(),
    ) {
        let (_, _, request_len, response_len) = PAYLOAD_LENGTHS[table];
        let len = if response { response_len } else { request_len };
        let short = &bytes[..cut.index(len + 1)];
        let mut padded = vec![0u8; len + 8];
        padded[..short.len()].copy_from_slice(short);
        let (r_short, r_padded) = (PayloadReader::new(short), PayloadReader::new(&padded));
        for offset in 0..len + 8 {
            for layout in layouts(4) {
                let f = Field { offset, layout };
                prop_assert_eq!(read_all(&r_short, f), read_all(&r_padded, f), "{:?}", f);
            }
        }
    }

    /// Writing a field that lies partly or wholly past the end of the buffer neither panics
    /// nor changes a byte outside the field; a field inside reads back what was written.
    #[test]
    fn payload_writer_stays_in_range(
        buffer_len in 0usize..64,
        offset in 0usize..96,
        layout in any_layout(),
        value in any::<u32>(),
        text in "[ -~]{0,40}",
        initial in vec(any::<u8>(), 64),
    ) {
        const GUARD: usize = 16;
        let mut whole = vec![0xC3u8; GUARD + buffer_len + GUARD];
        whole[GUARD..GUARD + buffer_len].copy_from_slice(&initial[..buffer_len]);
        let before = whole.clone();
        let f = Field { offset, layout };
        let inside = offset + f.size() <= buffer_len;
        let buffer = &mut whole[GUARD..GUARD + buffer_len];
        let mut w = PayloadWriter::new(buffer);
        let wire = match layout {
            Layout::Scalar(t) | Layout::Array(t, _) => t,
            _ => WireType::U8,
        };
        match (layout, wire) {
            (Layout::Array(WireType::Char, _), _) => w.set_chars(f, &text),
            (Layout::Array(..), _) => w.set_bytes(f, &value.to_be_bytes()),
            (_, WireType::U8 | WireType::Char) => w.set_u8(f, value as u8),
            (_, WireType::I8) => w.set_i8(f, value as i8),
            (_, WireType::U16) => w.set_u16(f, value as u16),
            (_, WireType::I16) => w.set_i16(f, value as i16),
            (_, WireType::U32) => w.set_u32(f, value),
            (_, WireType::F32) => w.set_f32(f, f32::from_bits(value)),
        }
        // Outside the buffer nothing changed; inside it only the field's bytes.
        let field_end = GUARD + offset + f.size();
        for (i, (&now, &was)) in whole.iter().zip(&before).enumerate() {
            if !(GUARD + offset..field_end).contains(&i) || i >= GUARD + buffer_len {
                prop_assert_eq!(now, was, "byte {} outside {:?}", i, f);
            }
        }
        // Strings and byte arrays are written element by element: the part inside the buffer
        // holds the (truncated, zero-padded) source. Scalars inside read back as written.
        let r = PayloadReader::new(&whole[GUARD..GUARD + buffer_len]);
        match (layout, wire) {
            (Layout::Array(..), _) => {
                let number = value.to_be_bytes();
                let src = if wire == WireType::Char { text.as_bytes() } else { &number[..] };
                let start = offset.min(buffer_len);
                let end = (offset + f.size()).min(buffer_len);
                let expect: Vec<u8> =
                    (0..end - start).map(|i| src.get(i).copied().unwrap_or(0)).collect();
                prop_assert_eq!(&whole[GUARD + start..GUARD + end], &expect[..]);
            }
            _ if !inside => {}
            (Layout::HighNibble | Layout::LowNibble, _) => {
                prop_assert_eq!(r.u8(f), (value as u8) & 0x0F);
            }
            (Layout::Bit(_), _) => prop_assert_eq!(r.bit(f), value as u8 != 0),
            (_, WireType::U8 | WireType::Char) => prop_assert_eq!(r.u8(f), value as u8),
            (_, WireType::I8) => prop_assert_eq!(r.i8(f), value as i8),
            (_, WireType::U16) => prop_assert_eq!(r.u16(f), value as u16),
            (_, WireType::I16) => prop_assert_eq!(r.i16(f), value as i16),
            (_, WireType::U32) => prop_assert_eq!(r.u32(f), value),
            (_, WireType::F32) => prop_assert_eq!(r.f32(f).to_bits(), value),
        }
    }
}

/// Every table of the specification read from an empty payload: every field at every offset
/// of the table (a superset of its generated fields) reads as zero.
#[test]
fn every_table_reads_zero_from_an_empty_payload() {
    let empty = PayloadReader::new(&[]);
    for &(command_type, name, request_len, response_len) in &PAYLOAD_LENGTHS {
        for len in [request_len, response_len] {
            for offset in 0..len {
                for layout in layouts(len - offset) {
                    let f = Field { offset, layout };
                    assert_eq!(read_all(&empty, f), [0; 7], "{name} ({command_type}) {f:?}");
                }
            }
        }
    }
}
