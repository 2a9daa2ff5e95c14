//! Arbitrary bytes as a `CommandRequest` the daemon receives (over
//! iceoryx2 from a local tool, or relayed by the link from another host):
//! reading it must not panic, every byte string of its size is a request
//! and no other, and `command()` either gives a command a tool could have
//! sent for it (same code, same fields) or a refusal whose reason fits the
//! reply unchanged. An E-stop is never refused.
#![no_main]

use anguilla_ipc::{
    Command, CommandReply, CommandRequest, Hold, HoldBody, LAYOUT_VERSION, Raw as _, SwimBody,
    SwimHoldBody, SwimParams, hold_bits,
};
use libfuzzer_sys::fuzz_target;

/// Equal, or both NaN (an f32 NaN's payload need not survive f64 and back).
fn same(a: f64, b: f64) -> bool {
    a == b || (a.is_nan() && b.is_nan())
}

/// The swim `p` read from `b` and sent again as `q`.
fn same_swim(p: &SwimParams, b: &SwimBody, q: &SwimParams) {
    assert!(same(p.amplitude, f64::from(b.amplitude)));
    assert!(same(p.frequency, f64::from(b.frequency)));
    assert!(same(p.turn, f64::from(b.turn)));
    assert!(same(p.pitch, f64::from(b.pitch)));
    assert!(same(p.amplitude, q.amplitude) && same(p.frequency, q.frequency));
    assert!(same(p.turn, q.turn) && same(p.pitch, q.pitch));
}

/// The hold `h` read from `b` and sent again as `g`.
fn same_hold(h: &Hold, b: &HoldBody, g: &Hold) {
    assert!(b.hold <= u32::from(hold_bits::HEADING | hold_bits::DEPTH));
    assert_eq!(u32::from(h.bits()), b.hold);
    assert_eq!(h.bits(), g.bits());
    let opt = |a: Option<f64>, b: Option<f64>| match (a, b) {
        (Some(a), Some(b)) => same(a, b),
        (None, None) => true,
        _ => false,
    };
    assert!(opt(h.heading, g.heading) && opt(h.depth, g.depth));
}

fuzz_target!(|input: &[u8]| {
    let req = CommandRequest::from_bytes(input);
    assert_eq!(req.is_some(), input.len() == size_of::<CommandRequest>());
    let Some(req) = req else { return };
    assert_eq!(req.as_bytes(), input);
    match req.command() {
        Ok(cmd) => {
            assert!(req.is_estop() || req.layout_version == LAYOUT_VERSION);
            assert_eq!(req.is_estop(), cmd == Command::EStop);
            // What a tool sends for this command reads back as it.
            let again = CommandRequest::new(cmd, req.sequence);
            assert_eq!(again.code, req.code);
            let back = again.command().expect("a tool's own request reads");
            match (cmd, back) {
                (Command::Swim(p), Command::Swim(q)) => same_swim(&p, &req.body_as(), &q),
                (Command::Hold(h), Command::Hold(g)) => same_hold(&h, &req.body_as(), &g),
                (Command::SwimHold(p, h), Command::SwimHold(q, g)) => {
                    let (swim, hold) = req.body_as::<SwimHoldBody>().parts();
                    same_swim(&p, &swim, &q);
                    same_hold(&h, &hold, &g);
                }
                // A path's numbers may be NaN (a waypoint's depth is NaN
                // for none): what is sent again reads back the same words.
                (Command::Waypoint(_), Command::Waypoint(_))
                | (Command::Follow(_), Command::Follow(_)) => {
                    assert_eq!(CommandRequest::new(back, req.sequence).body, again.body);
                }
                (c, b) => assert_eq!(c, b),
            }
        }
        Err(e) => {
            assert!(!req.is_estop(), "an E-stop is never refused");
            // The daemon's reply carries the reason whole.
            let r = CommandReply::refused(&req, 0, &e);
            assert_eq!(r.sequence, req.sequence);
            assert_eq!(r.accepted, 0);
            assert_eq!(r.reason(), e.to_string());
        }
    }
});
