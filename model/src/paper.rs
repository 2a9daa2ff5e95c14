//! The paper's comparison tables (Tables 2, 4, 6 and section 7.5): which
//! gait each row runs, what it compares, the paper's values, and the rows of
//! the reproduction table that `anguilla swim --paper` prints and README.md
//! shows. No I/O: a [`Table`] is [`Display`](fmt::Display)ed by the caller.
//!
//! ```
//! use anguilla_model::{Model, ModelConfig, gait, paper};
//!
//! let model = Model::new(ModelConfig { nodes: 12, dt: 0.02, ..ModelConfig::default() })?;
//! let row = paper::PAPER_ROWS[0];
//! let f1 = gait::named_gait(row.gait).unwrap();
//! let short = paper::PaperRow { duration: 1.0, ..row };
//! let c = paper::Comparison::run(&model, short, f1)?;
//! assert!(c.ours > 0.0); // F1 swims head first
//! let table = paper::Table::new(&model, vec![c]);
//! assert!(table.to_string().lines().last().unwrap().starts_with("F1     -V1 (m/s)"));
//! # Ok::<(), anguilla_model::ModelError>(())
//! ```

use crate::dynamics::Model;
use crate::error::Result;
use crate::gait::NamedGait;
use crate::run::{self, Summary};
use std::fmt;

/// What a row of the paper's tables compares.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Metric {
    /// Mean forward speed `-V1(0)` (m/s), Table 2.
    ForwardSpeed,
    /// Mean head yaw after the turn (deg), Table 4.
    YawDeg,
    /// Head `V1` at the final time 20 s (m/s), Table 6.
    FinalV1,
    /// Mean roll rate (rad/s), section 7.5.
    RollRate,
}

/// One row of the paper's tables.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PaperRow {
    /// Gait name.
    pub gait: &'static str,
    /// Compared quantity.
    pub metric: Metric,
    /// Navier–Stokes value, when the paper gives one.
    pub ns: Option<f64>,
    /// The paper's simplified-model value.
    pub sm: f64,
    /// Run duration used here (s).
    pub duration: f64,
}

const fn row(
    gait: &'static str,
    metric: Metric,
    ns: Option<f64>,
    sm: f64,
    duration: f64,
) -> PaperRow {
    PaperRow {
        gait,
        metric,
        ns,
        sm,
        duration,
    }
}

/// Tables 2, 4, 6 and section 7.5 of the paper.
pub const PAPER_ROWS: [PaperRow; 15] = [
    row("F1", Metric::ForwardSpeed, Some(0.642), 0.619, 30.0),
    row("F2", Metric::ForwardSpeed, Some(0.613), 0.614, 30.0),
    row("F3", Metric::ForwardSpeed, Some(1.310), 1.270, 30.0),
    row("F4", Metric::ForwardSpeed, Some(0.412), 0.407, 30.0),
    row("F5", Metric::ForwardSpeed, Some(0.753), 0.721, 30.0),
    row("F6", Metric::ForwardSpeed, Some(0.452), 0.456, 30.0),
    row("F7", Metric::ForwardSpeed, Some(0.278), 0.306, 30.0),
    row("T1", Metric::YawDeg, Some(-88.0), -86.0, 15.0),
    row("T2", Metric::YawDeg, Some(-116.0), -117.0, 15.0),
    row("T3", Metric::YawDeg, Some(-163.0), -166.0, 15.0),
    row("T4", Metric::YawDeg, Some(-94.0), -98.0, 15.0),
    row("T5", Metric::YawDeg, Some(-45.0), -49.0, 15.0),
    row("T6", Metric::YawDeg, Some(-157.0), -167.0, 15.0),
    row("STOP", Metric::FinalV1, Some(0.0321), -0.0581, 20.0),
    row("SPIRAL", Metric::RollRate, None, 0.31, 10.0),
];

/// Our value of `row`'s metric from a run summary.
pub fn metric_value(metric: Metric, s: &Summary) -> f64 {
    match metric {
        Metric::ForwardSpeed => s.mean_forward_speed,
        Metric::YawDeg => s.mean_yaw_deg,
        Metric::FinalV1 => s.final_v1,
        Metric::RollRate => s.mean_roll_rate,
    }
}

impl Metric {
    /// The quantity's label in the table.
    pub fn label(self) -> &'static str {
        match self {
            Metric::ForwardSpeed => "-V1 (m/s)",
            Metric::YawDeg => "yaw (deg)",
            Metric::FinalV1 => "V1 final (m/s)",
            Metric::RollRate => "roll rate (rad/s)",
        }
    }
}

