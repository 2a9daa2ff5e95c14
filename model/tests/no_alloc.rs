//! A counting global allocator proves that a control step (parametric gait
//! update, forward + inverse dynamics, joint mapping) allocates nothing.

use anguilla_model::*;
#[global_allocator]
static GLOBAL: anguilla_testkit::CountingAlloc = anguilla_testkit::CountingAlloc;

#[test]
fn a_control_step_allocates_nothing() {
    let model = Model::new(ModelConfig {
        dt: 0.001,
        joints: 12,
        integrator: Integrator::Midpoint,
        ..ModelConfig::default()
    })
    .unwrap();
    let mut ws = Workspace::new(&model);
    let mut gait = ParametricGait::from_rest(GaitParams::default(), 0.2).unwrap();
    let mut head = HeadState::launch(0.0);
    let mut joints = JointCurvature::new(12, 1.0);
    let turn = GaitParams {
        kc3: 1.0,
        ..GaitParams::default()
    };
    let mut sum = 0.0;
    let ((), calls) = anguilla_testkit::count(|| {
        for k in 0..500 {
            if k == 250 {
                gait.set_target(&turn).unwrap();
            }
            let r = step(&model, &mut ws, &mut gait, &mut head).unwrap();
            sum += r.forward_speed + ws.joints().iter().map(|j| j.c3 + j.yaw).sum::<f64>();
            // simulator path: curvature from measured joints, torques demanded
            for (m, j) in joints.joints_mut().iter_mut().zip(ws.joints()) {
                m.yaw = [j.yaw, j.yaw_rate, 0.0];
                m.pitch = [j.pitch, j.pitch_rate, 0.0];
            }
            let rj = evaluate(&model, &mut ws, &joints, &head).unwrap();
            sum += rj.v_dot.x;
            let _ = posture(&model, &mut ws, &gait);
        }
    });
    assert!(sum.is_finite());
    assert_eq!(calls, 0, "allocator calls during 500 control steps");
    // the counter does count this thread's allocations
    let (v, calls) = anguilla_testkit::count(|| std::hint::black_box(vec![1u8; 16]));
    assert!(calls > 0 && v.len() == 16);
}

#[test]
fn a_control_step_in_a_current_allocates_nothing() {
    let model = Model::new(ModelConfig {
        dt: 0.001,
        joints: 12,
        integrator: Integrator::Midpoint,
        ..ModelConfig::default()
    })
    .unwrap();
    let mut ws = Workspace::new(&model);
    let mut gait = ParametricGait::from_rest(GaitParams::default(), 0.2).unwrap();
    let mut head = HeadState::launch(0.0);
    let steady = Current::steady(nalgebra::Vector3::new(0.1, -0.05, 0.0)).unwrap();
    let swell = Current::oscillating(
        nalgebra::Vector3::new(0.1, 0.0, 0.0),
        nalgebra::Vector3::new(0.0, 0.05, 0.01),
        2.0,
    )
    .unwrap();
    let mut sum = 0.0;
    let ((), calls) = anguilla_testkit::count(|| {
        for k in 0..500 {
            // the loop changes the current as a scenario does
            ws.set_current(if k < 250 { steady } else { swell });
            let r = step(&model, &mut ws, &mut gait, &mut head).unwrap();
            sum += r.forward_speed + ws.joints().iter().map(|j| j.c3).sum::<f64>();
        }
    });
    assert!(sum.is_finite());
    assert_eq!(
        calls, 0,
        "allocator calls during 500 control steps in a current"
    );
}
