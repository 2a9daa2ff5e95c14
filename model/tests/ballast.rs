//! A ballasted body rights itself; the paper's (centre of mass on the
//! axis) has no restoring moment and keeps any roll.

use anguilla_model::{Body, HeadState, Integrator, Model, ModelConfig, ParametricGait, step};
use anguilla_model::{GaitParams, Workspace};
use nalgebra::{UnitQuaternion, Vector3};

/// The roll (deg) of a straight body at rest, released rolled by 30°, at
/// every step of `seconds`.
fn roll_trace(ballast: f64, seconds: f64) -> Vec<f64> {
    let model = Model::new(ModelConfig {
        body: Body {
            ballast,
            ..Body::paper()
        },
        nodes: 20,
        dt: 0.005,
        joints: 4,
        integrator: Integrator::Midpoint,
    })
    .unwrap();
    let mut gait = ParametricGait::new(
        GaitParams {
            wavelength: 1.0,
            period: 1e6,
            amplitude: [0.0; 3],
            phase: 0.0,
            kc3: 0.0,
            kc2: 0.0,
        },
        0.05,
    )
    .unwrap();
    let mut ws = Workspace::new(&model);
    let mut head = HeadState::launch(0.0);
    head.orientation = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 30f64.to_radians());
    (0..(seconds / 0.005) as usize)
        .map(|_| {
            step(&model, &mut ws, &mut gait, &mut head).unwrap();
            let t3 = head.orientation * Vector3::z();
            // Roll about the (still horizontal) body axis t1 = e1.
            t3.y.atan2(t3.z).to_degrees().abs()
        })
        .collect()
}

#[test]
fn ballast_swings_a_rolled_body_back_and_the_papers_body_stays_rolled() {
    let free = roll_trace(0.0, 1.0);
    let drift = free.iter().map(|r| (r - 30.0).abs()).fold(0.0, f64::max);
    assert!(drift < 0.5, "unballasted: the roll moved by {drift:.2}°");
    // A pendulum: it swings back through upright (the paper's body has no
    // roll drag, c1 = 0, so it swings on; water and fins damp a real one).
    let ballasted = roll_trace(0.02, 1.0);
    let least = ballasted.iter().copied().fold(f64::INFINITY, f64::min);
    assert!(
        least < 3.0,
        "ballasted: never nearer upright than {least:.1}°"
    );
    let most = ballasted.iter().copied().fold(0.0, f64::max);
    assert!(most < 30.5, "ballasted: rolled further, to {most:.1}°");
}