/// One row of the reproduction table: the paper's values and ours.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Comparison {
    /// The paper's row.
    pub row: PaperRow,
    /// The gait `row` names.
    pub gait: NamedGait,
    /// Our value of `row.metric`.
    pub ours: f64,
}

impl Comparison {
    /// Runs `gait` (the gait `row` names) on `model` for `row.duration` from
    /// the paper's launch state and takes our value of `row.metric`.
    pub fn run(model: &Model, row: PaperRow, gait: NamedGait) -> Result<Self> {
        debug_assert_eq!(row.gait, gait.name, "the row's gait");
        let s = run::run_gait(model, &gait, row.duration, |_, _, _, _, _| {})?;
        Ok(Self {
            row,
            gait,
            ours: metric_value(row.metric, &s),
        })
    }

    /// `(ours - S-M) / |S-M|`, or `/ |V_init|` for the stopping gait as in
    /// the paper's Table 6, in percent.
    pub fn diff_percent(&self) -> f64 {
        let scale = match self.row.metric {
            Metric::FinalV1 => self.gait.v_init.abs(),
            _ => self.row.sm.abs(),
        };
        100.0 * (self.ours - self.row.sm) / scale
    }

    /// The averaging window of our value, in words.
    pub fn window(&self) -> String {
        let r = &self.row;
        match r.metric {
            Metric::ForwardSpeed => format!(
                "-V1(0) mean over last 5 periods ({:.1}-{:.0} s)",
                r.duration - 5.0 * run::gait_period(&self.gait),
                r.duration
            ),
            Metric::YawDeg => format!("yaw mean over {:.0}-{:.0} s", r.duration - 5.0, r.duration),
            Metric::FinalV1 => format!("V1(0) at t = {:.0} s", r.duration),
            Metric::RollRate => format!("Omega1(0) mean over 0-{:.0} s", r.duration),
        }
    }
}

/// The reproduction table: the discretization and one [`Comparison`] per
/// row. Its [`Display`](fmt::Display) is the text `anguilla swim --paper`
/// prints (lines separated by `\n`, no final newline).
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// Space intervals of the model the rows ran on.
    pub intervals: usize,
    /// Time step (s) of that model.
    pub dt: f64,
    /// The rows, in the order given.
    pub rows: Vec<Comparison>,
}

impl Table {
    /// The table of `rows`, which ran on `model`.
    pub fn new(model: &Model, rows: Vec<Comparison>) -> Self {
        Self {
            intervals: model.intervals(),
            dt: model.dt(),
            rows,
        }
    }
}

impl fmt::Display for Table {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "Paper (Boyer et al. 2008, Tables 2, 4, 6, section 7.5) vs ours: {} intervals, dt = {} s, RK4 in space and time",
            self.intervals, self.dt
        )?;
        write!(
            f,
            "\ndifference = (ours - S-M) / |S-M|, for STOP / |V_init| (the paper's Table 6 ratio)"
        )?;
        write!(
            f,
            "\n{:<7}{:<18}{:>10}{:>10}{:>10}{:>10}  averaging window",
            "gait", "quantity", "N-S", "S-M", "ours", "vs S-M"
        )?;
        for c in &self.rows {
            let r = &c.row;
            write!(f, "\n{:<7}{:<18}", r.gait, r.metric.label())?;
            match r.ns {
                Some(v) => write!(f, "{v:>10.3}")?,
                None => write!(f, "{:>10}", "-")?,
            }
            write!(
                f,
                "{:>10.3}{:>10.3}{:>9.1}%  {}",
                r.sm,
                c.ours,
                c.diff_percent(),
                c.window()
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gait;

    #[test]
    fn every_row_names_a_gait_of_the_paper() {
        for r in PAPER_ROWS {
            assert!(gait::named_gait(r.gait).is_some(), "{}", r.gait);
        }
    }

    #[test]
    fn stop_is_compared_to_v_init_and_the_others_to_s_m() {
        let c = |gait: &str, above_sm: f64| {
            let row = *PAPER_ROWS.iter().find(|r| r.gait == gait).unwrap();
            Comparison {
                row,
                gait: gait::named_gait(gait).unwrap(),
                ours: row.sm + above_sm,
            }
        };
        // STOP: 0.1 m/s above S-M is 10 / |V_init| percent of the launch speed
        let stop = c("STOP", 0.1);
        let d = stop.diff_percent();
        assert!((d - 10.0 / stop.gait.v_init.abs()).abs() < 1e-9, "{d}");
        // F1: 10 % of |S-M| above S-M
        let f1 = c("F1", 0.0);
        let d = c("F1", 0.1 * f1.row.sm.abs()).diff_percent();
        assert!((d - 10.0).abs() < 1e-9, "{d}");
    }
}
