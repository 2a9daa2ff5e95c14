//! Arbitrary bytes as the link's messages from another host (a hello's
//! reply, a command's stamp, a command's reply, a hello's operator name)
//! and as a query's key:
//! each decoder must not panic, must accept exactly its own length, and
//! whatever decodes must encode back to the same bytes.
#![no_main]

use anguilla_ipc::{CommandReply, REASON_LEN};
use anguilla_link::wire::{self, Hello, ID_LEN, Stamp};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|input: &[u8]| {
    let stamp = Stamp::decode(input);
    assert_eq!(stamp.is_some(), input.len() == Stamp::LEN);
    if let Some(s) = stamp {
        assert_eq!(s.encode(), input);
    }

    let hello = Hello::decode(input);
    assert_eq!(hello.is_some(), input.len() == Hello::LEN);
    if let Some(h) = hello {
        assert_eq!(h.encode(), input);
    }

    let reply = wire::decode_reply(input);
    assert_eq!(
        reply.is_some(),
        input.len() == ID_LEN + size_of::<CommandReply>()
    );
    if let Some((id, r)) = reply {
        assert_eq!(wire::encode_reply(id, &r), input);
        // What a remote tool shows: never more than the reason's bytes.
        assert!(r.reason().len() <= REASON_LEN);
    }

    // A hello's operator name: short, and nothing that could split or
    // dress up the node name it goes into.
    if let Some(name) = wire::operator_name(input) {
        assert!(!name.is_empty() && name.len() <= wire::OPERATOR_NAME_MAX);
        assert!(name.bytes().all(|c| c.is_ascii_alphanumeric() || c == b'.' || c == b'_'));
    }

    // A query's key: only `prefix/command/<32 lowercase hex digits>`
    // names a session, and the token rebuilds the key exactly.
    if let Ok(key) = std::str::from_utf8(input) {
        for prefix in ["anguilla", "a/b"] {
            if let Some(t) = wire::token_of(prefix, key) {
                assert_eq!(t.len(), 32);
                assert!(t.bytes().all(|b| matches!(b, b'0'..=b'9' | b'a'..=b'f')));
                assert_eq!(anguilla_link::command_key(prefix, &t), key);
            }
        }
    }
});
