//! Profiling driver: `perf record target/release/examples/profile`.
use anguilla_model::*;
fn main() {
    let model = Model::new(ModelConfig {
        dt: 0.001,
        joints: 12,
        integrator: Integrator::Midpoint,
        ..Default::default()
    })
    .unwrap();
    let mut ws = Workspace::new(&model);
    let mut gait = ParametricGait::from_rest(GaitParams::default(), 0.2);
    let mut head = HeadState::launch(0.0);
    let t0 = std::time::Instant::now();
    let n = 100_000;
    for _ in 0..n {
        step(&model, &mut ws, &mut gait, &mut head).unwrap();
    }
    let el = t0.elapsed().as_secs_f64();
    println!(
        "{:.2} us per control step ({} intervals), v1 {}",
        el / n as f64 * 1e6,
        model.intervals(),
        head.v1()
    );
}
