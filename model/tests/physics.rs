//! Physics checks that need no reference data, plus the
//! comparison with the paper's simplified-model column.

use anguilla_model::gait::{self, LawSource};
use anguilla_model::paper::{self, PAPER_ROWS};
use anguilla_model::run;
use anguilla_model::*;
use nalgebra::Vector3;

fn model(body: Body, nodes: usize, dt: f64, joints: usize) -> Model {
    Model::new(ModelConfig {
        body,
        nodes,
        dt,
        joints,
        integrator: Integrator::Rk4,
    })
    .unwrap()
}

/// Runs `src` from `head` to time `t_end`.
fn advance_to(
    m: &Model,
    ws: &mut Workspace,
    src: &mut LawSource,
    head: &mut HeadState,
    t_end: f64,
) {
    while head.t < t_end - 1e-9 {
        step(m, ws, src, head).unwrap();
    }
}

#[test]
fn vacuum_conserves_momentum_and_centre_of_mass_in_3d() {
    // SPIRAL bends in pitch and yaw: a 3-D shape change from rest in vacuum.
    let m = model(Body::paper().vacuum(), 24, 0.01, 0);
    let mut ws = Workspace::new(&m);
    let g = gait::named_gait("SPIRAL").unwrap();
    let mut src = LawSource::new(g.law);
    let mut head = HeadState::launch(0.0);
    evaluate(&m, &mut ws, &src, &head).unwrap();
    let com0 = ws.diagnostics(&m, &head).centre_of_mass;
    let (mut pmax, mut lmax, mut cmax, mut moved) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for _ in 0..300 {
        evaluate(&m, &mut ws, &src, &head).unwrap();
        let d = ws.diagnostics(&m, &head);
        pmax = pmax.max(d.momentum.norm());
        lmax = lmax.max(d.angular_momentum.norm());
        cmax = cmax.max((d.centre_of_mass - com0).norm());
        moved = moved.max(head.position.norm());
        step(&m, &mut ws, &mut src, &mut head).unwrap();
    }
    // The head moves by centimetres while the momenta stay at the level of
    // the RK4 time and space truncation (body momentum scale ~ 2 kg x 0.3 m/s).
    assert!(moved > 0.02, "head should move, moved {moved}");
    assert!(pmax < 1e-4, "linear momentum {pmax}");
    assert!(lmax < 1e-4, "angular momentum {lmax}");
    assert!(cmax < 1e-5, "centre of mass drift {cmax}");
}

#[test]
fn tail_closure_of_figure_20_converges() {
    // The head acceleration closes the global balance (27) exactly on the
    // grid; the internal wrench of (17), (19), integrated from the nose, must
    // then meet the tail conditions (18), (20) up to a residual that shrinks
    // at the order of the space integration (the paper's figure 20).
    let g = gait::named_gait("SPIRAL").unwrap();
    let m0 = model(Body::paper(), 48, 0.01, 0);
    let mut ws = Workspace::new(&m0);
    let mut src = LawSource::new(g.law);
    let mut head = HeadState::launch(g.v_init);
    advance_to(&m0, &mut ws, &mut src, &mut head, 2.3);
    let mut res = Vec::new();
    let mut scale = 0.0;
    for n in [12, 24, 48, 96] {
        let m = model(Body::paper(), n, 0.01, 0);
        let mut w = Workspace::new(&m);
        evaluate(&m, &mut w, &src, &head).unwrap();
        res.push(w.tail_residual().norm());
        scale = w.c_star().iter().map(|c| c.norm()).fold(0.0, f64::max);
    }
    let order = (res[2] / res[3]).log2();
    eprintln!("tail residuals {res:?} (|c*| max {scale}), observed order {order:.2}");
    assert!(res.windows(2).all(|w| w[1] < w[0]), "{res:?}");
    // Simpson is 4th order, the nose profile ~ sqrt(X1) lowers it; at least 1.5
    assert!(order > 1.5, "order {order}, residuals {res:?}");
    assert!(res[3] < 1e-3 * scale.max(1e-3), "{res:?}");
}

