//! `anguilla calibrate`'s figures on the simulated robot (issue 30,
//! docs/calibration.md): recovery, prediction on held-out gaits, a body
//! of another drag law, and what a fit costs. Prints text; nothing is
//! asserted (`tests/calibrate.rs` asserts).
//!
//! `cargo bench -p anguilla-daemon --bench calibration` (about 5 min on
//! the project's 2-vCPU machine). `ANGUILLA_CAL_SEEDS=1` runs one body,
//! `ANGUILLA_CAL_FIRST_SEED=4` bodies from seed 4 on;
//! `ANGUILLA_CAL_MONITOR=0` leaves out the ten-minute swims of 3.
//! `ANGUILLA_CAL_DT=S` replays at a step of `S` seconds instead of the
//! fit's 5 ms, `ANGUILLA_CAL_TICK=S` records with the simulated robot's
//! physics at `S` seconds instead of its 2 ms (how far the figures move
//! with either: docs/calibration.md, "What is left").
//!
//! Each session is recorded as `anguilla run` records one (`session.mcap`:
//! every tenth state snapshot, `/sim/truth` at 20 Hz), by the controller
//! and the simulated robot in lockstep (`anguilla_testkit::lockstep`),
//! with the default configuration, a head sensor and **CAN FD** (`[bus] fd
//! = true`: 12-bit velocity and torque in the feedback; classic CAN's
//! 8 bits are too coarse for a fit, docs/calibration.md).
//!
//! 1. **Recovery.** For each of three seeds, a body whose six
//!    coefficients (`c_p`, `k`, `c1`, `c2`, `c3`, the skin friction's
//!    factor) are each the paper's times a factor drawn in 0.6..1.4 (`c1`,
//!    0 in the paper, becomes 0.1 times the factor); the calibration swim
//!    (`anguilla ctl calibrate-swim`'s legs) fitted for all six: every
//!    estimate against the body, and whether the fit calls it identified.
//! 2. **Prediction.** Three gaits not in the calibration swim, recorded
//!    on the same body: the model's mean forward speed error and joint
//!    torque RMS error with the paper's coefficients and with the fitted
//!    ones.
//! 3. **The residual monitor.** Ten minutes of swimming with a gait
//!    change every 10 s (0.6 to 1.6 Hz, turns both ways, no snag) on the
//!    first seed's body, the daemon's `[model]` holding the fitted
//!    coefficients; and on the paper's body with the paper's: the alarms
//!    raised and the largest normalised residual.
//! 4. **Structural mismatch.** The same on a body whose axial drag is
//!    quadratic (`drag = "quadratic"`), which no coefficient of the model
//!    matches: the fit's residual and the held-out errors.

use std::path::Path;
use std::time::Instant;

use anguilla_daemon::calibration::{LEGS, Leg};
use anguilla_daemon::config::Config;
use anguilla_daemon::mcap_log::swim;
use anguilla_ipc::vocabulary::{Command, SwimParams};
use anguilla_model::identify::{self, Coefficient, Evaluation, Fit, FitOptions, Swim};
use anguilla_model::{AxialDrag, Body};
use anguilla_testkit::lockstep::{self, Rig};

/// The held-out gaits: none of the calibration swim's.
const HELD_OUT: [Leg; 3] = [
    Leg {
        what: "forward, 0.9 Hz, amplitude 0.7",
        seconds: 15.0,
        gait: SwimParams {
            amplitude: 0.7,
            frequency: 0.9,
            turn: 0.0,
            pitch: 0.0,
        },
    },
    Leg {
        what: "forward, 1.8 Hz, amplitude 0.6",
        seconds: 15.0,
        gait: SwimParams {
            amplitude: 0.6,
            frequency: 1.8,
            turn: 0.0,
            pitch: 0.0,
        },
    },
    Leg {
        what: "turning 0.8 and climbing 0.4 per metre, 1.3 Hz",
        seconds: 15.0,
        gait: SwimParams {
            amplitude: 0.9,
            frequency: 1.3,
            turn: 0.8,
            pitch: -0.4,
        },
    },
];

fn config() -> Config {
    let mut cfg = lockstep::config();
    cfg.bus.fd = true;
    cfg.validate().expect("valid configuration");
    cfg
}

