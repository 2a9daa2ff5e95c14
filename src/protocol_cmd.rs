//! `anguilla protocol ...`: bus budget and DBC generation.

use crate::output::out;
use std::io::Write;
use std::path::PathBuf;

use anguilla_protocol::budget::{self, Bitrates, Budget, Cadence};
use anguilla_protocol::dbc;
use anguilla_protocol::message::Variant;
use anyhow::{Context, bail};
use clap::{Args, Subcommand};

/// The `protocol` subcommands.
#[derive(Subcommand, Debug)]
pub enum ProtocolCmd {
    /// Worst-case bus load of the cyclic traffic (setpoints, SYNC, feedback,
    /// heartbeats) for a robot, with bit stuffing.
    Budget(BudgetArgs),
    /// Print or write the DBC file generated from the message definitions
    /// (anguilla nodes, or the axes of a bought family with `--drive`).
    Dbc(DbcArgs),
    /// Print the Markdown layout tables of protocol/README.md.
    Layout {
        /// The CAN FD variant (default: classic CAN).
        #[arg(long)]
        fd: bool,
    },
    /// Print the node's transition table (state × input) of protocol/README.md.
    Transitions,
}

/// Arguments of `anguilla protocol budget`.
#[derive(Args, Debug)]
pub struct BudgetArgs {
    /// Actuated joints (one node of two axes each), 1..=63.
    #[arg(long, default_value_t = 12)]
    joints: u32,
    /// The drives' family: anguilla (one node per joint) or a bought family
    /// (one drive per axis; classic CAN only).
    #[arg(long, default_value = "anguilla", value_name = "FAMILY", value_parser = anguilla::family_arg::FamilyParser)]
    drive: anguilla_protocol::Family,
    /// The nodes' ids instead of 1..=joints, e.g. `1,7,13` (on CAN FD sparse
    /// ids take more setpoint-group frames).
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "IDS",
        conflicts_with = "joints"
    )]
    node_ids: Vec<u8>,
    /// Control rate in Hz (setpoints + SYNC + feedback per period).
    #[arg(long, default_value_t = 100.0)]
    rate: f64,
    /// Nominal (arbitration) bit rate, bit/s.
    #[arg(long, default_value_t = 1_000_000)]
    bitrate: u32,
    /// CAN FD with bit-rate switching (default data rate 5 Mbit/s).
    #[arg(long)]
    fd: bool,
    /// CAN FD data-phase bit rate, bit/s (requires --fd).
    #[arg(long)]
    data_bitrate: Option<u32>,
    /// Load limit (fraction) for the "max rate" line.
    #[arg(long, default_value_t = 0.6)]
    max_load: f64,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    json: bool,
}

/// Arguments of `anguilla protocol dbc`.
#[derive(Args, Debug)]
pub struct DbcArgs {
    /// The drives' family. CiA 402 drives are described by EDS files, not
    /// DBC.
    #[arg(long, default_value = "anguilla", value_name = "FAMILY", value_parser = anguilla::family_arg::FamilyParser)]
    drive: anguilla_protocol::Family,
    /// The CAN FD variant (default: classic CAN; anguilla only).
    #[arg(long)]
    fd: bool,
    /// Nodes (anguilla) or axes (a bought family) 1..=N to list (a DBC has no
    /// wildcard ids), 1..=63 [default: 12 anguilla nodes; a bought family's
    /// 24 axes, the default ids of 12 joints].
    #[arg(long)]
    nodes: Option<u8>,
    /// A bought family's axes' node ids instead of 1..=N, e.g. `1,2,5`.
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "IDS",
        conflicts_with = "nodes"
    )]
    node_ids: Vec<u8>,
    /// Write to this file instead of standard output.
    #[arg(long)]
    out: Option<PathBuf>,
}

/// Runs a `protocol` subcommand.
pub fn run(cmd: ProtocolCmd) -> anyhow::Result<()> {
    match cmd {
        ProtocolCmd::Budget(a) => run_budget(a),
        ProtocolCmd::Dbc(a) => run_dbc(a),
        ProtocolCmd::Layout { fd } => {
            let variant = if fd { Variant::Fd } else { Variant::Classic };
            out!("{}", anguilla_protocol::doc::layout_markdown(variant))?;
            Ok(())
        }
        ProtocolCmd::Transitions => {
            out!("{}", anguilla_protocol::doc::transitions_markdown())?;
            Ok(())
        }
    }
}

