//! Checks of a recorded swim before it is fitted (`anguilla calibrate`,
//! docs/calibration.md "Checks before the fit"): a recording that cannot
//! identify anything, or that holds something the model cannot explain,
//! is named with its time and refused, not fitted into the coefficients.
//!
//! Each check is a pure function of the [`Swim`]; times are seconds from
//! the swim's first joint sample.

use super::Swim;

/// The smallest span (rad) one axis's angle must cover within a
/// [`WINDOW`] for that window to count as swimming: ten times the
/// encoder's quantum (1.5 mrad), a twentieth of the smallest gait's
/// amplitude at the head.
pub const MOVING: f64 = 0.05;

/// The window (s) over which the joints' motion is judged.
pub const WINDOW: f64 = 1.0;

/// The least swimming (s, joints moving, over every fitted session) a fit
/// takes: on a 10 s swim the nose's drag came out ±250 % (issue 46), and
/// the calibration swim (`ctl calibrate-swim`) swims 50 s of its 59.
pub const MIN_SWIMMING: f64 = 30.0;

/// The longest interval between two joint samples (s) a fit takes: the
/// replay joins the samples by a cubic curve, and the speed, turn and
/// depth rate are compared over [`WINDOW`]s; half of one without a sample
/// is not a recording of the motion.
pub const MAX_GAP: f64 = 0.5;

/// How many times its own typical spread a torque sample must stand from
/// its neighbours' median to be an outlier (the largest of a healthy swim
/// is about 1.5 times its 99th percentile).
pub const OUTLIER_FACTOR: f64 = 4.0;

/// Of a torque limit, the fraction at which a measured torque counts as
/// saturated.
pub const SATURATED: f64 = 0.98;

/// One thing a check found.
#[derive(Debug, Clone, PartialEq)]
pub struct Finding {
    /// From when (s from the swim's first joint sample).
    pub from: f64,
    /// Until when (s).
    pub until: f64,
    /// What, in words.
    pub what: String,
    /// Whether it stops the fit (else a warning).
    pub refuse: bool,
}

impl std::fmt::Display for Finding {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.until > self.from {
            write!(f, "{:.2}–{:.2} s: {}", self.from, self.until, self.what)
        } else {
            write!(f, "{:.2} s: {}", self.from, self.what)
        }
    }
}

/// The axis's name in reports: joints counted from 1, head first.
pub fn axis_name(j: usize, ax: usize) -> String {
    format!("joint {} {}", j + 1, ["pitch", "yaw"][ax])
}

/// The seconds of `swim` in which the joints moved (some axis's angle
/// spanning [`MOVING`] within a [`WINDOW`]), and the largest span any axis
/// covered in any window (rad) with its axis.
pub fn swimming(swim: &Swim) -> (f64, f64, (usize, usize)) {
    let n = swim.joints();
    let Some(t0) = swim.samples.first().map(|s| s.t) else {
        return (0.0, 0.0, (0, 0));
    };
    let mut moving = 0.0;
    let mut largest = (0.0f64, (0, 0));
    let mut start = 0usize;
    while start < swim.samples.len() {
        let w0 = t0 + WINDOW * ((swim.samples[start].t - t0) / WINDOW).floor();
        let end = swim.samples[start..]
            .iter()
            .position(|s| s.t >= w0 + WINDOW)
            .map_or(swim.samples.len(), |p| start + p);
        let win = &swim.samples[start..end];
        let mut moved = false;
        for j in 0..n {
            for ax in 0..2 {
                let (lo, hi) = win.iter().fold((f64::MAX, f64::MIN), |(lo, hi), s| {
                    (lo.min(s.angle[j][ax]), hi.max(s.angle[j][ax]))
                });
                let span = hi - lo;
                if span > largest.0 {
                    largest = (span, (j, ax));
                }
                moved |= span >= MOVING;
            }
        }
        if moved {
            // the window's covered time, to the next sample
            let last = swim.samples.get(end).map_or(win[win.len() - 1].t, |s| s.t);
            moving += (last - win[0].t).min(WINDOW);
        }
        start = end;
    }
    (moving, largest.0, largest.1)
}

