//! A cut MCAP file (a daemon killed mid-chunk) copied into a complete one.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{self, BufWriter};
use std::path::Path;

use mcap::records::MessageHeader;

use super::err;

/// What [`repair`] did.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Repaired {
    /// Messages copied (every one readable before the cut).
    pub messages: u64,
    /// Channels copied.
    pub channels: usize,
    /// Why reading stopped: `None` when the file was whole.
    pub cut: Option<String>,
}

/// Copies the MCAP file `input` into a complete one at `out`: every
/// message readable in order before the end or the cut (a daemon killed
/// mid-chunk leaves a file without summary and index, which indexed
/// readers refuse), on the same channels and schemas, then the summary
/// and index. Any channel is kept, `/sim/truth` included (which an
/// [`export`](fn@super::export) from `state.bin` cannot give back).
pub fn repair(input: &Path, out: &Path) -> io::Result<Repaired> {
    let file = File::create(out)
        .map_err(|e| io::Error::new(e.kind(), format!("{}: {e}", out.display())))?;
    repair_into(input, file)
}

/// [`repair`] into `out`, opened by the caller.
pub fn repair_into(input: &Path, out: File) -> io::Result<Repaired> {
    let named =
        |what: &Path, e: io::Error| io::Error::new(e.kind(), format!("{}: {e}", what.display()));
    let bytes = std::fs::read(input).map_err(|e| named(input, e))?;
    let stream = mcap::MessageStream::new(&bytes).map_err(|e| {
        io::Error::new(
            io::ErrorKind::InvalidData,
            format!("{}: not an MCAP file ({e})", input.display()),
        )
    })?;
    let file = BufWriter::new(out);
    let mut w = mcap::WriteOptions::new()
        .compression(None)
        .profile("")
        .create(file)
        .map_err(err)?;
    // The input's channel ids to the output's.
    let mut channels: BTreeMap<u16, u16> = BTreeMap::new();
    let (mut messages, mut cut) = (0u64, None);
    for m in stream {
        let m = match m {
            Ok(m) => m,
            Err(e) => {
                cut = Some(e.to_string());
                break;
            }
        };
        let id = match channels.get(&m.channel.id) {
            Some(&id) => id,
            None => {
                let schema_id = match &m.channel.schema {
                    Some(s) => w.add_schema(&s.name, &s.encoding, &s.data).map_err(err)?,
                    None => 0,
                };
                let id = w
                    .add_channel(
                        schema_id,
                        &m.channel.topic,
                        &m.channel.message_encoding,
                        &m.channel.metadata,
                    )
                    .map_err(err)?;
                channels.insert(m.channel.id, id);
                id
            }
        };
        w.write_to_known_channel(
            &MessageHeader {
                channel_id: id,
                sequence: m.sequence,
                log_time: m.log_time,
                publish_time: m.publish_time,
            },
            &m.data,
        )
        .map_err(err)?;
        messages += 1;
    }
    w.finish().map_err(err)?;
    io::Write::flush(&mut w.into_inner())?;
    Ok(Repaired {
        messages,
        channels: channels.len(),
        cut,
    })
}
