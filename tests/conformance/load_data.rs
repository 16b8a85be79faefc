//! ReadLoadData (5103) and WriteLoadData (5201): loads within the robot's payload.

use plc_client::response::load_data;
use plc_client::{LoadData, Request, Timestamp};
use shared_types::srci::tables::{read_load_data as rld, write_load_data as wld};

use crate::common::{change_indices, expect_done, expect_error, initialized};

#[test]
fn loads_are_written_read_back_and_limited_by_the_payload() {
    let (_c, mut plc) = initialized("load");
    let load = LoadData {
        timestamp: Timestamp {
            date: 12_000,
            time_of_day_ms: 99,
        },
        centre_of_gravity: [0.0, 10.0, 45.5, 0.0, 0.0, 0.0],
        mass_kg: 2.5,
        inertia: [0.01, 0.02, 0.03],
    };
    let before = change_indices(&mut plc);
    expect_done(
        &mut plc,
        &Request::write_load_data(1, &load),
        wld::response::LEN,
    );
    assert_eq!(
        change_indices(&mut plc)[2],
        before[2].wrapping_add(1),
        "ChangeIndexLoad"
    );
    let s = expect_done(&mut plc, &Request::read_load_data(1), rld::response::LEN);
    let (index, read) = load_data(&s.response);
    assert_eq!(index, 1);
    assert_eq!(read.data, load);
    assert!(!read.data_changed);
    let s = expect_done(&mut plc, &Request::read_load_data(255), rld::response::LEN);
    let (in_use, none) = load_data(&s.response);
    assert_eq!((in_use, none.data.mass_kg), (0, 0.0), "no load in use");

    const INVALID_LOAD_NO: u16 = 0x8D17;
    const MASS_EXCEEDS_PAYLOAD: u16 = 0x8D49;
    const INDEX_OUT_OF_RANGE: u16 = 0x8D47;
    for index in [0, 16, 255] {
        expect_error(
            &mut plc,
            &Request::write_load_data(index, &load),
            INVALID_LOAD_NO,
        );
    }
    expect_error(&mut plc, &Request::read_load_data(16), INVALID_LOAD_NO);
    for mass in [1000.0, -0.5, f32::NAN] {
        let mut bad = load;
        bad.mass_kg = mass;
        expect_error(
            &mut plc,
            &Request::write_load_data(2, &bad),
            MASS_EXCEEDS_PAYLOAD,
        );
    }
    let mut bad = load;
    bad.inertia[1] = -1.0;
    expect_error(
        &mut plc,
        &Request::write_load_data(2, &bad),
        INDEX_OUT_OF_RANGE,
    );
    let mut bad = load;
    bad.centre_of_gravity[2] = f32::NAN;
    expect_error(&mut plc, &Request::write_load_data(2, &bad), 0x8D24);
}
