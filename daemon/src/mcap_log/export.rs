//! An MCAP file written again from a recorded session's `state.bin`
//! (`anguilla export`), and the snapshots of a `state.bin` read one by one.

use std::fs::File;
use std::io;
use std::path::Path;

use anguilla_ipc::{Raw as _, StateSnapshot};

use super::McapLog;
use crate::config::Config;

/// What [`export`] did.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Exported {
    /// Snapshots written.
    pub snapshots: u64,
    /// Bytes at the end of `state.bin` that were not a whole snapshot (a
    /// recording cut short), left out.
    pub partial_bytes: usize,
}

/// Writes `out` from a recorded session directory `dir` (its
/// `config.toml` and `state.bin`): the MCAP file of a session recorded
/// without one, or again.
pub fn export(dir: &Path, out: &Path) -> io::Result<Exported> {
    export_with(dir, out, &mut |_, _| {})
}

/// [`export`], telling `progress(snapshots done, snapshots in all)` every
/// [`crate::replay::PROGRESS_EVERY`] snapshots and at the end.
pub fn export_with(
    dir: &Path,
    out: &Path,
    progress: &mut dyn FnMut(u64, u64),
) -> io::Result<Exported> {
    let file = File::create(out)
        .map_err(|e| io::Error::new(e.kind(), format!("{}: {e}", out.display())))?;
    export_into(dir, file, progress)
}

/// [`export_with`] into `file`, opened by the caller.
pub fn export_into(
    dir: &Path,
    file: File,
    progress: &mut dyn FnMut(u64, u64),
) -> io::Result<Exported> {
    let cfg = Config::load(&dir.join("config.toml"))
        .map_err(|e| io::Error::new(io::ErrorKind::InvalidData, e.to_string()))?;
    let mut log = McapLog::from_file(file, &cfg)?;
    let (_, n, partial) = for_each_state(dir, |i, total, s| {
        if i.is_multiple_of(crate::replay::PROGRESS_EVERY) {
            progress(i, total);
        }
        log.write(s)
    })?;
    log.finish()?;
    progress(n, n);
    Ok(Exported {
        snapshots: n,
        partial_bytes: partial,
    })
}

/// Reads the session `dir`'s configuration and calls `f` with each
/// snapshot of its `state.bin`, its index and their count: the snapshots
/// `anguilla export` turns into MCAP and rosbag2 files. Returns the
/// configuration, the snapshots read and the bytes at the end that were
/// not a whole snapshot (a recording cut short). A snapshot of another
/// layout version is an error that says which.
pub fn for_each_state(
    dir: &Path,
    mut f: impl FnMut(u64, u64, &StateSnapshot) -> io::Result<()>,
) -> io::Result<(Config, u64, usize)> {
    let named = |what: &str, e: io::Error| io::Error::new(e.kind(), format!("{what}: {e}"));
    let cfg_path = dir.join("config.toml");
    let cfg = Config::load(&cfg_path)
        .map_err(|e| io::Error::new(io::ErrorKind::InvalidData, e.to_string()))?;
    let states = dir.join("state.bin");
    let bytes = std::fs::read(&states).map_err(|e| named(&states.display().to_string(), e))?;
    let size = core::mem::size_of::<StateSnapshot>();
    let total = (bytes.len() / size) as u64;
    let mut n = 0u64;
    for (i, chunk) in bytes.chunks_exact(size).enumerate() {
        let s = StateSnapshot::from_bytes(chunk)
            .ok_or_else(|| io::Error::from(io::ErrorKind::InvalidData))?;
        if s.layout_version != anguilla_ipc::LAYOUT_VERSION {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                format!(
                    "{}: snapshot {i} has layout version {} (this anguilla reads {}); \
                     export it with the anguilla that recorded it",
                    states.display(),
                    s.layout_version,
                    anguilla_ipc::LAYOUT_VERSION
                ),
            ));
        }
        f(i as u64, total, &s)?;
        n += 1;
    }
    Ok((cfg, n, bytes.len() % size))
}
