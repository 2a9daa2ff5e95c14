//! Arbitrary bytes → a classic frame → CANopen (CiA 301) decode must not
//! panic, and whatever decodes must encode, and decode again to itself.
#![no_main]

use anguilla_protocol::canopen::{cia402::DriveState, decode};
use libfuzzer_sys::fuzz_target;

#[path = "classic_frame.rs"]
mod classic_frame;
use classic_frame::classic_frame;

fuzz_target!(|input: &[u8]| {
    let [a, b, ..] = input else {
        return;
    };
    // The statusword parser sees the same bytes.
    let word = u16::from_le_bytes([*a, *b]);
    if let Ok(state) = DriveState::from_statusword(word) {
        let (mask, value) = state.pattern();
        assert_eq!(word & mask, value);
    }
    let Some(frame) = classic_frame(input) else {
        return;
    };
    if let Ok(m) = decode(&frame) {
        let again = m.encode();
        assert_eq!(decode(&again).expect("its encoding decodes"), m);
    }
});