/// Checks `swim` before a fit: whether it swims at all (`None`: it does
/// not, with the reason; a session with no swim is no calibration), then
/// gaps between samples, torque outliers, and torques at `torque_limit`
/// (N·m, the drives' limit: a saturated torque is the drive's, not the
/// water's). Returns the seconds swum and what was found.
pub fn check(swim: &Swim, torque_limit: f64) -> Result<(f64, Vec<Finding>), String> {
    let (moving, largest, (j, ax)) = swimming(swim);
    if moving <= 0.0 {
        return Err(format!(
            "{}: no swim in it: over its {:.1} s the joints never moved {MOVING} rad within \
             {WINDOW} s (the most: {}, {largest:.3} rad). Record the swim while the robot swims: \
             `anguilla ctl enable`, then `anguilla ctl calibrate-swim` (docs/calibration.md)",
            swim.name,
            swim.duration(),
            axis_name(j, ax)
        ));
    }
    let mut found = gaps(swim);
    found.extend(torques(swim, torque_limit));
    found.sort_by(|a, b| a.from.total_cmp(&b.from));
    Ok((moving, found))
}

/// Intervals between joint samples beyond three times the usual one
/// (missed control periods, a stalled recorder): named, and refused
/// beyond [`MAX_GAP`].
pub fn gaps(swim: &Swim) -> Vec<Finding> {
    let s = &swim.samples;
    if s.len() < 3 {
        return Vec::new();
    }
    let t0 = s[0].t;
    let mut dts: Vec<f64> = s.windows(2).map(|w| w[1].t - w[0].t).collect();
    dts.sort_by(f64::total_cmp);
    let usual = dts[dts.len() / 2];
    s.windows(2)
        .filter(|w| w[1].t - w[0].t > 3.0 * usual)
        .map(|w| {
            let dt = w[1].t - w[0].t;
            let refuse = dt > MAX_GAP;
            Finding {
                from: w[0].t - t0,
                until: w[1].t - t0,
                what: format!(
                    "no joint sample for {dt:.3} s (about {} missed of one every {:.3} s){}",
                    (dt / usual).round() as i64 - 1,
                    usual,
                    if refuse {
                        format!(": longer than the {MAX_GAP} s a fit bridges")
                    } else {
                        String::new()
                    }
                ),
                refuse,
            }
        })
        .collect()
}

