//! `anguilla dump`: print a bus's frames live, decoded with the drive
//! family's protocol (anguilla's own, CiA 402/CANopen or ODrive CANSimple), and
//! optionally log them in can-utils' `candump -l` format; or decode such a
//! log offline (`--file`), with the same output.

use std::io::Write;
use std::path::PathBuf;
use std::time::Duration;

use anguilla_protocol::Family;
use anguilla_protocol::candump::{Interface, LogEntry, Reader, Record, Timestamp, Writer};
use anguilla_protocol::message::Variant;
use anyhow::Context;

/// Arguments of `anguilla dump`.
#[derive(clap::Args, Debug)]
#[command(group(clap::ArgGroup::new("source").required(true).args(["bus", "file"])))]
pub struct DumpArgs {
    /// Bus to listen on, e.g. `socketcan:can0`, `slcan:/dev/ttyACM0@1000000`.
    #[arg(long, value_name = "SPEC")]
    bus: Option<String>,
    /// Decode this `candump -l` log instead of a live bus (`-` for standard
    /// input): can-utils' and python-can's forms, error frames included.
    #[arg(long, value_name = "LOG", conflicts_with_all = ["bus", "log", "duration"])]
    file: Option<PathBuf>,
    /// Also write every frame to this file (`candump -l` format), a new
    /// one: an existing file is never replaced (a recording).
    #[arg(long, value_name = "FILE")]
    log: Option<PathBuf>,
    /// Decode as CAN FD (default: classic CAN).
    #[arg(long)]
    fd: bool,
    /// Decode with this family's protocol.
    #[arg(long, default_value = "anguilla", value_name = "FAMILY", value_parser = anguilla::family_arg::FamilyParser)]
    drive: Family,
    /// Stop after this many frames.
    #[arg(long, value_name = "N")]
    count: Option<u64>,
    /// Stop after this many seconds.
    #[arg(long, value_name = "SECONDS")]
    duration: Option<f64>,
}

/// How `dump` decodes frames: the family, and for anguilla the variant.
#[derive(Debug, Clone, Copy)]
struct Decoder {
    family: Family,
    variant: Variant,
}

impl Decoder {
    fn decode(&self, f: &anguilla_protocol::Frame) -> String {
        match self.family.decode(f, self.variant) {
            Ok(m) => crate::plain::plain(&format!("{m:?}")),
            Err(e) => format!("(not ours: {e})"),
        }
    }
}

/// One line of `dump`'s output: the timestamp, the frame in candump
/// notation, and what the family's protocol makes of it.
fn print_line(
    out: &mut impl Write,
    ts: Timestamp,
    record: &Record,
    suffix: &str,
    decoder: Decoder,
) -> std::io::Result<()> {
    let decoded = match record {
        Record::Frame(f) => decoder.decode(f),
        Record::Error(e) => format!("error frame: {}", e.describe()),
    };
    let shown = format!("{record}{suffix}");
    writeln!(out, "({}.{:06}) {shown:<24} {decoded}", ts.secs, ts.micros)
}

/// Bad lines of a `--file` log printed one by one; the rest are counted.
const BAD_LINES_SHOWN: usize = 20;

/// `dump --file`: decode a candump log offline. Bad lines are reported on
/// standard error with their numbers and skipped; the exit status is an
/// error when there were any.
fn run_file(path: &std::path::Path, count: Option<u64>, decoder: Decoder) -> anyhow::Result<()> {
    let input: Box<dyn std::io::BufRead> = if path.as_os_str() == "-" {
        Box::new(std::io::stdin().lock())
    } else {
        Box::new(std::io::BufReader::new(
            std::fs::File::open(path).with_context(|| format!("opening {}", path.display()))?,
        ))
    };
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    let (mut n, mut bad) = (0u64, 0usize);
    for entry in Reader::new(input) {
        if count.is_some_and(|c| n >= c) {
            break;
        }
        match entry {
            Ok(e) => {
                n += 1;
                let mut suffix = String::new();
                if let Some(dlc) = e.len8_dlc {
                    suffix = format!("_{dlc:X}");
                }
                print_line(&mut out, e.timestamp, &e.record, &suffix, decoder)
                    .context("writing to standard output")?;
            }
            Err(e) => {
                if let anguilla_protocol::candump::LogErrorKind::Io(kind) = e.kind {
                    out.flush().context("writing to standard output")?;
                    anyhow::bail!("reading {}: {}", path.display(), std::io::Error::from(kind));
                }
                bad += 1;
                if bad <= BAD_LINES_SHOWN {
                    out.flush().context("writing to standard output")?;
                    eprintln!("{}: {e}", path.display());
                }
            }
        }
    }
    out.flush().context("writing to standard output")?;
    if bad > 0 {
        if bad > BAD_LINES_SHOWN {
            eprintln!("({} more bad lines not shown)", bad - BAD_LINES_SHOWN);
        }
        anyhow::bail!(
            "{}: {bad} bad line{} skipped, {n} frames decoded",
            path.display(),
            if bad == 1 { "" } else { "s" }
        );
    }
    eprintln!("{n} frames");
    Ok(())
}

pub fn run(args: DumpArgs) -> anyhow::Result<()> {
    if let Some(d) = args.duration
        && !(d.is_finite() && d > 0.0)
    {
        anyhow::bail!("--duration {d} is invalid (expected a number of seconds > 0)");
    }
    if args.fd && !args.drive.speaks_fd() {
        anyhow::bail!(
            "--fd decodes anguilla's CAN FD variant; {} drives speak classic CAN",
            args.drive
        );
    }
    let decoder = Decoder {
        family: args.drive,
        variant: if args.fd {
            Variant::Fd
        } else {
            Variant::Classic
        },
    };
    let spec = match (&args.bus, &args.file) {
        (_, Some(path)) => {
            return run_file(path, args.count, decoder);
        }
        (Some(spec), None) => spec.clone(),
        (None, None) => anyhow::bail!("give --bus SPEC (live) or --file LOG (offline)"),
    };
    let mut bus = anguilla_drivers::open(&spec).with_context(|| format!("opening bus '{spec}'"))?;
    let mut log = match &args.log {
        Some(p) => Some(Writer::new(std::io::BufWriter::new(
            anguilla::user_file::create_new(p)?,
        ))),
        None => None,
    };
    let name = log_interface(&spec);
    let iface = Interface::new(&name).map_err(|e| anyhow::anyhow!("interface name: {e}"))?;
    crate::signals::install();
    let start = std::time::Instant::now();
    let mut n = 0u64;
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    // A failing stdout ends the dump (the log is still flushed).
    let mut write_failed = None;
    while !crate::signals::requested()
        && args.count.is_none_or(|c| n < c)
        && args
            .duration
            .is_none_or(|d| start.elapsed().as_secs_f64() < d)
    {
        let Some(r) = bus
            .recv(Duration::from_millis(100))
            .with_context(|| format!("reading {spec}"))?
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
        if let Err(e) = print_line(&mut out, ts, &Record::Frame(r.frame), "", decoder) {
            write_failed = Some(e);
        }
        if let Some(w) = log.as_mut() {
            w.write(&LogEntry::new(ts, iface, r.frame))
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
