//! Arbitrary bytes → a classic frame → CANopen (CiA 301) decode must not
//! panic, and whatever decodes must encode, and decode again to itself.
#![no_main]

use anguilla_protocol::canopen::{cia402::DriveState, decode};
use anguilla_protocol::frame::{Frame, Id};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|input: &[u8]| {
    let [a, b, ctl, rest @ ..] = input else {
        return;
    };
    // The statusword parser sees the same bytes.
    let word = u16::from_le_bytes([*a, *b]);
    if let Ok(state) = DriveState::from_statusword(word) {
        let (mask, value) = state.pattern();
        assert_eq!(word & mask, value);
    }
    let Ok(id) = Id::standard(word & 0x7FF) else {
        return;
    };
    let frame = if ctl & 1 == 0 {
        Frame::new(id, &rest[..rest.len().min(8)])
    } else {
        Frame::new_remote(id, (ctl >> 1) % 9)
    };
    let Ok(frame) = frame else { return };
    if let Ok(m) = decode(&frame) {
        let again = m.encode();
        assert_eq!(decode(&again).expect("its encoding decodes"), m);
    }
});