#[test]
fn reactive_energy_balance() {
    // Purely reactive model: d(T_b + T_f)/dt = actuator power + tail flux.
    let mut body = Body::paper();
    body.resistive = false;
    let dt = 0.002;
    let m = model(body, 48, dt, 0);
    let mut ws = Workspace::new(&m);
    let g = gait::named_gait("T4").unwrap();
    let mut src = LawSource::new(g.law);
    let mut head = HeadState::launch(-0.3);
    advance_to(&m, &mut ws, &mut src, &mut head, 1.3);
    let mut rec = Vec::new();
    for _ in 0..200 {
        evaluate(&m, &mut ws, &src, &head).unwrap();
        let d = ws.diagnostics(&m, &head);
        rec.push((d.energy, d.actuator_power + d.tail_flux));
        step(&m, &mut ws, &mut src, &mut head).unwrap();
    }
    let scale = rec.iter().map(|r| r.1.abs()).fold(0.0, f64::max);
    let mut worst = 0.0f64;
    for k in 1..rec.len() - 1 {
        let de = (rec[k + 1].0 - rec[k - 1].0) / (2.0 * dt);
        worst = worst.max((de - rec[k].1).abs());
    }
    // central difference O(dt²) and RK4 errors: well under 1 % of the power
    assert!(scale > 0.01, "power scale {scale}");
    assert!(
        worst < 1e-2 * scale,
        "energy balance error {worst} vs power {scale}"
    );
}

fn f1_speed(nodes: usize, dt: f64) -> f64 {
    let m = model(Body::paper(), nodes, dt, 0);
    let g = gait::named_gait("F1").unwrap();
    run::run_gait(&m, &g, 8.0, |_, _, _, _, _| {})
        .unwrap()
        .last_period_forward_speed
}

#[test]
fn f1_speed_converges_in_nodes_and_dt() {
    let v: Vec<f64> = [12, 24, 48, 96]
        .iter()
        .map(|&n| f1_speed(n, 0.02))
        .collect();
    let d: Vec<f64> = v.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
    eprintln!("F1 speed vs nodes 12/24/48/96: {v:?}");
    assert!(d[1] < d[0] && d[2] < d[1], "{v:?}");
    assert!(d[2] / v[3] < 1e-3, "48 -> 96 changes by {}", d[2] / v[3]);
    let w: Vec<f64> = [0.04, 0.02, 0.01]
        .iter()
        .map(|&dt| f1_speed(24, dt))
        .collect();
    eprintln!("F1 speed vs dt 0.04/0.02/0.01: {w:?}");
    // RK4 in time is converged already at dt = 0.04 s: the remaining
    // differences (~1e-4 relative) come from sampling the average at the steps
    assert!((w[1] - w[0]).abs() / w[2] < 3e-4, "{w:?}");
    assert!((w[2] - w[1]).abs() / w[2] < 3e-4, "{w:?}");
}

