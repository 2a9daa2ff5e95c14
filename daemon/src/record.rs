//! Recording a session: the recorder thread.
//!
//! While recording (`recording.dir`), the controller hands every input and
//! output of every period to the recorder thread through a bounded channel
//! that never blocks (a full channel drops the record and counts it). The
//! recorder writes five files into a fresh directory, flushed and synced to
//! the disk every [`SYNC_INTERVAL`] and at the end (a recording that ends
//! early, the disk full or the daemon killed, replays as truncated):
//!
//! - `bus.log`: every frame in and out, in can-utils' `candump -l` format
//!   (interface `anguilla0`), so `canplayer`, python-can, SavvyCAN and
//!   cantools open it;
//! - `session.log`: the replay script, one line per event
//!   ([`crate::session`] has the format);
//! - `config.toml`: the configuration the daemon ran with;
//! - `state.bin`: every tenth [`StateSnapshot`], as its raw `#[repr(C)]`
//!   bytes (layout in `docs/ipc.md`);
//! - `session.mcap`: the same snapshots for Foxglove, Lichtblick and
//!   PlotJuggler ([`crate::mcap_log`] has the channels), finished with its
//!   summary at the end, and readable up to its last chunk (one a second)
//!   after a kill; with the built-in simulated robot, its ground truth
//!   too ([`crate::truth`]).
//!
//! [`crate::replay`] replays a recording.

use std::io::{BufWriter, Write};
use std::path::PathBuf;

use anguilla_protocol::candump::{self, Interface, LogEntry, Timestamp};
use crossbeam_channel::Receiver;

use crate::config::Config;
use crate::mcap_log::McapLog;
use crate::session::{self, Record};
use crate::truth::GroundTruth;
use anguilla_ipc::vocabulary::Nanos;
use anguilla_ipc::{Raw as _, StateSnapshot};

/// Writes a recording; runs on its own thread until the records and the
/// states close (the ground truth, `(daemon time ns, truth)` from a
/// simulated robot, goes to the MCAP file only, and may close any time).
pub fn recorder(
    dir: PathBuf,
    cfg: Config,
    records: Receiver<Record>,
    mut states: Receiver<StateSnapshot>,
    mut truth: Receiver<(u64, GroundTruth)>,
) -> std::io::Result<()> {
    std::fs::create_dir_all(&dir)?;
    let cfg_text = cfg.to_toml();
    std::fs::write(dir.join("config.toml"), &cfg_text)?;
    let mut session = BufWriter::new(std::fs::File::create(dir.join("session.log"))?);
    let mut bus = candump::Writer::new(BufWriter::new(std::fs::File::create(dir.join("bus.log"))?));
    let mut state = BufWriter::new(std::fs::File::create(dir.join("state.bin"))?);
    let mut mcap = McapLog::create(&dir.join("session.mcap"), &cfg)?;
    // The format, and which config.toml this session ran with (replay
    // checks it).
    session::write_header(&mut session, &cfg_text)?;
    let epoch = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or(0);
    let iface = Interface::new("anguilla0").map_err(|_| std::io::ErrorKind::InvalidInput)?;
    let mut start = None;
    let stamp = |now: Nanos, start: Option<Nanos>| {
        let t = epoch + now.saturating_sub(start.unwrap_or(now)).as_nanos();
        Timestamp {
            secs: t / 1_000_000_000,
            micros: ((t % 1_000_000_000) / 1000) as u32,
        }
    };
    // What is written reaches the disk at most SYNC_INTERVAL late: a power
    // cut or a kill loses at most that much (replay then says where the
    // recording ends).
    let ticks = crossbeam_channel::tick(SYNC_INTERVAL);
    let sync = |session: &mut BufWriter<std::fs::File>,
                bus: &mut candump::Writer<BufWriter<std::fs::File>>,
                state: &mut BufWriter<std::fs::File>| {
        for w in [&mut *session, bus.get_mut(), &mut *state] {
            w.flush()?;
            w.get_ref().sync_data()?;
        }
        std::io::Result::Ok(())
    };
    loop {
        crossbeam_channel::select! {
            recv(ticks) -> _ => {
                mcap.flush()?;
                sync(&mut session, &mut bus, &mut state)?;
            }
            recv(records) -> r => {
                let Ok(r) = r else { break };
                session::write_line(&mut session, &r)?;
                match r {
                    Record::Start(t) => start = Some(t),
                    Record::Rx(now, f) | Record::Tx(now, f) => {
                        bus.write(&LogEntry::new(stamp(now, start), iface, f))?;
                    }
                    _ => {}
                }
            }
            recv(states) -> s => {
                match s {
                    Ok(s) => {
                        state.write_all(s.as_bytes())?;
                        mcap.write(&s)?;
                    }
                    // Closed: wait on the records alone from now on.
                    Err(_) => states = crossbeam_channel::never(),
                }
            }
            recv(truth) -> t => {
                match t {
                    Ok((ns, t)) => mcap.write_truth(ns, &t)?,
                    Err(_) => truth = crossbeam_channel::never(),
                }
            }
        }
    }
    for (ns, t) in truth.try_iter() {
        mcap.write_truth(ns, &t)?;
    }
    // Records are closed; take what is left of the states.
    for s in states.try_iter() {
        state.write_all(s.as_bytes())?;
        mcap.write(&s)?;
    }
    mcap.finish()?;
    sync(&mut session, &mut bus, &mut state)
}

/// How often the recorder flushes its files and syncs them to the disk.
pub const SYNC_INTERVAL: std::time::Duration = std::time::Duration::from_secs(1);