/// Torque samples at the drive's limit (saturated) or far from their
/// neighbours (an outlier: [`OUTLIER_FACTOR`] times the axis's own 99th
/// percentile of the distance from the median of the half-second on each
/// side), each run of them on one axis one refused finding.
pub fn torques(swim: &Swim, torque_limit: f64) -> Vec<Finding> {
    let s = &swim.samples;
    let n = swim.joints();
    let Some(t0) = s.first().map(|x| x.t) else {
        return Vec::new();
    };
    let mut found = Vec::new();
    let half = 0.5;
    for j in 0..n {
        for ax in 0..2 {
            let tau: Vec<(f64, f64)> = s
                .iter()
                .map(|x| (x.t, x.torque[j][ax]))
                .filter(|(_, v)| v.is_finite())
                .collect();
            if tau.len() < 10 {
                continue;
            }
            // distance from the running median of ±half a second
            let mut dev = Vec::with_capacity(tau.len());
            let (mut lo, mut hi) = (0usize, 0usize);
            let mut buf = Vec::new();
            for &(t, v) in &tau {
                while tau[lo].0 < t - half {
                    lo += 1;
                }
                while hi < tau.len() && tau[hi].0 <= t + half {
                    hi += 1;
                }
                buf.clear();
                buf.extend(tau[lo..hi].iter().map(|p| p.1));
                buf.sort_by(f64::total_cmp);
                dev.push((v - buf[buf.len() / 2]).abs());
            }
            let mut sorted = dev.clone();
            sorted.sort_by(f64::total_cmp);
            let p99 = sorted[(sorted.len() * 99 / 100).min(sorted.len() - 1)];
            // a floor: the CAN FD torque quantum, 2.5 mN·m, ten times
            let bound = OUTLIER_FACTOR * p99.max(0.0025);
            let mut run: Option<(f64, f64, f64, bool)> = None;
            let mut flush = |run: &mut Option<(f64, f64, f64, bool)>| {
                if let Some((a, b, worst, sat)) = run.take() {
                    found.push(Finding {
                        from: a - t0,
                        until: b - t0,
                        what: if sat {
                            format!(
                                "{}: torque at the drive's limit ({worst:+.3} N·m of \
                                 ±{torque_limit} N·m): saturated, the drive's torque not the \
                                 water's",
                                axis_name(j, ax)
                            )
                        } else {
                            format!(
                                "{}: torque outlier, {worst:+.3} N·m, {:.1} times the farthest \
                                 its neighbours' spread goes ({:.4} N·m)",
                                axis_name(j, ax),
                                worst.abs() / p99.max(1e-9),
                                p99
                            )
                        },
                        refuse: true,
                    });
                }
            };
            for (&(t, v), &d) in tau.iter().zip(&dev) {
                let sat = v.abs() >= SATURATED * torque_limit;
                if sat || d > bound {
                    let r = run.get_or_insert((t, t, v, sat));
                    r.1 = t;
                    if v.abs() > r.2.abs() {
                        r.2 = v;
                    }
                    r.3 |= sat;
                } else if run.as_ref().is_some_and(|r| t - r.1 > half) {
                    flush(&mut run);
                }
            }
            flush(&mut run);
        }
    }
    found
}

/// The mean torque error over a window (N·m) beyond which, and beyond
/// [`UNEXPLAINED_FACTOR`] times the swim's typical window, one axis's
/// torque is not the water's: after a fit the simulated robot's windows
/// are within about 0.002 N·m; a snag of 0.5 N·m (`joint 7 yaw snag 0.5`)
/// stands out hundreds of times.
pub const UNEXPLAINED_FLOOR: f64 = 0.02;

/// See [`UNEXPLAINED_FLOOR`].
pub const UNEXPLAINED_FACTOR: f64 = 8.0;

/// After a fit (or on held-out sessions), each swim's axis whose torque
/// error, averaged over [`super::replay::BIAS_WINDOW`], stays beyond
/// [`UNEXPLAINED_FLOOR`] and [`UNEXPLAINED_FACTOR`] times the typical: a
/// torque the fitted model does not explain (a snag, a tether, a failing
/// drive), which pulls the coefficients. Each with its swim's name.
pub fn unexplained_torque(ev: &super::Evaluation) -> Vec<(String, Finding)> {
    ev.swims
        .iter()
        .filter_map(|s| {
            let b = s.worst_bias?;
            (b.mean.abs() > UNEXPLAINED_FLOOR.max(UNEXPLAINED_FACTOR * b.typical)).then(|| {
                (
                    s.name.clone(),
                    Finding {
                        from: b.from,
                        until: b.until,
                        what: format!(
                            "{}: a torque the fitted model does not explain, {:+.3} N·m on \
                             average over {} s (the swim's typical {:.4} N·m): a snag, a \
                             tether, a failing drive? It pulls the coefficients",
                            axis_name(b.joint, b.axis),
                            b.mean,
                            super::replay::BIAS_WINDOW,
                            b.typical
                        ),
                        refuse: true,
                    },
                )
            })
        })
        .collect()
}