#[test]
fn discrete_chain_converges_to_the_beam() {
    // Drive the body by n joints carrying the continuous gait's joint angles
    // (curvature lumped over each joint's span) and compare the head
    // acceleration with the continuous beam's, at the same state.
    let g = gait::named_gait("F1").unwrap();
    let beam = model(Body::paper(), 96, 0.01, 0);
    let mut ws = Workspace::new(&beam);
    let mut src = LawSource::new(g.law);
    let mut head = HeadState::launch(0.0);
    advance_to(&beam, &mut ws, &mut src, &mut head, 2.4);
    let r = evaluate(&beam, &mut ws, &src, &head).unwrap();
    let reference = Vector3::new(r.v_dot.x, r.v_dot.y, r.omega_dot.z);
    let mut errs = Vec::new();
    for n in [6, 12, 24] {
        let m = model(Body::paper(), 8 * (n + 1), 0.01, n);
        let mut w = Workspace::new(&m);
        let h = 1e-4;
        let mut at = |dt: f64| {
            let mut s = src;
            s.t += dt;
            posture(&m, &mut w, &s).to_vec()
        };
        let (jm, j0, jp) = (at(-h), at(0.0), at(h));
        let mut jc = JointCurvature::new(n, 1.0);
        for (k, jmut) in jc.joints_mut().iter_mut().enumerate() {
            jmut.pitch = [
                j0[k].pitch,
                j0[k].pitch_rate,
                (jp[k].pitch_rate - jm[k].pitch_rate) / (2.0 * h),
            ];
            jmut.yaw = [
                j0[k].yaw,
                j0[k].yaw_rate,
                (jp[k].yaw_rate - jm[k].yaw_rate) / (2.0 * h),
            ];
        }
        let rc = evaluate(&m, &mut w, &jc, &head).unwrap();
        let e = (Vector3::new(rc.v_dot.x, rc.v_dot.y, rc.omega_dot.z) - reference).norm();
        errs.push(e / reference.norm());
    }
    eprintln!("chain vs beam head acceleration relative errors (n = 6, 12, 24): {errs:?}");
    // first order in the joint spacing: the error halves when n+1 doubles
    assert!(
        errs[0] > 1.6 * errs[1] && errs[1] > 1.6 * errs[2],
        "{errs:?}"
    );
    assert!(errs[2] < 0.3, "{errs:?}");
}

/// The band within which one gait's signed deviation from the paper's
/// simplified-model (S-M) value must lie, and why it sits there.
struct Band {
    gait: &'static str,
    /// Lowest and highest accepted `(ours - S-M) / |S-M|`.
    lo: f64,
    hi: f64,
}

const fn band(gait: &'static str, lo: f64, hi: f64) -> Band {
    Band { gait, lo, hi }
}

// Each band is the deviation measured here (52 intervals, dt = 0.025 s,
// the default; the value in each comment) +- 1 percentage point. The point
// covers what is not physics: the test's discretization against the
// converged one (F1 +0.2 %, README "Convergence"); the time step (below,
// `the_paper_table_does_not_move_with_the_time_step`); libm differences
// between machines (far smaller). A
// change of the model that moves a gait by more fails here: re-measure,
// explain the new deviation, then update the band and the README table.
//
// Why the centres are not at zero: the paper gives neither its averaging
// windows nor its run lengths, and several details are read, not given
// (docs/MODEL-NOTES.md, "What to expect against the tables": a faithful
// reading lands 3-13 % from S-M; no coefficient is tuned to the tables).
// The paper's values are printed in its tables, not read off figures:
// speeds to 1e-3 m/s (0.2 % of F7's 0.306, the smallest), yaws to whole
// degrees (+-0.5 deg: 1 % of T5's 49 deg, the smallest).
const BANDS: [Band; 13] = [
    // Forward speeds, Table 2: -V1(0), mean over the last 5 periods of 30 s.
    // F1-F6 swim 3-8 % faster than S-M, F2 (a0 = 0, lambda = 1.25) the
    // most: its cause is not isolated (model/README.md).
    band("F1", 0.057, 0.077), // measured +6.74 %
    band("F2", 0.106, 0.126), // measured +11.56 %
    band("F3", 0.054, 0.074), // measured +6.36 %
    band("F4", 0.064, 0.084), // measured +7.44 %
    band("F5", 0.040, 0.060), // measured +4.95 %
    band("F6", 0.021, 0.041), // measured +3.06 %
    // F7 (a2 = 3.5, a1 = -4.5: the slowest swimmer) is the low-Reynolds
    // case: the paper says its friction law (41) is unreliable there (its
    // own S-M is 9 % from N-S, the most of Table 2), and MODEL-NOTES that it
    // depends strongly on run length and window. Ours is slower than S-M,
    // 2.9 % from N-S.
    band("F7", -0.129, -0.109), // measured -11.92 %
    // Turns, Table 4: yaw mean over 10-15 s of a 15 s run. We turn 2-9 %
    // more than S-M, except T5.
    band("T1", -0.098, -0.078), // measured -8.78 %
    band("T2", -0.085, -0.065), // measured -7.51 %
    band("T3", -0.072, -0.052), // measured -6.22 %
    band("T4", -0.051, -0.031), // measured -4.09 %
    // T5, the smallest turn, turns less than S-M. Its switching times
    // (0.25, 0.75, 1.75, 2.25 s) are the shortest: a step that straddles
    // one (dt 0.02 or 0.04 s) moved it by up to 0.5 points before the
    // default step became 0.025 s, which divides them.
    band("T5", 0.057, 0.077),   // measured +6.69 %
    band("T6", -0.029, -0.009), // measured -1.89 %
];

