//! F1 mean speed and joint torque with each integrator at dt = 1 ms.
use anguilla_model::*;
fn main() {
    let g = gait::named_gait("F1").unwrap();
    for integ in [
        Integrator::Rk4,
        Integrator::Midpoint,
        Integrator::SemiImplicitEuler,
    ] {
        let m = Model::new(ModelConfig {
            dt: 0.001,
            joints: 12,
            integrator: integ,
            ..Default::default()
        })
        .unwrap();
        let t0 = std::time::Instant::now();
        let mut c3 = 0.0;
        let s = run::run_gait(&m, &g, 10.0, |_, _, _, ws, _| c3 = ws.joints()[6].c3).unwrap();
        println!(
            "{integ:?}: speed {:.6} final V1 {:.6} C3_7 {:.6} ({:.1} us/step)",
            s.last_period_forward_speed,
            s.final_v1,
            c3,
            t0.elapsed().as_secs_f64() / 1e4 * 1e6
        );
    }
}
