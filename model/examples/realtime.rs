//! The model's real-time factor on F1 at the default discretization
//! (52 intervals, dt 0.025 s, RK4): simulated seconds per wall second, and
//! the cost per node per step. `cargo run --release -p anguilla-model
//! --example realtime [SIMULATED_SECONDS]` prints one JSON line; the
//! benchmark check (`scripts/bench-check`) reads it.
use anguilla_model::*;

fn main() {
    let seconds: f64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(200.0);
    let model = Model::new(ModelConfig::default()).expect("default model");
    let g = gait::named_gait("F1").expect("F1");
    // Best of three runs: the figure is the machine's, not its neighbours'.
    let mut best = f64::INFINITY;
    let mut speed = 0.0;
    for _ in 0..3 {
        let t0 = std::time::Instant::now();
        let s = run::run_gait(&model, &g, seconds, |_, _, _, _, _| {}).expect("F1 runs");
        best = best.min(t0.elapsed().as_secs_f64());
        speed = s.mean_forward_speed;
    }
    let steps = (seconds / model.dt()).round();
    let nodes = (model.intervals() + 1) as f64;
    println!(
        "{{\"bench\":\"model_realtime\",\"gait\":\"F1\",\"intervals\":{},\"dt\":{},\"simulated_s\":{seconds},\
\"wall_s\":{best:.4},\"realtime_factor\":{:.1},\"us_per_step\":{:.3},\"ns_per_node_step\":{:.1},\
\"mean_forward_speed\":{speed:.6},\"goal_realtime_factor\":1000}}",
        model.intervals(),
        model.dt(),
        seconds / best,
        best / steps * 1e6,
        best / steps / nodes * 1e9,
    );
}
