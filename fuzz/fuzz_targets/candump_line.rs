//! Arbitrary text → candump line parser must not panic; whatever parses
//! must print back to a line that parses to the same entry.
#![no_main]

use anguilla_protocol::candump::parse_line;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|input: &[u8]| {
    let Ok(text) = core::str::from_utf8(input) else {
        return;
    };
    if let Ok(entry) = parse_line(text) {
        let line = entry.to_string();
        assert_eq!(parse_line(&line), Ok(entry), "{line}");
    }
});
