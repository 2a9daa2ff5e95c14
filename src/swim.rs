//! `anguilla swim`: runs the swimming model on a gait of the paper and writes
//! a CSV trace, an SVG plot, a JSON summary or the paper reproduction table.

use crate::output::outln;
use anguilla_daemon::config::fmt_number;
use anguilla_model::gait::{self, NamedGait};
use anguilla_model::paper;
use anguilla_model::run::{self, Summary};
use anguilla_model::{Model, ModelConfig};
use anyhow::{Context, Result, bail};
use std::io::Write;
use std::path::PathBuf;

/// Arguments of `anguilla swim`.
#[derive(clap::Args, Debug)]
pub struct SwimArgs {
    /// Gait name (F1..F7, T1..T6, STOP, SPIRAL).
    #[arg(long, required_unless_present = "paper")]
    pub gait: Option<String>,
    /// Simulated duration (s).
    #[arg(long, default_value_t = 20.0, allow_negative_numbers = true)]
    pub duration: f64,
    /// Space intervals along the body (rounded up to a multiple of 2(joints+1)).
    #[arg(long, default_value_t = anguilla_model::DEFAULT_NODES)]
    pub nodes: usize,
    /// Time step (s).
    #[arg(long, default_value_t = anguilla_model::DEFAULT_DT, allow_negative_numbers = true)]
    pub dt: f64,
    /// Joints of the discrete robot.
    #[arg(long, default_value_t = 12)]
    pub joints: usize,
    /// Write one CSV row per 0.01 s of simulated time (per step when the
    /// step is longer).
    #[arg(long)]
    pub csv: Option<PathBuf>,
    /// Write an SVG plot (body shapes from above, head velocity).
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Print a JSON summary on stdout.
    #[arg(long)]
    pub json: bool,
    /// Run every gait of the paper's tables and print the comparison.
    #[arg(long, conflicts_with_all = ["gait", "csv", "plot"])]
    pub paper: bool,
}

fn find_gait(name: &str) -> Result<NamedGait> {
    gait::named_gait(name)
        .with_context(|| format!("unknown gait `{name}`; known gaits: {}", gait::gait_names()))
}

/// Smallest model step `swim` takes (s): below it a run takes hours.
const MIN_DT: f64 = 1e-5;
/// Longest simulated run `swim` takes (s).
const MAX_DURATION: f64 = 3600.0;

fn model(args: &SwimArgs) -> Result<Model> {
    if args.nodes == 0 {
        bail!("--nodes must be a positive integer (got 0)");
    }
    if !(MIN_DT..=anguilla_model::MAX_DT).contains(&args.dt) {
        bail!(
            "--dt {} is out of range (expected {MIN_DT} ..= {} s)",
            fmt_number(args.dt),
            anguilla_model::MAX_DT
        );
    }
    Model::new(ModelConfig {
        nodes: args.nodes,
        dt: args.dt,
        joints: args.joints,
        ..ModelConfig::default()
    })
    .context("invalid model configuration")
}

