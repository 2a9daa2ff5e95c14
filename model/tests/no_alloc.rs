//! A counting global allocator proves that a control step (parametric gait
//! update, forward + inverse dynamics, joint mapping) allocates nothing.

use anguilla_model::*;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

struct Counting;

thread_local! {
    static COUNT: Cell<usize> = const { Cell::new(0) };
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let _ = COUNT.try_with(|c| c.set(c.get() + 1));
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let _ = COUNT.try_with(|c| c.set(c.get() + 1));
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn allocations() -> usize {
    COUNT.with(|c| c.get())
}

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
    let mut gait = ParametricGait::from_rest(GaitParams::default(), 0.2);
    let mut head = HeadState::launch(0.0);
    let mut joints = JointCurvature::new(12, 1.0);
    let turn = GaitParams {
        kc3: 1.0,
        ..GaitParams::default()
    };
    let before = allocations();
    let mut sum = 0.0;
    for k in 0..500 {
        if k == 250 {
            gait.set_target(&turn);
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
    let after = allocations();
    assert!(sum.is_finite());
    assert_eq!(after - before, 0, "allocations during 500 control steps");
    // the counter does count this thread's allocations
    let v = std::hint::black_box(vec![1u8; 16]);
    assert!(allocations() > after && v.len() == 16);
}