#[test]
fn forward_and_turning_gaits_each_within_its_band_of_the_paper() {
    // Converged discretization (52 intervals, dt = 0.025 s), the run
    // lengths and averaging windows of `anguilla swim --paper`.
    let m = model(Body::paper(), 52, DEFAULT_DT, 0);
    let rows: Vec<_> = PAPER_ROWS
        .iter()
        .filter(|r| r.gait.starts_with('F') || r.gait.starts_with('T'))
        .collect();
    assert_eq!(
        rows.iter().map(|r| r.gait).collect::<Vec<_>>(),
        BANDS.iter().map(|b| b.gait).collect::<Vec<_>>(),
        "every forward and turning gait of the paper has a band"
    );
    let mut outside = Vec::new();
    for (row, b) in rows.iter().zip(&BANDS) {
        let g = gait::named_gait(row.gait).unwrap();
        let s = run::run_gait(&m, &g, row.duration, |_, _, _, _, _| {}).unwrap();
        let ours = paper::metric_value(row.metric, &s);
        let e = (ours - row.sm) / row.sm.abs();
        let ok = (b.lo..=b.hi).contains(&e);
        eprintln!(
            "{:3} ours {ours:9.4}  S-M {:9.4}  deviation {:+6.2} %  band {:+6.2} ..= {:+6.2} %{}",
            row.gait,
            row.sm,
            100.0 * e,
            100.0 * b.lo,
            100.0 * b.hi,
            if ok { "" } else { "  OUTSIDE" }
        );
        if !ok {
            outside.push(row.gait);
        }
    }
    assert!(outside.is_empty(), "outside their bands: {outside:?}");
}

/// The default time step (0.025 s, 2.5 times the paper's runs' 0.01 s and
/// so 2.5 times faster) leaves every row of the paper table within 0.05 %
/// of the same row at half the step. A step that straddles the gaits'
/// switching times does not: at 0.02 s T5 moves by 0.54 % from 0.01 s
/// (model/README.md, "Time step"), which this test would catch.
#[test]
fn the_paper_table_does_not_move_with_the_time_step() {
    let coarse = model(Body::paper(), 52, DEFAULT_DT, 12);
    let fine = model(Body::paper(), 52, DEFAULT_DT / 2.0, 12);
    let mut worst = (0.0f64, "");
    for row in PAPER_ROWS {
        let g = gait::named_gait(row.gait).unwrap();
        let a = paper::Comparison::run(&coarse, row, g).unwrap().ours;
        let b = paper::Comparison::run(&fine, row, g).unwrap().ours;
        let moved = ((a - b) / b).abs();
        eprintln!(
            "{:7} dt {DEFAULT_DT}: {a:10.5}  dt {}: {b:10.5}  moved {:.4} %",
            row.gait,
            DEFAULT_DT / 2.0,
            100.0 * moved
        );
        if moved > worst.0 {
            worst = (moved, row.gait);
        }
    }
    assert!(
        worst.0 < 5e-4,
        "{} moved by {:.4} %",
        worst.1,
        100.0 * worst.0
    );
}

#[test]
fn bad_parameters_are_errors_naming_them() {
    for (nodes, dt, name) in [
        (0, 0.01, "nodes"),
        (10, 0.0, "dt"),
        (10, f64::NAN, "dt"),
        (10, 0.5, "dt"),
    ] {
        let e = Model::new(ModelConfig {
            nodes,
            dt,
            ..ModelConfig::default()
        })
        .unwrap_err();
        assert!(e.to_string().contains(name), "{e}");
    }
}

