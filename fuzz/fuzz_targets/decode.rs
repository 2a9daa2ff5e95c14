//! Arbitrary bytes → a frame (id, kind, data) → decode must not panic, and
//! whatever decodes must re-encode to the same identifier and data.
#![no_main]

use anguilla_protocol::frame::{FD_LENGTHS, Frame, Id};
use anguilla_protocol::message::{NodeSet, Variant, decode};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|input: &[u8]| {
    let [a, b, c, d, ctl, rest @ ..] = input else {
        return;
    };
    let raw = u32::from_le_bytes([*a, *b, *c, *d]);
    // Mostly standard ids in the protocol's range, sometimes anything.
    let id = match ctl & 0b11 {
        0 | 1 => Id::standard((raw & 0x3FF) as u16),
        2 => Id::standard((raw & 0x7FF) as u16),
        _ => Id::extended(raw & 0x1FFF_FFFF),
    };
    let Ok(id) = id else { return };
    let frame = match (ctl >> 2) & 0b11 {
        0 => Frame::new(id, &rest[..rest.len().min(8)]),
        1 => Frame::new_remote(id, (ctl >> 4) % 9),
        _ => {
            let len = FD_LENGTHS
                .iter()
                .rev()
                .map(|&l| l as usize)
                .find(|&l| l <= rest.len())
                .unwrap_or(0);
            Frame::new_fd(id, &rest[..len], ctl & 0x80 != 0)
        }
    };
    let Ok(frame) = frame else { return };
    let nodes = if ctl & 0x40 != 0 {
        NodeSet::all()
    } else {
        NodeSet::first(12)
    };
    for variant in [Variant::Classic, Variant::Fd] {
        if let Ok(m) = decode(&frame, variant, nodes) {
            let again = m.encode(variant).expect("a decoded message encodes");
            assert_eq!(again.id(), frame.id());
            assert_eq!(again.data(), frame.data());
            assert_eq!(again.is_fd(), frame.is_fd());
        }
    }
});