/// Runs the subcommand.
pub fn run(args: &SwimArgs) -> Result<()> {
    if args.paper {
        return paper(args);
    }
    let name = args.gait.as_deref().unwrap_or_default();
    let g = find_gait(name)?;
    if !(args.duration > 0.0 && args.duration <= MAX_DURATION) {
        bail!(
            "--duration {} is out of range (expected 0 < S <= {MAX_DURATION} s)",
            fmt_number(args.duration)
        );
    }
    let model = model(args)?;
    let n = model.joints();
    let mut csv = match &args.csv {
        Some(p) => {
            // a file beside it, renamed over the path when complete
            let f = anguilla::user_file::Replacement::new(p)?;
            let mut w = std::io::BufWriter::new(f);
            let mut h = String::from("t,x,y,z,qw,qx,qy,qz,wx,wy,wz,vx,vy,vz,V1,yaw_deg");
            for pre in ["C2", "C3", "pitch", "yaw"] {
                for j in 1..=n {
                    h.push_str(&format!(",{pre}_{j}"));
                }
            }
            writeln!(w, "{h}")?;
            Some(w)
        }
        None => None,
    };
    let mut shapes: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut vel: Vec<(f64, [f64; 4])> = Vec::new();
    let mut next_row = 0usize;
    let mut next_shape = 0usize;
    let mut io_err: Option<std::io::Error> = None;
    let t0 = std::time::Instant::now();
    let mut io_time = std::time::Duration::ZERO;
    let summary = run::run_gait(&model, &g, args.duration, |r, before, after, ws, yaw| {
        let ti = std::time::Instant::now();
        if r.t + 1e-9 >= next_row as f64 * 0.01 {
            next_row = (r.t / 0.01 + 1e-6).floor() as usize + 1;
            if let Some(w) = csv.as_mut() {
                let q = before.orientation.quaternion();
                let mut line = format!(
                    "{:.4},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
                    r.t,
                    before.position.x,
                    before.position.y,
                    before.position.z,
                    q.w,
                    q.i,
                    q.j,
                    q.k,
                    before.omega.x,
                    before.omega.y,
                    before.omega.z,
                    before.velocity.x,
                    before.velocity.y,
                    before.velocity.z,
                    r.v1,
                    yaw.to_degrees()
                );
                let js = ws.joints();
                for v in js.iter().map(|j| j.c2).chain(js.iter().map(|j| j.c3)) {
                    line.push_str(&format!(",{v}"));
                }
                for v in js.iter().map(|j| j.pitch).chain(js.iter().map(|j| j.yaw)) {
                    line.push_str(&format!(",{v}"));
                }
                if let Err(e) = writeln!(w, "{line}") {
                    io_err.get_or_insert(e);
                }
            }
            if args.plot.is_some() {
                vel.push((
                    r.t,
                    [
                        before.velocity.x,
                        before.velocity.y,
                        before.velocity.z,
                        before.omega.z,
                    ],
                ));
            }
        }
        if args.plot.is_some() && after.t + 1e-9 >= next_shape as f64 {
            next_shape += 1;
            let rot = after.orientation;
            shapes.push(
                ws.shape()
                    .iter()
                    .map(|p| {
                        let q = after.position + rot * p;
                        (q.x, q.y)
                    })
                    .collect(),
            );
        }
        io_time += ti.elapsed();
    })
    .with_context(|| format!("simulating gait {}", g.name))?;
    let wall = (t0.elapsed() - io_time).as_secs_f64();
    if let Some(e) = io_err {
        return Err(e).context("writing the CSV file");
    }
    if let Some(w) = csv {
        w.into_inner()
            .map_err(|e| e.into_error())
            .context("writing the CSV file")?
            .commit()?;
    }
    if let Some(p) = &args.plot {
        plot(p, g.name, &shapes, &vel).with_context(|| format!("writing plot {}", p.display()))?;
    }
    if args.json {
        let v = serde_json::json!({
            "gait": g.name,
            "duration": summary.duration,
            "nodes": model.intervals(),
            "dt": model.dt(),
            "joints": n,
            "mean_forward_speed": summary.mean_forward_speed,
            "mean_yaw_deg": summary.mean_yaw_deg,
            "mean_roll_rate": summary.mean_roll_rate,
            "final_V1": summary.final_v1,
            "wall_seconds": wall,
            "realtime_factor": summary.duration / wall,
        });
        outln!("{v}")?;
    } else {
        print_summary(&g, &model, &summary, wall)?;
    }
    Ok(())
}

fn print_summary(g: &NamedGait, model: &Model, s: &Summary, wall: f64) -> anyhow::Result<()> {
    outln!(
        "gait {}: {} s simulated, {} intervals, dt {} s, {} joints",
        g.name,
        s.duration,
        model.intervals(),
        model.dt(),
        model.joints()
    )?;
    outln!(
        "  mean forward speed -V1 (last 5 periods): {:.4} m/s",
        s.mean_forward_speed
    )?;
    outln!(
        "  mean head yaw (last 5 s):                {:.2} deg",
        s.mean_yaw_deg
    )?;
    outln!(
        "  mean roll rate (whole run):              {:.4} rad/s",
        s.mean_roll_rate
    )?;
    outln!(
        "  final V1:                                {:.4} m/s",
        s.final_v1
    )?;
    outln!(
        "  wall time {:.3} s, {:.0} x real time",
        wall,
        s.duration / wall
    )?;
    Ok(())
}

/// Runs every row of the paper's tables on the model of `args`.
fn paper_table(args: &SwimArgs) -> Result<paper::Table> {
    let model = model(args)?;
    let mut rows = Vec::new();
    for r in paper::PAPER_ROWS {
        let g = find_gait(r.gait)?;
        rows.push(
            paper::Comparison::run(&model, r, g)
                .with_context(|| format!("simulating gait {}", g.name))?,
        );
    }
    Ok(paper::Table::new(&model, rows))
}

fn paper(args: &SwimArgs) -> Result<()> {
    let table = paper_table(args)?;
    if args.json {
        let v: Vec<_> = table
            .rows
            .iter()
            .map(|c| {
                let r = &c.row;
                serde_json::json!({
                    "gait": r.gait,
                    "quantity": format!("{:?}", r.metric),
                    "paper_ns": r.ns,
                    "paper_sm": r.sm,
                    "ours": c.ours,
                    "diff_vs_sm_percent": c.diff_percent(),
                    "window": c.window(),
                    "duration": r.duration,
                })
            })
            .collect();
        outln!(
            "{}",
            serde_json::json!({"nodes": table.intervals, "dt": table.dt, "rows": v})
        )?;
        return Ok(());
    }
    outln!("{table}")?;
    Ok(())
}