fn run_budget(a: BudgetArgs) -> anyhow::Result<()> {
    let rates = match (a.fd, a.data_bitrate) {
        (false, Some(_)) => bail!("--data-bitrate needs --fd (classic CAN has one bit rate)"),
        (false, None) => Bitrates {
            nominal: a.bitrate,
            data: None,
        },
        (true, d) => Bitrates {
            nominal: a.bitrate,
            data: Some(d.unwrap_or(5_000_000)),
        },
    };
    let nodes = if a.node_ids.is_empty() {
        budget::first_nodes(a.joints).context("invalid --joints")?
    } else {
        let mut set = anguilla_protocol::NodeSet::empty();
        for &id in &a.node_ids {
            let node = anguilla_protocol::NodeId::new(id)
                .map_err(|e| anyhow::anyhow!("--node-ids: {e}"))?;
            if set.contains(id) {
                anyhow::bail!("--node-ids: {id} given twice (expected distinct ids)");
            }
            set = set.with(node);
        }
        set
    };
    if a.drive.drive_per_axis() && !a.node_ids.is_empty() {
        bail!(
            "--node-ids applies to anguilla nodes; {} drives are counted by --joints",
            a.drive
        );
    }
    let traffic = budget::Traffic::of_family(a.drive, nodes);
    let b = budget::budget_of(traffic, a.rate, rates).context("invalid budget arguments")?;
    let max = budget::max_rate_of(traffic, rates, a.max_load).context("invalid --max-load")?;
    let mut out = std::io::stdout().lock();
    if a.json {
        print_json(&mut out, &b, a.max_load, max).context("writing to standard output")?;
    } else {
        print_table(&mut out, &b, a.max_load, max).context("writing to standard output")?;
    }
    Ok(())
}

fn print_table(out: &mut impl Write, b: &Budget, max_load: f64, max: f64) -> anyhow::Result<()> {
    let data = match b.rates.data {
        Some(d) => format!(" / {} kbit/s data phase", d / 1000),
        None => String::new(),
    };
    writeln!(
        out,
        "{} at {} kbit/s{data}: {} joints ({}), {} Hz, period {:.0} us",
        b.variant,
        b.rates.nominal / 1000,
        b.traffic.joints(),
        match b.traffic {
            budget::Traffic::Anguilla(..) => "nodes".to_string(),
            budget::Traffic::Drives { family, axes } => format!("{axes} {}", family.drives_noun()),
        },
        b.rate,
        1e6 / b.rate
    )?;
    writeln!(
        out,
        "worst-case bit stuffing, 3-bit interframe space included"
    )?;
    writeln!(
        out,
        "{:<21} {:>6} {:>12} {:>22} {:>12}",
        "message", "bytes", "frames/per", "bits/frame (nom+data)", "us/period"
    )?;
    for l in &b.lines {
        let frames = l.frames_per_period(b.rate);
        let count = match l.cadence {
            Cadence::PerPeriod(c) => c.max(1) as f64,
            Cadence::PerSecond(_) => 1.0,
        };
        let per_frame = format!(
            "{:.0} + {:.0}",
            l.bits.nominal as f64 / count,
            l.bits.data as f64 / count
        );
        writeln!(
            out,
            "{:<21} {:>6} {:>12.2} {:>22} {:>12.1}",
            l.name,
            l.bytes,
            frames,
            per_frame,
            l.busy_per_second(b.rates, b.rate) / b.rate * 1e6
        )?;
    }
    writeln!(
        out,
        "total: {:.1} us of {:.1} us per period = {:.1} % bus load",
        b.busy_per_period * 1e6,
        1e6 / b.rate,
        b.load * 100.0
    )?;
    writeln!(
        out,
        "max rate at <= {:.0} % load: {:.1} Hz",
        max_load * 100.0,
        max
    )?;
    Ok(())
}

fn print_json(out: &mut impl Write, b: &Budget, max_load: f64, max: f64) -> anyhow::Result<()> {
    let lines: Vec<String> = b
        .lines
        .iter()
        .map(|l| {
            format!(
                "{{\"message\":\"{}\",\"bytes\":{},\"frames_per_period\":{},\"nominal_bits\":{},\"data_bits\":{},\"us_per_period\":{}}}",
                l.name,
                l.bytes,
                l.frames_per_period(b.rate),
                l.bits.nominal,
                l.bits.data,
                l.busy_per_second(b.rates, b.rate) / b.rate * 1e6
            )
        })
        .collect();
    writeln!(
        out,
        "{{\"variant\":\"{}\",\"bitrate\":{},\"data_bitrate\":{},\"joints\":{},\"rate_hz\":{},\"lines\":[{}],\"us_per_period\":{},\"load\":{},\"max_load\":{},\"max_rate_hz\":{}}}",
        match b.variant {
            Variant::Classic => "classic",
            Variant::Fd => "fd",
        },
        b.rates.nominal,
        b.rates.data.map_or("null".to_string(), |d| d.to_string()),
        b.traffic.joints(),
        b.rate,
        lines.join(","),
        b.busy_per_period * 1e6,
        b.load,
        max_load,
        max
    )?;
    Ok(())
}