/// splitmix64: the seeds' factors, the same on every machine.
fn factors(seed: u64) -> [f64; 6] {
    let mut x = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    std::array::from_fn(|_| {
        x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = x;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        0.6 + 0.8 * (z >> 11) as f64 / (1u64 << 53) as f64
    })
}

/// A positive number of seconds from the environment variable `name`.
fn seconds(name: &str) -> Option<f64> {
    let v = std::env::var(name).ok()?;
    match v.parse::<f64>() {
        Ok(s) if s > 0.0 && s.is_finite() => Some(s),
        _ => panic!("{name}={v}: expected a positive number of seconds"),
    }
}

fn record(cfg: &Config, seed: u64, body: &Body, legs: &[Leg], dir: &Path) -> Swim {
    std::fs::create_dir_all(dir).expect("session directory");
    let path = dir.join("session.mcap");
    let body = body.clone();
    let tick = seconds("ANGUILLA_CAL_TICK");
    let mut rig = Rig::with_robot(
        cfg,
        seed,
        [0.0; 3],
        |_| {},
        move |r| {
            r.body = body;
            if let Some(t) = tick {
                r.tick = std::time::Duration::from_secs_f64(t);
            }
        },
    );
    rig.record_legs(cfg, legs, &path).expect("recorded");
    let read = swim::read(dir, None).expect("readable session");
    std::fs::remove_dir_all(dir).expect("removed");
    read.swim
}

fn held_out(cfg: &Config, seed: u64, body: &Body, dir: &Path) -> Vec<Swim> {
    HELD_OUT
        .iter()
        .enumerate()
        .map(|(i, leg)| {
            let mut s = record(
                cfg,
                seed + 100 + i as u64,
                body,
                std::slice::from_ref(leg),
                &dir.join(format!("held-out-{i}")),
            );
            s.name = leg.what.to_string();
            s
        })
        .collect()
}

/// Ten minutes of gait changes, no snag: (alarm onsets, largest |residual|).
fn ten_minutes(cfg: &Config, body: &Body) -> (usize, f32) {
    let mut rig = Rig::with_body(cfg, 11, body.clone());
    rig.swim(1.0);
    let (mut onsets, mut worst, mut was) = (0usize, 0.0f32, false);
    for i in 0..60 {
        rig.ok(Command::Swim(SwimParams {
            amplitude: 1.0,
            frequency: 0.6 + 0.1 * ((i * 7) % 11) as f64,
            turn: [0.0, 1.0, -1.5, 0.5][i % 4],
            pitch: 0.0,
        }));
        rig.run(10.0, |r| {
            let s = r.state();
            let n = s.joint_count as usize;
            for j in &s.joints[..n] {
                worst = worst
                    .max(j.pitch_torque_residual.abs())
                    .max(j.yaw_torque_residual.abs());
            }
            let now = s.residual_alarms().next().is_some();
            if now && !was {
                onsets += 1;
            }
            was = now;
        });
    }
    (onsets, worst)
}

fn print_fit(fit: &Fit, body: &Body, took: f64) {
    println!(
        "  fit: {took:.1} s, {} replays, {} iterations",
        fit.simulations, fit.iterations
    );
    for e in &fit.estimates {
        let truth = e.coefficient.get(body);
        println!(
            "  {:>8}: prior {:.4}  estimate {:.4} ± {:.4}  body {:.4}  error {}  {}",
            e.coefficient.name(),
            e.prior,
            e.estimate,
            e.std_error,
            truth,
            if truth == 0.0 {
                format!("{:+.4} (absolute)", e.estimate)
            } else {
                format!("{:+6.1} %", 100.0 * (e.estimate / truth - 1.0))
            },
            match (e.identified, e.fitted) {
                (true, _) => "identified",
                (false, true) => "fitted, not identified",
                (false, false) => "not identified, left at the prior",
            }
        );
    }
    let r = |ev: &Evaluation| {
        format!(
            "speed {:.4} m/s, turn {:.4} rad/s, depth rate {:.4} m/s, sway {:.4} rad, torque {:.4} N·m",
            ev.rms[0], ev.rms[1], ev.rms[2], ev.rms[3], ev.rms[4]
        )
    };
    println!("  residual, paper's coefficients: {}", r(&fit.before));
    println!("  residual, every estimate:       {}", r(&fit.estimated));
    println!("  residual, the fitted body:      {}", r(&fit.after));
}