fn plot(
    path: &PathBuf,
    name: &str,
    shapes: &[Vec<(f64, f64)>],
    vel: &[(f64, [f64; 4])],
) -> Result<()> {
    use plotters::prelude::*;
    let root = SVGBackend::new(path, (1000, 900)).into_drawing_area();
    root.fill(&WHITE)?;
    let (top, bottom) = root.split_vertically(450);
    let pts = shapes.iter().flatten();
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in pts {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if !x0.is_finite() || x0 > x1 {
        (x0, x1, y0, y1) = (-1.0, 1.0, -1.0, 1.0);
    }
    // equal aspect: pad the smaller range
    let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    let half = ((x1 - x0).max((y1 - y0) * 2.0) / 2.0 + 0.1).max(0.5);
    let mut c = ChartBuilder::on(&top)
        .caption(
            format!("{name}: body shapes from above, one per second"),
            ("sans-serif", 18),
        )
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(45)
        .build_cartesian_2d(cx - half..cx + half, cy - half / 2.0..cy + half / 2.0)?;
    c.configure_mesh().x_desc("x (m)").y_desc("y (m)").draw()?;
    for s in shapes {
        c.draw_series(LineSeries::new(s.iter().copied(), &BLUE))?;
        if let Some(&p) = s.first() {
            c.draw_series(std::iter::once(Circle::new(p, 3, RED.filled())))?;
        }
    }
    let t_end = vel.last().map_or(1.0, |v| v.0.max(1e-3));
    let (mut lo, mut hi) = (f64::MAX, f64::MIN);
    for (_, v) in vel {
        for x in v {
            lo = lo.min(*x);
            hi = hi.max(*x);
        }
    }
    if lo >= hi || !lo.is_finite() {
        (lo, hi) = (-1.0, 1.0);
    }
    let mut c = ChartBuilder::on(&bottom)
        .caption("head velocity, earth frame", ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(45)
        .build_cartesian_2d(0.0..t_end, lo - 0.05..hi + 0.05)?;
    c.configure_mesh().x_desc("t (s)").draw()?;
    let labels = ["vx (m/s)", "vy (m/s)", "vz (m/s)", "wz (rad/s)"];
    let colors = [RED, BLUE, GREEN, MAGENTA];
    for k in 0..4 {
        let col = colors[k];
        c.draw_series(LineSeries::new(vel.iter().map(|(t, v)| (*t, v[k])), &col))?
            .label(labels[k])
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], col));
    }
    c.configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(gait: &str) -> SwimArgs {
        SwimArgs {
            gait: Some(gait.into()),
            duration: 0.2,
            nodes: 12,
            dt: 0.01,
            joints: 3,
            csv: None,
            plot: None,
            json: true,
            paper: false,
        }
    }

    #[test]
    fn csv_has_the_documented_columns_and_one_row_per_10_ms() {
        let dir = std::env::temp_dir().join(format!("anguilla-swim-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let csv = dir.join("f1.csv");
        let svg = dir.join("f1.svg");
        let mut a = args("F1");
        a.csv = Some(csv.clone());
        a.plot = Some(svg.clone());
        run(&a).unwrap();
        let text = std::fs::read_to_string(&csv).unwrap();
        let mut lines = text.lines();
        let header: Vec<&str> = lines.next().unwrap().split(',').collect();
        assert_eq!(header.len(), 16 + 4 * 3);
        assert_eq!(header[15], "yaw_deg");
        assert_eq!(header[16], "C2_1");
        assert_eq!(header[27], "yaw_3");
        let rows: Vec<&str> = lines.collect();
        assert_eq!(rows.len(), 20, "0.2 s at one row per 0.01 s");
        assert!(rows.iter().all(|r| r.split(',').count() == header.len()));
        assert!(!text.contains("NaN"));
        assert!(std::fs::read_to_string(&svg).unwrap().contains("<svg"));
        std::fs::remove_dir_all(&dir).ok();
    }

    /// docs/architecture.md and model/README.md show `anguilla swim
    /// --paper`'s table between their paper-table markers;
    /// `ANGUILLA_BLESS=1` rewrites both.
    #[test]
    fn the_readmes_show_the_paper_table() {
        use clap::Parser as _;
        let cli = crate::Cli::try_parse_from(["anguilla", "swim", "--paper"]).unwrap();
        let crate::Command::Swim(args) = cli.command else {
            panic!("`anguilla swim --paper` parses as swim")
        };
        let block = format!("```text\n{}\n```\n", paper_table(&args).unwrap());
        for page in ["docs/architecture.md", "model/README.md"] {
            let path = format!("{}/{page}", env!("CARGO_MANIFEST_DIR"));
            anguilla_testkit::generated_block(std::path::Path::new(&path), "paper-table", &block);
        }
    }

    #[test]
    fn bad_arguments_are_errors_naming_them() {
        let e = run(&args("F9")).unwrap_err().to_string();
        assert!(e.contains("F9") && e.contains("SPIRAL"), "{e}");
        let mut a = args("F1");
        a.duration = f64::NAN;
        assert!(run(&a).unwrap_err().to_string().contains("--duration"));
        let mut a = args("F1");
        a.dt = -1.0;
        assert!(run(&a).unwrap_err().to_string().contains("--dt"));
        let mut a = args("F1");
        a.dt = 0.2;
        assert!(format!("{:#}", run(&a).unwrap_err()).contains("dt"));
        let mut a = args("F1");
        a.nodes = 0;
        assert!(run(&a).unwrap_err().to_string().contains("--nodes"));
    }
}
