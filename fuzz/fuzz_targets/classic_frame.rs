//! The classic CAN frame a fuzz input describes, for the targets of the
//! bought families' codecs: bytes 0 and 1 the 11-bit id (little endian,
//! the top bits dropped); byte 2's bit 0 a remote frame, of length
//! `(byte 2 >> 1) % 9`; the rest its data (at most 8 bytes). `None` for an
//! input too short to say.

use anguilla_protocol::frame::{Frame, Id};

pub fn classic_frame(input: &[u8]) -> Option<Frame> {
    let [a, b, ctl, rest @ ..] = input else {
        return None;
    };
    let id = Id::standard(u16::from_le_bytes([*a, *b]) & 0x7FF).ok()?;
    if ctl & 1 == 0 {
        Frame::new(id, &rest[..rest.len().min(8)]).ok()
    } else {
        Frame::new_remote(id, (ctl >> 1) % 9).ok()
    }
}
