//! F1 mean forward speed (last 5 periods of 30 s) against space intervals and
//! time step: `cargo run --release -p anguilla-model --example convergence`.
use anguilla_model::*;
fn speed(nodes: usize, dt: f64) -> (f64, usize, f64) {
    let m = Model::new(ModelConfig {
        nodes,
        dt,
        joints: 0,
        ..Default::default()
    })
    .unwrap();
    let g = gait::named_gait("F1").unwrap();
    let t0 = std::time::Instant::now();
    let s = run::run_gait(&m, &g, 30.0, |_, _, _, _, _| {}).unwrap();
    (
        s.mean_forward_speed,
        m.intervals(),
        30.0 / t0.elapsed().as_secs_f64(),
    )
}
fn main() {
    let (reference, _, _) = speed(384, 0.01);
    println!("reference (384 intervals, dt 0.01 s): {reference:.6} m/s");
    for n in [12, 24, 48, 96, 192] {
        let (v, ni, rt) = speed(n, 0.02);
        println!(
            "intervals {ni:4} dt 0.02: {v:.6} m/s  error {:+.3} %  ({rt:.0} x real time)",
            100.0 * (v - reference) / reference
        );
    }
    for dt in [0.05, 0.04, 0.02, 0.01, 0.005] {
        let (v, ni, rt) = speed(24, dt);
        println!(
            "intervals {ni:4} dt {dt}: {v:.6} m/s  error {:+.3} %  ({rt:.0} x real time)",
            100.0 * (v - reference) / reference
        );
    }
}
