//! The water's surface (`Workspace::set_surface`): a section above it is
//! neither buoyed nor dragged; under it, or with no surface set, the model
//! is bit for bit as without one.

use anguilla_model::*;
use nalgebra::Vector3;

fn model() -> Model {
    Model::new(ModelConfig {
        nodes: 24,
        dt: 0.005,
        joints: 0,
        integrator: Integrator::Rk4,
        ..ModelConfig::default()
    })
    .unwrap()
}

/// A straight body that does not swim.
struct Straight(f64);
impl CurvatureSource for Straight {
    fn curvature(&self, _tau: f64, _x: &[f64], out: &mut [Curvature]) {
        out.fill(Curvature::default());
    }
    fn advance(&mut self, dt: f64) {
        self.0 += dt;
    }
    fn time(&self) -> f64 {
        self.0
    }
}

/// The head's acceleration (earth frame) of the straight, level body at the
/// origin moving at `velocity`, with the surface at `surface`.
fn accel(surface: Option<f64>, velocity: Vector3<f64>) -> Vector3<f64> {
    let m = model();
    let mut ws = Workspace::new(&m);
    ws.set_surface(surface);
    let mut head = HeadState::launch(0.0);
    head.velocity = velocity;
    evaluate(&m, &mut ws, &Straight(0.0), &head).unwrap().v_dot
}

#[test]
fn under_the_surface_the_model_is_bit_for_bit_as_without_one() {
    for v in [Vector3::zeros(), Vector3::new(-0.4, 0.2, -0.1)] {
        let none = accel(None, v);
        // The body's half-height is a few centimetres: 1 m below the
        // surface, every section is wholly in the water.
        let under = accel(Some(1.0), v);
        assert_eq!(none, under, "velocity {v:?}");
    }
}

#[test]
fn a_body_above_the_water_falls_and_a_half_submerged_one_falls_half_as_fast() {
    // The paper's body is neutrally buoyant: at rest in the water it
    // stays.
    let wet = accel(None, Vector3::zeros());
    assert!(wet.norm() < 1e-9, "in the water: {wet:?}");
    // 1 m above the water: its weight with no buoyancy. The added mass
    // is kept (a simplification, docs/autopilot.md), so it falls slower
    // than g, by m_b / (m_b + m_f3) of the sections.
    let dry = accel(Some(-1.0), Vector3::zeros());
    assert!(
        dry.z < -0.3 * GRAVITY && dry.z > -GRAVITY,
        "above the water: {dry:?}"
    );
    assert!(dry.x.abs() < 1e-9 && dry.y.abs() < 1e-9, "{dry:?}");
    // The surface through the axis: every section half in the water.
    let half = accel(Some(0.0), Vector3::zeros());
    assert!(
        (half.z / dry.z - 0.5).abs() < 1e-9,
        "half submerged: {half:?}, dry {dry:?}"
    );
}

#[test]
fn a_body_above_the_water_is_not_dragged() {
    // Sideways at 0.5 m/s: in the water the drag slows it.
    let v = Vector3::new(0.0, 0.5, 0.0);
    let wet = accel(None, v);
    assert!(wet.y < -0.1, "in the water: {wet:?}");
    // Above it, nothing does (the reactive terms of a straight body in
    // uniform motion are zero).
    let dry = accel(Some(-1.0), v);
    assert!(
        dry.y.abs() < 1e-3 * wet.y.abs(),
        "above: {dry:?}, in: {wet:?}"
    );
}

#[test]
fn a_nose_lifted_out_of_the_water_falls_back() {
    // The body pitched nose up by 20°, its nose 5 cm above the surface,
    // at rest: with the surface its emerged front is heavy and pitches it
    // back down; without, nothing moves it (neutral buoyancy).
    let m = model();
    let pitched = nalgebra::UnitQuaternion::from_axis_angle(&Vector3::y_axis(), 20f64.to_radians());
    let run = |surface: Option<f64>| {
        let mut ws = Workspace::new(&m);
        ws.set_surface(surface);
        let mut head = HeadState::launch(0.0);
        head.orientation = pitched;
        let tail_up = |h: &HeadState| (h.orientation * Vector3::x()).z;
        let before = tail_up(&head);
        let mut src = Straight(0.0);
        for _ in 0..100 {
            step(&m, &mut ws, &mut src, &mut head).unwrap();
        }
        (before, tail_up(&head))
    };
    let (before, still) = run(None);
    assert!((still - before).abs() < 1e-6, "{before} -> {still}");
    // t1 points to the tail: nose up is a tail below (t1.z < 0); the nose
    // falling back brings t1.z towards 0.
    assert!(before < 0.0, "{before}");
    let (_, after) = run(Some(-0.05));
    assert!(
        after > before + 0.01,
        "t1.z {before} -> {after}: the nose did not fall back"
    );
}
