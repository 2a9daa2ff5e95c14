//! `anguilla dump`: print a bus's frames live, decoded with our protocol, and
//! optionally log them in can-utils' `candump -l` format.

use std::io::Write;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use anguilla_protocol::candump::{Interface, LogEntry, Timestamp, Writer};
use anguilla_protocol::message::{self, NodeSet, Variant};
use anyhow::Context;

/// Arguments of `anguilla dump`.
#[derive(clap::Args, Debug)]
pub struct DumpArgs {
    /// Bus to listen on, e.g. `socketcan:can0`, `slcan:/dev/ttyACM0@1000000`.
    #[arg(long, value_name = "SPEC")]
    bus: String,
    /// Also write every frame to this file (`candump -l` format).
    #[arg(long, value_name = "FILE")]
    log: Option<PathBuf>,
    /// Decode as CAN FD (default: classic CAN).
    #[arg(long)]
    fd: bool,
    /// Stop after this many frames.
    #[arg(long, value_name = "N")]
    count: Option<u64>,
    /// Stop after this many seconds.
    #[arg(long, value_name = "SECONDS")]
    duration: Option<f64>,
}

static SIGNALLED: AtomicBool = AtomicBool::new(false);

extern "C" fn on_signal(_: libc::c_int) {
    SIGNALLED.store(true, Ordering::SeqCst);
}

pub fn run(args: DumpArgs) -> anyhow::Result<()> {
    if let Some(d) = args.duration
        && !(d.is_finite() && d > 0.0)
    {
        anyhow::bail!("--duration {d} is invalid (expected a number of seconds > 0)");
    }
    let mut bus =
        anguilla_drivers::open(&args.bus).with_context(|| format!("opening bus '{}'", args.bus))?;
    let mut log = match &args.log {
        Some(p) => Some(Writer::new(std::io::BufWriter::new(
            std::fs::File::create(p).with_context(|| format!("creating {}", p.display()))?,
        ))),
        None => None,
    };
    let name = log_interface(&args.bus);
    let iface = Interface::new(&name).map_err(|e| anyhow::anyhow!("interface name: {e}"))?;
    let variant = if args.fd {
        Variant::Fd
    } else {
        Variant::Classic
    };
    let handler = on_signal as extern "C" fn(libc::c_int) as libc::sighandler_t;
    // SAFETY: the handler only stores to an atomic.
    unsafe {
        libc::signal(libc::SIGINT, handler);
        libc::signal(libc::SIGTERM, handler);
        libc::signal(libc::SIGHUP, handler);
    }
    let start = std::time::Instant::now();
    let mut n = 0u64;
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    // A failing stdout ends the dump (the log is still flushed).
    let mut write_failed = None;
    while !SIGNALLED.load(Ordering::SeqCst)
        && args.count.is_none_or(|c| n < c)
        && args
            .duration
            .is_none_or(|d| start.elapsed().as_secs_f64() < d)
    {
        let Some(r) = bus
            .recv(Duration::from_millis(100))
            .with_context(|| format!("reading {}", args.bus))?
        else {
            continue;
        };
        n += 1;
        let now = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap_or_default();
        let ts = Timestamp {
            secs: now.as_secs(),
            micros: now.subsec_micros(),
        };
        let decoded = match message::decode(&r.frame, variant, NodeSet::all()) {
            Ok(m) => format!("{m:?}"),
            Err(e) => format!("(not ours: {e})"),
        };
        if let Err(e) = writeln!(
            out,
            "({}.{:06}) {:<24} {decoded}",
            ts.secs, ts.micros, r.frame
        ) {
            write_failed = Some(e);
        }
        if let Some(w) = log.as_mut() {
            w.write(&LogEntry {
                timestamp: ts,
                interface: iface,
                frame: r.frame,
            })
            .context("writing the log")?;
        }
        if write_failed.is_some() {
            break;
        }
    }
    if let Some(w) = log {
        w.into_inner()
            .and_then(|mut b| b.flush())
            .context("flushing the log")?;
    }
    if let Some(e) = write_failed {
        return Err(anyhow::Error::new(e).context("writing to standard output"));
    }
    eprintln!("{n} frames");
    Ok(())
}

/// The interface name a `--log` line carries for bus `spec`: a SocketCAN
/// interface's own name; `slcan0` for a serial adapter (the name `slcand`
/// gives it); `can0` otherwise. A device path's basename (`/dev/pts/1` →
/// `1`) is no interface name for the tools that read the log.
fn log_interface(spec: &str) -> String {
    let (kind, rest) = spec.split_once(':').unwrap_or(("", spec));
    let own: String = rest
        .split(['@', '?'])
        .next()
        .unwrap_or_default()
        .chars()
        .take(15)
        .collect();
    match kind {
        "socketcan" if !own.is_empty() && own.chars().all(|c| c.is_ascii_graphic()) => own,
        "slcan" => "slcan0".into(),
        _ => "can0".into(),
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn logs_name_a_real_interface() {
        use super::log_interface;
        assert_eq!(log_interface("socketcan:vcan0?fd=1"), "vcan0");
        assert_eq!(log_interface("slcan:/dev/pts/1@1000000"), "slcan0");
        assert_eq!(
            log_interface("slcan:/dev/ttyACM0@1000000?baud=115200"),
            "slcan0"
        );
        assert_eq!(log_interface("mem:test"), "can0");
    }
}
