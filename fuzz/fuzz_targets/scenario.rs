//! Arbitrary bytes as a scenario file: the parser returns a scenario or an
//! error naming a line, never panics; a parsed scenario's events are in time
//! order.
#![no_main]

use anguilla_sim::scenario::Scenario;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|input: &[u8]| {
    let Ok(text) = core::str::from_utf8(input) else {
        return;
    };
    match Scenario::parse(text, &[1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12]) {
        Ok(s) => {
            let times: Vec<_> = s.events.iter().map(|e| e.at).collect();
            assert!(times.windows(2).all(|w| w[0] <= w[1]));
        }
        Err(e) => {
            let msg = e.to_string();
            assert!(!msg.is_empty());
        }
    }
});
