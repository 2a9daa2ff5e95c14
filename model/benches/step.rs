//! Speed of the model: one 1 kHz control step (12 joints, forward + inverse
//! dynamics) and one simulated second of F1 at the converged discretization.
//! Run with `cargo bench -p anguilla-model`.
//!
//! Each case is warmed up, then timed in batches of about 0.1 s for
//! `ANGUILLA_BENCH_SECONDS` (default 2 s under `cargo bench`, a short run
//! otherwise); it prints the median and the fastest batch per iteration.
//! The median is the figure; the fastest says how much the machine's
//! neighbours took.

use anguilla_model::*;
use std::hint::black_box;
use std::time::{Duration, Instant};

/// Times `f` in batches for `total`, after a warm-up, and prints one line:
/// median and fastest time per call.
fn bench(name: &str, total: Duration, mut f: impl FnMut()) {
    // Warm-up, and the batch size that takes about 0.1 s.
    let t0 = Instant::now();
    let mut calls = 0u64;
    while t0.elapsed() < Duration::from_millis(200) {
        f();
        calls += 1;
    }
    let per_call = t0.elapsed().as_secs_f64() / calls as f64;
    let batch = ((0.1 / per_call).ceil() as u64).max(1);
    let mut per_iter = Vec::new();
    let start = Instant::now();
    while start.elapsed() < total || per_iter.len() < 3 {
        let t = Instant::now();
        for _ in 0..batch {
            f();
        }
        per_iter.push(t.elapsed().as_secs_f64() / batch as f64);
    }
    per_iter.sort_by(f64::total_cmp);
    let median = per_iter[per_iter.len() / 2];
    println!(
        "{name}: median {:.2} µs, fastest {:.2} µs ({} batches of {batch})",
        median * 1e6,
        per_iter[0] * 1e6,
        per_iter.len()
    );
}

fn control_step(total: Duration) {
    for (nodes, integrator) in [
        (52, Integrator::Midpoint),
        (52, Integrator::SemiImplicitEuler),
        (26, Integrator::Midpoint),
    ] {
        let model = Model::new(ModelConfig {
            nodes,
            dt: 0.001,
            joints: 12,
            integrator,
            ..ModelConfig::default()
        })
        .expect("the model's configuration");
        let mut ws = Workspace::new(&model);
        let mut gait =
            ParametricGait::from_rest(GaitParams::default(), 0.2).expect("the default gait");
        let mut head = HeadState::launch(0.0);
        for _ in 0..2000 {
            step(&model, &mut ws, &mut gait, &mut head).expect("a step");
        }
        bench(
            &format!(
                "control_step_dt1ms_12joints_{}intervals_{integrator:?}",
                model.intervals()
            ),
            total,
            || {
                let r = step(&model, &mut ws, &mut gait, black_box(&mut head)).expect("a step");
                black_box((r, ws.joints()[6]));
            },
        );
    }
}

fn simulated_second(total: Duration) {
    let g = gait::named_gait("F1").expect("F1");
    for (nodes, dt) in [(24, 0.04), (24, 0.02), (48, 0.02)] {
        let model = Model::new(ModelConfig {
            nodes,
            dt,
            joints: 0,
            ..ModelConfig::default()
        })
        .expect("the model's configuration");
        let mut ws = Workspace::new(&model);
        let mut src = LawSource::new(g.law);
        let mut head = HeadState::launch(0.0);
        let steps = (1.0 / dt).round() as usize;
        bench(
            &format!(
                "f1_one_simulated_second_{}intervals_dt{dt}",
                model.intervals()
            ),
            total,
            || {
                for _ in 0..steps {
                    step(&model, &mut ws, &mut src, &mut head).expect("a step");
                }
                black_box(head.velocity);
            },
        );
    }
}

fn main() {
    // `cargo bench` passes --bench; `cargo test --benches` does not: a
    // short run then.
    let full = std::env::args().any(|a| a == "--bench");
    let seconds: f64 = std::env::var("ANGUILLA_BENCH_SECONDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(if full { 2.0 } else { 0.3 });
    let total = Duration::from_secs_f64(seconds);
    control_step(total);
    simulated_second(total);
}
