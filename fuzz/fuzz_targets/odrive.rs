//! Arbitrary bytes → a classic frame → ODrive CANSimple decode must not
//! panic, and whatever decodes must encode, and decode again to itself.
#![no_main]

use anguilla_protocol::frame::{Frame, Id};
use anguilla_protocol::odrive::decode;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|input: &[u8]| {
    let [a, b, ctl, rest @ ..] = input else {
        return;
    };
    let Ok(id) = Id::standard(u16::from_le_bytes([*a, *b]) & 0x7FF) else {
        return;
    };
    let frame = if ctl & 1 == 0 {
        Frame::new(id, &rest[..rest.len().min(8)])
    } else {
        Frame::new_remote(id, (ctl >> 1) % 9)
    };
    let Ok(frame) = frame else { return };
    if let Ok(m) = decode(&frame) {
        let again = m.encode().expect("a decoded message encodes");
        assert_eq!(decode(&again).expect("its encoding decodes"), m);
    }
});
