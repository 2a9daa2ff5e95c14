//! Arbitrary bytes from a serial line → SLCAN line reader and parsers must
//! not panic; every frame that parses must encode back to a line that parses
//! to the same frame (and timestamp), and every command likewise.
#![no_main]

use anguilla_drivers::slcan::codec::{
    LineReader, MAX_LINE, Reply, Token, encode_command, encode_frame, parse_command, parse_reply,
};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|input: &[u8]| {
    let mut reader = LineReader::new();
    reader.feed(input, &mut |token| {
        let Token::Line(line) = token else { return };
        assert!(line.len() <= MAX_LINE);
        let mut buf = [0u8; MAX_LINE];
        if let Ok(Reply::Frame { frame, timestamp }) = parse_reply(line) {
            let n = encode_frame(&frame, timestamp, &mut buf);
            assert_eq!(
                parse_reply(&buf[..n - 1]),
                Ok(Reply::Frame { frame, timestamp })
            );
        }
        if let Ok(cmd) = parse_command(line) {
            let n = encode_command(&cmd, &mut buf);
            assert_eq!(parse_command(&buf[..n - 1]), Ok(cmd));
        }
    });
});