/// Why the drives' terms a fit found (`[inertia, friction, lag]`) are
/// not physical, if they are not: a negative inertia or friction (a drive
/// that pushes with its motion) is something in the swims the model
/// lacks, not the drive.
pub fn impossible_drive(actuator: [f64; super::replay::DRIVE]) -> Option<String> {
    let [j, b, lag] = actuator;
    let bad = [
        (j < 0.0).then(|| format!("an inertia of {j:.5} kg·m²")),
        (b < 0.0).then(|| format!("a friction of {b:.5} N·m·s/rad")),
        (lag < 0.0).then(|| format!("a torque lag of {:.2} ms", 1e3 * lag)),
    ];
    let bad: Vec<String> = bad.into_iter().flatten().collect();
    (!bad.is_empty()).then(|| {
        format!(
            "the drives' own terms came out as {}: below zero no drive is, so the torques hold \
             something the model lacks (a snag, a tether, a torque sensor's offset)",
            bad.join(" and ")
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::JointSample;

    /// 40 s of two joints at 50 Hz swimming at 1 Hz (0.3 rad, torques
    /// ±0.1 N·m), idle before `idle_until`.
    fn swim(idle_until: f64) -> Swim {
        let samples = (0..2000)
            .map(|i| {
                let t = 100.0 + i as f64 * 0.02;
                let a = if t - 100.0 < idle_until { 0.0 } else { 0.3 };
                let ph = std::f64::consts::TAU * t;
                JointSample {
                    t,
                    angle: vec![[0.0, a * ph.sin()], [0.0, a * (ph - 1.0).sin()]],
                    rate: vec![[0.0, a * ph.cos()], [0.0, a * (ph - 1.0).cos()]],
                    torque: vec![[0.001, 0.1 * ph.cos()], [0.001, 0.1 * (ph - 1.0).cos()]],
                }
            })
            .collect();
        Swim {
            name: "s".into(),
            samples,
            ..Swim::default()
        }
    }

    #[test]
    fn a_negative_friction_is_impossible() {
        assert_eq!(impossible_drive([0.02, 0.05, 0.001]), None);
        let e = impossible_drive([0.02, -0.01, 0.0]).unwrap();
        assert!(
            e.contains("a friction of -0.01000 N·m·s/rad: below zero"),
            "{e}"
        );
    }

    #[test]
    fn a_session_with_no_swim_is_refused_and_a_swim_counted() {
        let e = check(&swim(1e9), 2.0).unwrap_err();
        assert!(e.contains("s: no swim in it: over its 40.0 s"), "{e}");
        let (moving, found) = check(&swim(10.0), 2.0).unwrap();
        assert!((29.0..=30.5).contains(&moving), "{moving}");
        assert_eq!(found, vec![]);
    }

    /// The overload glitch of issue 46: 0.1 s of one axis's torque at the
    /// limit, and 0.1 s of another's ten times its swing, each named with
    /// its time; a gap of 0.3 s named, one of 0.8 s refused.
    #[test]
    fn glitches_and_gaps_are_named_with_their_time() {
        let mut s = swim(0.0);
        for k in 1000..1005 {
            s.samples[k].torque[1][1] = 2.0;
            s.samples[k + 500].torque[0][1] = -1.0;
        }
        let (_, found) = check(&s, 2.0).unwrap();
        let text: Vec<String> = found.iter().map(ToString::to_string).collect();
        assert_eq!(found.len(), 2, "{text:?}");
        assert!(text[0].starts_with("20.00–20.08 s: joint 2 yaw: torque at the drive's limit"));
        assert!(text[1].starts_with("30.00–30.08 s: joint 1 yaw: torque outlier, -1.000 N·m"));
        assert!(found.iter().all(|f| f.refuse));
        let mut g = swim(0.0);
        g.samples.drain(500..515);
        g.samples.drain(1200..1240);
        let found = gaps(&g);
        let text: Vec<String> = found.iter().map(ToString::to_string).collect();
        assert_eq!(text.len(), 2, "{text:?}");
        assert!(text[0].starts_with("9.98–10.30 s: no joint sample for 0.320 s (about 15 missed"));
        assert!(!found[0].refuse);
        assert!(found[1].refuse && text[1].contains("longer than the 0.5 s"));
    }
}
