//! Speed of the model: one 1 kHz control step (12 joints, forward + inverse
//! dynamics) and one simulated second of F1 at the converged discretization.
//! Run with `cargo bench -p anguilla-model`.

use anguilla_model::*;
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;

fn control_step(c: &mut Criterion) {
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
        .unwrap();
        let mut ws = Workspace::new(&model);
        let mut gait = ParametricGait::from_rest(GaitParams::default(), 0.2);
        let mut head = HeadState::launch(0.0);
        for _ in 0..2000 {
            step(&model, &mut ws, &mut gait, &mut head).unwrap();
        }
        c.bench_function(
            &format!(
                "control_step_dt1ms_12joints_{}intervals_{integrator:?}",
                model.intervals()
            ),
            |b| {
                b.iter(|| {
                    let r = step(&model, &mut ws, &mut gait, black_box(&mut head)).unwrap();
                    black_box((r, ws.joints()[6]))
                })
            },
        );
    }
}

fn simulated_second(c: &mut Criterion) {
    let g = gait::named_gait("F1").unwrap();
    for (nodes, dt) in [(24, 0.04), (24, 0.02), (48, 0.02)] {
        let model = Model::new(ModelConfig {
            nodes,
            dt,
            joints: 0,
            ..ModelConfig::default()
        })
        .unwrap();
        let mut ws = Workspace::new(&model);
        let mut src = LawSource::new(g.law);
        let mut head = HeadState::launch(0.0);
        let steps = (1.0 / dt).round() as usize;
        c.bench_function(
            &format!(
                "f1_one_simulated_second_{}intervals_dt{dt}",
                model.intervals()
            ),
            |b| {
                b.iter(|| {
                    for _ in 0..steps {
                        step(&model, &mut ws, &mut src, &mut head).unwrap();
                    }
                    black_box(head.velocity)
                })
            },
        );
    }
}

criterion_group!(benches, control_step, simulated_second);
criterion_main!(benches);
