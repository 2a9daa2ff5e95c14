//! Quick run of every paper gait: `cargo run --release -p anguilla-model --example f1 -- NODES DT`.
use anguilla_model::*;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let nodes: usize = args.get(1).map(|s| s.parse().unwrap()).unwrap_or(26);
    let dt: f64 = args.get(2).map(|s| s.parse().unwrap()).unwrap_or(0.01);
    let model = Model::new(ModelConfig {
        nodes,
        dt,
        joints: 0,
        ..Default::default()
    })
    .unwrap();
    for r in paper::PAPER_ROWS {
        let g = gait::named_gait(r.gait).unwrap();
        let t0 = std::time::Instant::now();
        let s = run::run_gait(&model, &g, r.duration, |_, _, _, _, _| {}).unwrap();
        let v = paper::metric_value(r.metric, &s);
        println!(
            "{:6} sm {:8.3} ours {:8.4} ({:+.1}%) rt {:.0} {:?}",
            r.gait,
            r.sm,
            v,
            100.0 * (v - r.sm) / r.sm,
            r.duration / t0.elapsed().as_secs_f64(),
            s
        );
    }
}