struct Nan;
impl CurvatureSource for Nan {
    fn curvature(&self, _tau: f64, _x: &[f64], out: &mut [Curvature]) {
        for o in out {
            o.k_ddot.z = f64::NAN;
        }
    }
    fn advance(&mut self, _dt: f64) {}
    fn time(&self) -> f64 {
        0.0
    }
}

struct Wild(f64);
impl CurvatureSource for Wild {
    fn curvature(&self, tau: f64, x: &[f64], out: &mut [Curvature]) {
        let w = 2000.0;
        for (o, &xx) in out.iter_mut().zip(x) {
            let a = w * (self.0 + tau) + 10.0 * xx;
            o.k.z = 5.0 * a.sin();
            o.k_dot.z = 5.0 * w * a.cos();
            o.k_ddot.z = -5.0 * w * w * a.sin();
        }
    }
    fn advance(&mut self, dt: f64) {
        self.0 += dt;
    }
    fn time(&self) -> f64 {
        self.0
    }
}

#[test]
fn non_finite_or_diverging_states_are_errors_not_panics() {
    let m = model(Body::paper(), 12, 0.05, 0);
    let mut ws = Workspace::new(&m);
    let mut head = HeadState::launch(0.0);
    let e = step(&m, &mut ws, &mut Nan, &mut head).unwrap_err();
    assert!(matches!(e, ModelError::NonFinite { .. }), "{e}");
    assert_eq!(head, HeadState::launch(0.0), "state unchanged on error");
    // a gait far too fast for dt = 0.05 s either diverges or stays finite;
    // it never panics and never returns NaN
    let mut src = Wild(0.0);
    for _ in 0..2000 {
        match step(&m, &mut ws, &mut src, &mut head) {
            Ok(r) => assert!(r.v_dot.iter().all(|v| v.is_finite())),
            Err(e) => {
                assert!(e.to_string().contains("t = "), "{e}");
                break;
            }
        }
    }
}

/// A law of time that does not say so: the model integrates every shape.
struct Opaque(LawSource);

impl CurvatureSource for Opaque {
    fn curvature(&self, tau: f64, x: &[f64], out: &mut [Curvature]) {
        self.0.curvature(tau, x, out);
    }
    fn advance(&mut self, dt: f64) {
        self.0.advance(dt);
    }
    fn time(&self) -> f64 {
        self.0.time()
    }
}

#[test]
fn a_carried_shape_and_a_shared_inertia_change_nothing() {
    // RK4 keeps a step's last shape for the next step when the source is a
    // law of time; the source that hides it integrates every shape. Bit
    // for bit the same head state and torques after 300 steps of F1,
    // turning (T1) and with the step size the tables use.
    for name in ["F1", "T1"] {
        let g = gait::named_gait(name).unwrap();
        let m = Model::new(ModelConfig::default()).unwrap();
        let (mut wa, mut wb) = (Workspace::new(&m), Workspace::new(&m));
        let (mut sa, mut sb) = (LawSource::new(g.law), Opaque(LawSource::new(g.law)));
        assert!(sa.is_law_of_time() && !sb.is_law_of_time());
        let (mut ha, mut hb) = (HeadState::launch(g.v_init), HeadState::launch(g.v_init));
        for _ in 0..300 {
            let ra = step(&m, &mut wa, &mut sa, &mut ha).unwrap();
            let rb = step(&m, &mut wb, &mut sb, &mut hb).unwrap();
            assert_eq!(ra, rb, "{name}");
            assert_eq!(wa.joints(), wb.joints(), "{name}");
        }
        assert_eq!(ha, hb, "{name}");
        // A source swapped under the workspace (another time) is integrated.
        let mut other = LawSource::new(g.law);
        let r = step(&m, &mut wa, &mut other, &mut HeadState::launch(g.v_init)).unwrap();
        let fresh = step(
            &m,
            &mut Workspace::new(&m),
            &mut LawSource::new(g.law),
            &mut HeadState::launch(g.v_init),
        )
        .unwrap();
        assert_eq!(r, fresh, "{name}");
    }
}