fn run_dbc(a: DbcArgs) -> anyhow::Result<()> {
    if let Some(n) = a.nodes
        && !(1..=anguilla_protocol::message::MAX_NODE_ID).contains(&n)
    {
        bail!("--nodes {n} is out of range (expected 1..=63)");
    }
    if a.fd && !a.drive.speaks_fd() {
        bail!(
            "--fd does not apply to --drive {} (its drives speak classic CAN only)",
            a.drive
        );
    }
    let text = if a.drive.drive_per_axis() {
        // A bought family: one id per axis, from --nodes N (1..=N), from
        // --node-ids, or the family's default ids of the default robot.
        let ids: Vec<u8> = match a.nodes {
            Some(n) => (1..=n).collect(),
            None if a.node_ids.is_empty() => (0..dbc::DEFAULT_NODES as usize)
                .flat_map(|j| a.drive.default_ids(j))
                .collect(),
            None => {
                for (i, id) in a.node_ids.iter().enumerate() {
                    if a.node_ids[..i].contains(id) {
                        bail!("--node-ids: {id} given twice (expected distinct ids)");
                    }
                }
                a.node_ids.clone()
            }
        };
        a.drive
            .drive_dbc(&ids)
            .map_err(|why| anyhow::anyhow!("--drive {}: {why}", a.drive))?
    } else {
        if !a.node_ids.is_empty() {
            bail!(
                "--node-ids applies to families with a drive per axis (--drive odrive); \
                 the anguilla DBC lists nodes 1..=N (--nodes N)"
            );
        }
        let variant = if a.fd { Variant::Fd } else { Variant::Classic };
        dbc::generate(variant, a.nodes.unwrap_or(dbc::DEFAULT_NODES))
    };
    match a.out {
        Some(path) => {
            anguilla::user_file::replace(&path, text.as_bytes())?;
        }
        None => crate::output::write_fmt(format_args!("{text}"))?,
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args() -> BudgetArgs {
        BudgetArgs {
            joints: 12,
            drive: anguilla_protocol::Family::Anguilla,
            node_ids: Vec::new(),
            rate: 100.0,
            bitrate: 1_000_000,
            fd: false,
            data_bitrate: None,
            max_load: 0.6,
            json: true,
        }
    }

    #[test]
    fn node_ids_are_checked_and_sparse_fd_ids_cost_more() {
        let e = run_budget(BudgetArgs {
            node_ids: vec![1, 64],
            ..args()
        })
        .unwrap_err();
        assert!(format!("{e:#}").contains("--node-ids"), "{e:#}");
        let e = run_budget(BudgetArgs {
            node_ids: vec![3, 3],
            ..args()
        })
        .unwrap_err();
        assert!(format!("{e:#}").contains("3 given twice"), "{e:#}");
    }

    #[test]
    fn bought_families_are_classic_and_counted_by_joints() {
        use anguilla_protocol::Family;
        for drive in [Family::Cia402, Family::Odrive] {
            let e = run_budget(BudgetArgs {
                drive,
                fd: true,
                ..args()
            })
            .unwrap_err();
            assert!(format!("{e:#}").contains("classic CAN"), "{e:#}");
            let e = run_budget(BudgetArgs {
                drive,
                node_ids: vec![1, 2],
                ..args()
            })
            .unwrap_err();
            assert!(format!("{e:#}").contains("--joints"), "{e:#}");
            run_budget(BudgetArgs { drive, ..args() }).unwrap();
        }
    }

    #[test]
    fn bad_budget_arguments_are_clear_errors() {
        let e = run_budget(BudgetArgs {
            data_bitrate: Some(5_000_000),
            ..args()
        })
        .unwrap_err();
        assert!(e.to_string().contains("--data-bitrate needs --fd"), "{e}");
        let e = run_budget(BudgetArgs {
            rate: 0.0,
            ..args()
        })
        .unwrap_err();
        assert!(format!("{e:#}").contains("control rate 0 Hz"), "{e:#}");
        let e = run_budget(BudgetArgs {
            bitrate: 100_000_000,
            ..args()
        })
        .unwrap_err();
        assert!(
            format!("{e:#}").contains("expected 10000..=1000000"),
            "{e:#}"
        );
        assert!(run_budget(args()).is_ok());
    }
}
