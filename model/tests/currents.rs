//! A uniform current in the water: physical checks of
//! `Workspace::set_current`.
//!
//! Why most tolerances here are tight: the hydrodynamic terms see only the
//! velocity relative to the water, so for a *steady* uniform current the
//! model is Galilean invariant. A swimmer launched at rest relative to the
//! water moves exactly as in still water, plus `u t`: not "about" but exactly,
//! up to rounding (the nonlinear drag laws are functions of the relative
//! velocity, which is the same in both runs). What can differ is only the
//! transient of a body launched relative to the *ground*.

use anguilla_model::gait::{self, LawSource};
use anguilla_model::*;
use nalgebra::{UnitQuaternion, Vector3};

fn model(nodes: usize, dt: f64) -> Model {
    Model::new(ModelConfig {
        nodes,
        dt,
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

fn steady(x: f64, y: f64) -> Current {
    Current::steady(Vector3::new(x, y, 0.0)).unwrap()
}

/// Releases the straight body at rest (ground frame) in `current` and runs
/// it for `duration` s; returns the final head state.
fn passive_drift(current: Current, duration: f64) -> HeadState {
    let m = model(12, 0.05);
    let mut ws = Workspace::new(&m);
    ws.set_current(current);
    let mut src = Straight(0.0);
    let mut head = HeadState::launch(0.0);
    while head.t < duration - 1e-9 {
        step(&m, &mut ws, &mut src, &mut head).unwrap();
    }
    head
}

#[test]
fn a_passive_body_drifts_with_a_cross_current() {
    // Broadside: the lateral drag (c2 = 1.98 on the body's height) is strong
    // against the lateral inertia with added mass (~7 kg): the lateral
    // relative speed decays as 1 / (1 + t / tau), tau ~ 0.8 s at 0.1 m/s.
    // While it does, the drag and the Munk moment turn the body a little
    // (head and tail differ), so part of the relative flow ends up along
    // the body, where only the weak skin friction damps it: hence 600 s.
    let u = 0.1;
    let head = passive_drift(steady(0.0, u), 600.0);
    let v = head.velocity;
    let rel = (v - Vector3::new(0.0, u, 0.0)).norm();
    eprintln!(
        "passive, cross current {u} m/s, 600 s: ground velocity {v:?}, relative speed {rel:.2e}, yaw {:.4} rad, omega {:.2e}",
        head.yaw(),
        head.omega.norm()
    );
    // "within a few %": 3 % of U (measured 1.6 %)
    assert!(rel < 0.03 * u, "relative speed {rel} after 600 s");
}

#[test]
fn a_passive_body_drifts_with_an_axial_current() {
    // Along the body only skin friction (41) and the nose pressure drag act:
    // ~3 mN at 0.1 m/s on ~2 kg, so the relative speed decays slowly.
    let u = 0.1;
    let head = passive_drift(steady(u, 0.0), 600.0);
    let v = head.velocity;
    let rel = (v - Vector3::new(u, 0.0, 0.0)).norm();
    eprintln!(
        "passive, axial current {u} m/s, 600 s: ground velocity {v:?}, relative speed {rel:.2e}"
    );
    // "within a few %": 3 % of U (measured 2.4 %); no sideways motion or
    // turn at all (the flow is along the axis of a symmetric body)
    assert!(rel < 0.03 * u, "relative speed {rel} after 600 s");
    assert!(v.y.abs() < 1e-12 && head.yaw().abs() < 1e-12, "{v:?}");
}

/// Runs F1 for `duration` s at `dt` from `head` in `current`, calling
/// `observe` after every step.
fn swim_f1(
    current: Current,
    mut head: HeadState,
    duration: f64,
    mut observe: impl FnMut(&HeadState),
) -> HeadState {
    let m = model(24, 0.02);
    let mut ws = Workspace::new(&m);
    ws.set_current(current);
    let g = gait::named_gait("F1").unwrap();
    let mut src = LawSource::new(g.law);
    while head.t < duration - 1e-9 {
        step(&m, &mut ws, &mut src, &mut head).unwrap();
        observe(&head);
    }
    head
}

/// Mean ground velocity over the last 5 periods (5 s) of a 30 s F1 run, and
/// the range of the yaw over the same window.
fn f1_mean_velocity(current: Current, head: HeadState) -> (Vector3<f64>, f64, f64) {
    let (mut sum, mut n) = (Vector3::zeros(), 0);
    let (mut ylo, mut yhi) = (f64::INFINITY, f64::NEG_INFINITY);
    swim_f1(current, head, 30.0, |h| {
        if h.t > 25.0 + 1e-9 {
            sum += h.velocity;
            n += 1;
            ylo = ylo.min(h.yaw());
            yhi = yhi.max(h.yaw());
        }
    });
    (sum / n as f64, ylo, yhi)
}

#[test]
fn zero_current_is_bit_for_bit_still_water() {
    let g = gait::named_gait("F1").unwrap();
    let plain = {
        let m = model(24, 0.02);
        let mut ws = Workspace::new(&m);
        let mut src = LawSource::new(g.law);
        let mut head = HeadState::launch(0.0);
        for _ in 0..100 {
            step(&m, &mut ws, &mut src, &mut head).unwrap();
        }
        (head, ws.joints().to_vec(), ws.torques().to_vec())
    };
    let with = {
        let m = model(24, 0.02);
        let mut ws = Workspace::new(&m);
        ws.set_current(Current::ZERO);
        let mut src = LawSource::new(g.law);
        let mut head = HeadState::launch(0.0);
        for _ in 0..100 {
            step(&m, &mut ws, &mut src, &mut head).unwrap();
        }
        (head, ws.joints().to_vec(), ws.torques().to_vec())
    };
    assert_eq!(plain.0, with.0);
    assert_eq!(plain.1, with.1);
    assert_eq!(plain.2, with.2);
    // and a steady zero current built from a zero vector is the same value
    assert_eq!(Current::steady(Vector3::zeros()).unwrap(), Current::ZERO);
}

#[test]
fn swimming_in_a_steady_current_is_still_water_plus_u_t() {
    // Launched at rest relative to the water, F1 in a current u is F1 in
    // still water translated by u t, with the same yaw: a uniform current
    // exerts no force or moment of its own. Any term that used the ground
    // velocity instead of the relative one (drag, added mass, Munk moment,
    // tail flux, nose drag) would break this by ~1e-2.
    let u = Vector3::new(0.1, -0.07, 0.0);
    let g = gait::named_gait("F1").unwrap();
    let mut still = Vec::new();
    swim_f1(Current::ZERO, HeadState::launch(g.v_init), 10.0, |h| {
        still.push(*h)
    });
    let mut k = 0;
    let (mut dpos, mut dvel, mut dyaw) = (0.0f64, 0.0f64, 0.0f64);
    let start = HeadState {
        velocity: HeadState::launch(g.v_init).velocity + u,
        ..HeadState::launch(g.v_init)
    };
    swim_f1(Current::steady(u).unwrap(), start, 10.0, |h| {
        let s = &still[k];
        dpos = dpos.max((h.position - (s.position + u * h.t)).norm());
        dvel = dvel.max((h.velocity - (s.velocity + u)).norm());
        dyaw = dyaw.max((h.yaw() - s.yaw()).abs());
        k += 1;
    });
    eprintln!(
        "F1 in a current {u:?} vs still water + u t over 10 s: |dpos| {dpos:.1e} m, |dvel| {dvel:.1e} m/s, |dyaw| {dyaw:.1e} rad"
    );
    // rounding only: the two runs add u to different partial sums
    assert!(dpos < 1e-9 && dvel < 1e-9 && dyaw < 1e-9);
}

#[test]
fn swimming_head_on_into_a_current_loses_its_speed() {
    // F1 swims towards -e1; the water flows towards +e1 at U. Both runs
    // start at rest on the ground (the still-water run in still water, the
    // other with the water already flowing past it).
    let u = 0.1;
    let g = gait::named_gait("F1").unwrap();
    let (v0, ..) = f1_mean_velocity(Current::ZERO, HeadState::launch(g.v_init));
    let (v1, ..) = f1_mean_velocity(steady(u, 0.0), HeadState::launch(g.v_init));
    let (speed0, speed1) = (-v0.x, -v1.x);
    let loss = speed0 - speed1;
    eprintln!(
        "F1 ground speed, mean over 25-30 s: still water {speed0:.5} m/s, head-on current {u} m/s: {speed1:.5} m/s, loss {loss:.5} m/s ({:+.3} % of U)",
        100.0 * (loss - u) / u
    );
    // The steady state is a limit cycle of the relative motion, the same as
    // in still water (Galilean invariance, previous test); what remains at
    // 25-30 s is the memory of the different launch (relative speed 0.1 m/s
    // head first at t = 0), which the drag damps within a few periods:
    // measured +0.015 % of U. Tolerance 1 % of U: "about U" of the issue,
    // made exact by the model's invariance; a nonlinear drag does not spoil
    // it because it is a function of the relative velocity only.
    assert!((loss - u).abs() < 0.01 * u, "loss {loss} vs U {u}");
}

#[test]
fn a_cross_current_carries_the_swimmer_sideways_at_its_speed() {
    // F1 starts at rest on the ground while the water flows past it
    // sideways at U. During the first strokes the relative cross flow turns
    // it (weathervaning into the current by a few degrees); once it moves
    // with the water the current exerts no moment and the heading stays
    // where the transient left it. Its ground velocity is then its
    // still-water swimming velocity, turned by that heading change, plus U.
    let u = 0.1;
    let g = gait::named_gait("F1").unwrap();
    let (v0, y0lo, y0hi) = f1_mean_velocity(Current::ZERO, HeadState::launch(g.v_init));
    let (v1, ylo, yhi) = f1_mean_velocity(steady(0.0, u), HeadState::launch(g.v_init));
    let turn = 0.5 * (ylo + yhi) - 0.5 * (y0lo + y0hi);
    let swim = nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), turn) * v0;
    let drift = v1 - swim;
    eprintln!(
        "F1, cross current {u} m/s from rest on the ground: heading turned by {turn:.4} rad, ground velocity {v1:?}, minus the turned still-water swimming velocity: {drift:?} m/s"
    );
    // After the transient the motion is the still-water limit cycle turned
    // and translated (the model is invariant under both), so this holds to
    // the accuracy of the heading estimate: measured 2e-8 U. Tolerance
    // 1e-3 U: a drag or moment that used the ground velocity would break it
    // by orders of magnitude more.
    assert!((drift.y - u).abs() < 1e-3 * u, "drift {drift:?}");
    assert!(drift.x.abs() < 1e-3 * u, "drift {drift:?}");
    // The heading is steady once the body moves with the water: the yaw
    // mid-range over 15-20 s and over 25-30 s agree as in still water.
    let mut late = [(f64::INFINITY, f64::NEG_INFINITY); 2];
    swim_f1(steady(0.0, u), HeadState::launch(g.v_init), 30.0, |h| {
        let w = if h.t > 15.0 && h.t <= 20.0 {
            0
        } else if h.t > 25.0 {
            1
        } else {
            return;
        };
        late[w] = (late[w].0.min(h.yaw()), late[w].1.max(h.yaw()));
    });
    let mid = |w: (f64, f64)| 0.5 * (w.0 + w.1);
    let yaw_change = mid(late[1]) - mid(late[0]);
    eprintln!("  heading change from 15-20 s to 25-30 s: {yaw_change:.2e} rad");
    assert!(turn.abs() > 0.01, "the transient turns the swimmer: {turn}");
    // measured 3e-7 rad (still water: the same order)
    assert!(yaw_change.abs() < 1e-4, "{yaw_change}");
}

#[test]
fn an_oscillating_current_carries_a_passive_body_along() {
    // A neutrally buoyant body at rest relative to an accelerating uniform
    // current stays at rest relative to it: added mass on the relative
    // acceleration and the Froude–Krylov force rho_f A u_dot exactly make up
    // the body's inertia m u_dot (rho_b = rho_f). Without the fluid-
    // acceleration terms the body would lag, by ~u_amp.
    let c = Current::oscillating(
        Vector3::new(0.05, 0.0, 0.0),
        Vector3::new(0.05, 0.08, 0.0),
        4.0,
    )
    .unwrap();
    let m = model(12, 0.01);
    let mut ws = Workspace::new(&m);
    ws.set_current(c);
    let mut src = Straight(0.0);
    let mut head = HeadState {
        velocity: c.velocity(0.0),
        orientation: UnitQuaternion::identity(),
        ..HeadState::launch(0.0)
    };
    let mut worst = 0.0f64;
    while head.t < 8.0 - 1e-9 {
        step(&m, &mut ws, &mut src, &mut head).unwrap();
        worst = worst.max((head.velocity - c.velocity(head.t)).norm());
    }
    eprintln!("passive in an oscillating current: max |v - u| {worst:.2e} m/s over 2 periods");
    assert!(worst < 1e-6, "{worst}");
}
