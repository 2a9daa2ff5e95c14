//! Arbitrary bytes → a classic frame → ODrive CANSimple decode must not
//! panic, and whatever decodes must encode, and decode again to itself.
#![no_main]

use anguilla_protocol::odrive::decode;
use libfuzzer_sys::fuzz_target;

#[path = "classic_frame.rs"]
mod classic_frame;
use classic_frame::classic_frame;

fuzz_target!(|input: &[u8]| {
    let Some(frame) = classic_frame(input) else {
        return;
    };
    if let Ok(m) = decode(&frame) {
        let again = m.encode().expect("a decoded message encodes");
        assert_eq!(decode(&again).expect("its encoding decodes"), m);
    }
});
