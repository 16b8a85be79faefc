//! MoveDirectOffset (2111): a joint-interpolated move to a reference position displaced by
//! an offset in the frame's axes.

use shared_types::srci::payload::PayloadReader;
use shared_types::srci::tables::move_direct_offset as mdo;

use super::move_requests::{
    assert_tcp_at, expect_move_done, keep_configuration, move_request, set_pose, shifted, tcp,
};
use crate::common::enabled;

#[test]
fn the_tcp_reaches_the_displaced_reference() {
    let (_c, mut plc) = enabled("mdo");
    let reference = tcp(&mut plc, 0, 0);
    let rates = [
        mdo::request::VELOCITY_RATE,
        mdo::request::ACCELERATION_RATE,
        mdo::request::DECELERATION_RATE,
        mdo::request::JERK_RATE,
    ];
    let request = move_request(mdo::TYPE, rates, |w| {
        set_pose(w, mdo::request::REFERENCE_POSITION_X_RZ, reference);
        set_pose(
            w,
            mdo::request::OFFSET_X_RZ,
            [30.0, -30.0, 0.0, 0.0, 0.0, 0.0],
        );
        keep_configuration(w, mdo::request::CONFIG_MODE, mdo::request::TURN_MODE);
        w.set_u8(mdo::request::REFERENCE_TYPE, 1);
    });
    let response = expect_move_done(&mut plc, &request);
    assert_eq!(response.len(), mdo::response::LEN);
    assert_eq!(
        PayloadReader::new(&response).u16(mdo::response::PROGRESS),
        10_000
    );
    assert_tcp_at(&mut plc, shifted(reference, [30.0, -30.0, 0.0]));
}