/// Prints the held-out errors; returns the largest speed error with the
/// fitted coefficients and the torque RMS ratios to the paper's: the
/// fitted coefficients' and the body's own (the least any fit could
/// reach). Each body's model carries the drives' inertia, friction and lag it
/// was fitted with on the calibration swim (`cal`), as `anguilla
/// calibrate --holdout` does, or refits them on each held-out gait
/// (`refit`).
fn print_prediction(bodies: [&Body; 3], cal: &[Swim], hs: &[Swim], refit: bool) -> (f64, f64, f64) {
    let evs: Vec<Evaluation> = bodies
        .iter()
        .map(|b| {
            let actuator = if refit {
                None
            } else {
                let ev = identify::compare(&[b], cal, &fit_options()).expect("replayed");
                Some(ev[0].actuator)
            };
            let opts = FitOptions {
                actuator,
                ..fit_options()
            };
            identify::compare(&[b], hs, &opts)
                .expect("replayed")
                .remove(0)
        })
        .collect();
    let (p, f, b) = (&evs[0], &evs[1], &evs[2]);
    println!(
        "  the drives' inertia, friction and lag {}",
        if refit {
            "refitted on each held-out gait".to_string()
        } else {
            format!(
                "from the calibration swim: paper's {:.4}, {:.4}, {:.1} ms; fitted {:.4}, {:.4}, {:.1} ms; body's own {:.4}, {:.4}, {:.1} ms",
                p.actuator[0],
                p.actuator[1],
                1e3 * p.actuator[2],
                f.actuator[0],
                f.actuator[1],
                1e3 * f.actuator[2],
                b.actuator[0],
                b.actuator[1],
                1e3 * b.actuator[2]
            )
        }
    );
    let mut worst: f64 = 0.0;
    for ((x, y), z) in p.swims.iter().zip(&f.swims).zip(&b.swims) {
        worst = worst.max(y.speed_error().abs());
        println!(
            "  {:<48} speed {:.3} m/s; model: paper's {:+6.1} %, fitted {:+6.1} %, body's own {:+6.1} %; torque RMS {:.4} -> {:.4} N·m (body's own {:.4})",
            x.name,
            x.speed,
            100.0 * x.speed_error(),
            100.0 * y.speed_error(),
            100.0 * z.speed_error(),
            x.torque_rms,
            y.torque_rms,
            z.torque_rms
        );
    }
    (worst, f.rms[4] / p.rms[4], b.rms[4] / p.rms[4])
}

