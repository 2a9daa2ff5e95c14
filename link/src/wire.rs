//! The link's own message layouts (docs/remote.md), beside the
//! daemon's payloads (`anguilla_ipc::Raw`): one encoder and one decoder
//! each, used by both ends, and the command key's token. Everything here
//! reads bytes or keys from another host, so none of it needs Zenoh: it
//! compiles without the `zenoh` feature (the fuzz targets build it so).

use anguilla_ipc::{CommandReply, Raw as _};

/// Bytes of a client id (u128 LE) at the head of a command reply.
pub const ID_LEN: usize = 16;

fn word(b: &[u8], at: usize) -> [u8; 8] {
    let mut w = [0u8; 8];
    w.copy_from_slice(&b[at..at + 8]);
    w
}

/// Most bytes of the operator's name that a hello may carry (its
/// attachment).
pub const OPERATOR_NAME_MAX: usize = 32;

/// The operator's name from a hello's attachment, as the link shows it
/// (the holder is then `link:NAME`): ASCII letters, digits, `.` and `_`
/// kept, every other byte (a `-`, which separates a node name's parts, a
/// space, a control character, non-ASCII) made `_`, cut to
/// [`OPERATOR_NAME_MAX`] bytes, `_` trimmed at both ends; `None` when
/// nothing is left. The name is what the tool says: the link cannot check
/// it (the operator's certificate is what lets it in).
pub fn operator_name(b: &[u8]) -> Option<String> {
    let s: String = b
        .iter()
        .take(OPERATOR_NAME_MAX)
        .map(|&c| {
            if c.is_ascii_alphanumeric() || c == b'.' || c == b'_' {
                c as char
            } else {
                '_'
            }
        })
        .collect();
    let s = s.trim_matches('_');
    (!s.is_empty()).then(|| s.to_string())
}

/// The link's clock as a tool knows it: the link process's epoch
/// (random per process) and its clock in ms.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Stamp {
    /// The link process's epoch.
    pub epoch: u64,
    /// The link's clock (ms).
    pub link_ms: i64,
}

impl Stamp {
    /// Its bytes: 16, epoch (u64 LE) then clock (i64 LE).
    pub const LEN: usize = 16;

    /// The bytes of a command's attachment.
    pub fn encode(&self) -> Vec<u8> {
        [self.epoch.to_le_bytes(), self.link_ms.to_le_bytes()].concat()
    }

    /// `None` unless `b` is exactly [`Stamp::LEN`] bytes.
    pub fn decode(b: &[u8]) -> Option<Self> {
        (b.len() == Self::LEN).then(|| Self {
            epoch: u64::from_le_bytes(word(b, 0)),
            link_ms: i64::from_le_bytes(word(b, 8)),
        })
    }
}

/// A hello's reply: the session's client id and the link's clock.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Hello {
    /// The client id the daemon knows the session by.
    pub id: u128,
    /// The link's epoch and clock when it replied.
    pub clock: Stamp,
}

impl Hello {
    /// Its bytes: the id then the [`Stamp`].
    pub const LEN: usize = ID_LEN + Stamp::LEN;

    /// Its bytes.
    pub fn encode(&self) -> Vec<u8> {
        [&self.id.to_le_bytes()[..], &self.clock.encode()].concat()
    }

    /// `None` unless `b` is exactly [`Hello::LEN`] bytes.
    pub fn decode(b: &[u8]) -> Option<Self> {
        if b.len() != Self::LEN {
            return None;
        }
        let mut id = [0u8; ID_LEN];
        id.copy_from_slice(&b[..ID_LEN]);
        Some(Self {
            id: u128::from_le_bytes(id),
            clock: Stamp::decode(&b[ID_LEN..])?,
        })
    }
}

/// A command's reply: the client id then the daemon's `CommandReply`.
pub fn encode_reply(id: u128, r: &CommandReply) -> Vec<u8> {
    [&id.to_le_bytes()[..], r.as_bytes()].concat()
}

/// See [`encode_reply`]; `None` unless `b` is exactly one.
pub fn decode_reply(b: &[u8]) -> Option<(u128, CommandReply)> {
    let r = CommandReply::from_bytes(b.get(ID_LEN..)?)?;
    let mut id = [0u8; ID_LEN];
    id.copy_from_slice(&b[..ID_LEN]);
    Some((u128::from_le_bytes(id), r))
}

/// The token of a command key `prefix/command/<token>`: `None` unless the
/// token is exactly 32 lowercase hex digits (128 bits, as
/// [`crate::command_key`] is given by the remote session).
pub fn token_of(prefix: &str, key: &str) -> Option<String> {
    let t = key.strip_prefix(prefix)?.strip_prefix("/command/")?;
    (t.len() == 32
        && t.bytes()
            .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b)))
    .then(|| t.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_operator_name_is_short_and_cannot_split_a_node_name() {
        assert_eq!(operator_name(b"alice").as_deref(), Some("alice"));
        assert_eq!(operator_name(b"jean-luc").as_deref(), Some("jean_luc"));
        assert_eq!(
            operator_name(b"ctl (user root, pid 1)\n").as_deref(),
            Some("ctl__user_root__pid_1")
        );
        assert_eq!(
            operator_name("żółw".as_bytes()).as_deref(),
            Some("w"),
            "ASCII only"
        );
        assert_eq!(operator_name("żół".as_bytes()), None, "nothing ASCII left");
        assert_eq!(operator_name(b"--__--"), None);
        assert_eq!(operator_name(b""), None);
        let long = operator_name(&[b'a'; 10_000]).unwrap();
        assert_eq!(long.len(), OPERATOR_NAME_MAX);
    }

    #[test]
    fn the_link_messages_decode_what_they_encode_and_nothing_else() {
        use anguilla_ipc::{Command, CommandReply, CommandRequest};
        let h = Hello {
            id: u128::MAX - 7,
            clock: Stamp {
                epoch: 0xfeed,
                link_ms: -3,
            },
        };
        assert_eq!(Hello::decode(&h.encode()), Some(h));
        assert_eq!(Hello::decode(&h.encode()[1..]), None);
        assert_eq!(Stamp::decode(&[0; 15]), None);
        let r = CommandReply::refused(
            &CommandRequest::new(Command::Stop, 9),
            2,
            &"take control first",
        );
        let b = encode_reply(42, &r);
        assert_eq!(decode_reply(&b), Some((42, r)));
        assert_eq!(decode_reply(&b[..b.len() - 1]), None);
        assert_eq!(decode_reply(&[0; 3]), None);
    }

    #[test]
    fn tokens_are_32_lowercase_hex_digits_under_the_prefix() {
        let t = "0123456789abcdef0123456789abcdef";
        assert_eq!(token_of("a/b", &format!("a/b/command/{t}")), Some(t.into()));
        assert_eq!(
            token_of("a/b", &crate::command_key("a/b", t)),
            Some(t.into())
        );
        for bad in [
            format!("a/command/{t}"),
            format!("a/b/command/{}", t.to_uppercase()),
            "a/b/command/0123".to_string(),
            format!("a/b/command/{t}/x"),
            "a/b/command/**".to_string(),
        ] {
            assert_eq!(token_of("a/b", &bad), None, "{bad}");
        }
    }
}
