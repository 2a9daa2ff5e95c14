//! Arbitrary bytes → a classic frame → MIT-mode decode (the Mini Cheetah
//! controller's ranges) must not panic, and whatever decodes must encode,
//! and decode again to itself.
#![no_main]

use anguilla_protocol::mit::{DEFAULT_RANGES, decode};
use libfuzzer_sys::fuzz_target;

#[path = "classic_frame.rs"]
mod classic_frame;
use classic_frame::classic_frame;

fuzz_target!(|input: &[u8]| {
    let Some(frame) = classic_frame(input) else {
        return;
    };
    let r = DEFAULT_RANGES;
    if let Ok(m) = decode(&frame, &r) {
        let again = m.encode(&r).expect("a decoded message encodes");
        assert_eq!(decode(&again, &r).expect("its encoding decodes"), m);
    }
});