fn main() {
    let cfg = config();
    let prior = cfg.model.body();
    let seeds: u64 = std::env::var("ANGUILLA_CAL_SEEDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(3);
    // ANGUILLA_CAL_FIRST_SEED=K: seeds K.. instead of 1.. (other bodies
    // than the ones the docs quote)
    let first: u64 = std::env::var("ANGUILLA_CAL_FIRST_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1);
    // ANGUILLA_CAL_MONITOR=0 leaves out the residual monitor's two
    // ten-minute swims (said in the output)
    let monitor = std::env::var("ANGUILLA_CAL_MONITOR").map_or(true, |v| v != "0");
    if !monitor {
        println!("residual monitor left out (ANGUILLA_CAL_MONITOR=0)");
    }
    let dir = std::env::temp_dir().join(format!("anguilla-bench-cal-{}", std::process::id()));
    let opts = FitOptions {
        fit: Coefficient::ALL.to_vec(),
        ..fit_options()
    };
    if let Some(t) = seconds("ANGUILLA_CAL_TICK") {
        println!(
            "the simulated robot's physics step: {:.2} ms (ANGUILLA_CAL_TICK)",
            1e3 * t
        );
    }
    println!("the replay's step: {:.2} ms", 1e3 * opts.dt);
    println!(
        "calibration: lockstep, CAN FD, calibration swim {:.0} s, held-out gaits 3 × 15 s; published band: ≈1 % at the fitted gait, 10-16 % off-gait (Kelasidi et al. 2016)",
        lockstep_duration()
    );
    let mut summary = Vec::new();
    for seed in first..first + seeds {
        let f = factors(seed);
        let mut body = prior.clone();
        for (c, k) in Coefficient::ALL.into_iter().zip(f) {
            let base = match c.get(&prior) {
                0.0 => 0.1,
                v => v,
            };
            c.set(&mut body, base * k);
        }
        println!(
            "\nrecovery, seed {seed}: factors {}",
            f.map(|k| format!("{k:.2}")).join(", ")
        );
        let swim = record(&cfg, seed, &body, &LEGS, &dir.join("cal"));
        let start = Instant::now();
        let fit = identify::fit(&prior, std::slice::from_ref(&swim), &opts).expect("fitted");
        let took = start.elapsed().as_secs_f64();
        print_fit(&fit, &body, took);
        let all = fit.body.clone();
        println!("  prediction on held-out gaits (the fitted body):");
        let hs = held_out(&cfg, seed, &body, &dir);
        let cal = std::slice::from_ref(&swim);
        print_prediction([&prior, &all, &body], cal, &hs, true);
        let (worst, torque, own) = print_prediction([&prior, &all, &body], cal, &hs, false);
        let bad: Vec<String> = fit
            .estimates
            .iter()
            .filter(|e| e.identified && (e.estimate / e.coefficient.get(&body) - 1.0).abs() > 0.05)
            .map(|e| e.coefficient.name().to_string())
            .collect();
        if seed == 1 && monitor {
            let mut fitted = cfg.clone();
            let m = &mut fitted.model;
            [m.c_p, m.k, m.c1, m.c2, m.c3, m.friction] = Coefficient::ALL.map(|c| c.get(&all));
            fitted.validate().expect("fitted coefficients in range");
            let (a, w) = ten_minutes(&fitted, &body);
            println!(
                "  residual monitor, 10 min of gait changes, no snag, fitted coefficients: {a} alarms, largest |residual| {w:.2}"
            );
            let (a, w) = ten_minutes(&cfg, &prior);
            println!(
                "  residual monitor, 10 min of gait changes, no snag, paper's body and coefficients: {a} alarms, largest |residual| {w:.2}"
            );
        }
        summary.push((
            seed,
            fit.estimates.iter().filter(|e| e.identified).count(),
            bad,
            worst,
            torque,
            own,
            took,
        ));
    }
    println!(
        "\nstructural mismatch: quadratic axial drag (c = 0.004), the paper's other coefficients"
    );
    let mut quad = prior.clone();
    quad.axial = AxialDrag::Quadratic { c: 0.004 };
    let swim = record(&cfg, 7, &quad, &LEGS, &dir.join("quad"));
    let start = Instant::now();
    let fit = identify::fit(&prior, std::slice::from_ref(&swim), &opts).expect("fitted");
    print_fit(&fit, &quad, start.elapsed().as_secs_f64());
    let all = fit.body.clone();
    println!("  prediction on held-out gaits (the fitted body):");
    let hs = held_out(&cfg, 7, &quad, &dir);
    let (worst, torque, own) = print_prediction(
        [&prior, &all, &quad],
        std::slice::from_ref(&swim),
        &hs,
        false,
    );
    println!(
        "  worst held-out speed error {:.1} %, torque RMS fitted/paper {:.2} (the body's own/paper {:.2})",
        100.0 * worst,
        torque,
        own
    );
    println!("\nsummary:");
    for (seed, n, bad, worst, torque, own, took) in summary {
        println!(
            "  seed {seed}: {n} of 6 identified, {} outside 5 %{}; held-out speed error at most {:.1} %; torque RMS fitted/paper {:.2} (the body's own/paper {own:.2}); fit {took:.1} s",
            bad.len(),
            if bad.is_empty() {
                String::new()
            } else {
                format!(" ({})", bad.join(", "))
            },
            100.0 * worst,
            torque
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The fit's options, the replay's step from `ANGUILLA_CAL_DT` if set.
fn fit_options() -> FitOptions {
    let d = FitOptions::default();
    FitOptions {
        dt: seconds("ANGUILLA_CAL_DT").unwrap_or(d.dt),
        ..d
    }
}

fn lockstep_duration() -> f64 {
    anguilla_daemon::calibration::duration()
}
