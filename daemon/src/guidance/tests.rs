//! The law on a kinematic robot: speed `U` along its heading, the heading
//! following the asked one with a first-order lag, pushed by a current.

use super::*;

const U: f64 = 0.6;
const DT: f64 = 0.01;

fn guidance(integral: f64) -> Guidance {
    let mut cfg = Config::default();
    cfg.guidance.integral = integral;
    Guidance::new(&cfg)
}

fn wp(index: u32, x: f64, y: f64) -> Waypoint {
    Waypoint {
        index,
        x,
        y,
        depth: None,
    }
}

fn load(g: &mut Guidance, points: &[(f64, f64)]) {
    for (i, &(x, y)) in points.iter().enumerate() {
        let w = wp(i as u32, x, y);
        g.check_waypoint(&w).expect("a good waypoint");
        g.load(&w);
    }
}

fn follow(count: usize, looped: bool, from_here: bool) -> Follow {
    Follow {
        swim: anguilla_ipc::SwimParams::REST,
        count: count as u32,
        looped,
        from_here,
        resume: false,
    }
}

/// The kinematic robot: position, heading (rad).
struct Body {
    x: f64,
    y: f64,
    psi: f64,
}

impl Body {
    /// One period: the heading lags the asked one (τ = 1 s, at most
    /// 30 deg/s), the body moves at `U` plus the current.
    fn step(&mut self, asked_deg: f64, current: (f64, f64)) {
        let e = (asked_deg.to_radians() - self.psi + std::f64::consts::PI)
            .rem_euclid(std::f64::consts::TAU)
            - std::f64::consts::PI;
        let rate = e.clamp(-0.52, 0.52);
        self.psi += rate * DT;
        self.x += (U * self.psi.cos() + current.0) * DT;
        self.y += (U * self.psi.sin() + current.1) * DT;
    }
}

/// Follows the x axis from (0, 2) heading −90° in `current` for
/// `seconds`; the cross-track errors every period.
fn run_line(g: &mut Guidance, current: (f64, f64), seconds: f64) -> Vec<f64> {
    load(g, &[(0.0, 0.0), (1000.0, 0.0)]);
    g.check_follow(
        &follow(2, false, false),
        Some((0.0, 2.0)),
        PositionHealth::Fixed,
    )
    .expect("followed");
    g.start(&follow(2, false, false), (0.0, 2.0));
    let mut b = Body {
        x: 0.0,
        y: 2.0,
        psi: -std::f64::consts::FRAC_PI_2,
    };
    let mut out = Vec::new();
    for _ in 0..(seconds / DT) as usize {
        let s = g.steer(DT, (b.x, b.y), (0.0, 0.0), U).expect("following");
        b.step(s.heading, current);
        out.push(g.cross);
    }
    out
}

#[test]
fn integral_los_cancels_a_cross_current_that_plain_los_leaves_as_an_offset() {
    let current = (0.0, 0.1);
    let ilos = run_line(&mut guidance(0.25), current, 180.0);
    let los = run_line(&mut guidance(0.0), current, 180.0);
    let last = |v: &[f64]| v[v.len() - 1000..].iter().sum::<f64>() / 1000.0;
    let delta = Config::default().guidance.look_ahead;
    let expected = delta * 0.1 / (U * U - 0.01).sqrt();
    eprintln!(
        "steady cross-track: ILOS {:.4} m, LOS {:.4} m (Δ V/√(U²−V²) = {expected:.4} m)",
        last(&ilos),
        last(&los)
    );
    assert!(last(&ilos).abs() < 0.01, "ILOS offset {}", last(&ilos));
    // Pushed left, it settles left of the line by the law's offset.
    assert!(
        (last(&los) - expected).abs() < 0.02,
        "LOS offset {} for {expected}",
        last(&los)
    );
    // Within 0.1 m of the line within 30 s of starting 2 m off.
    let t = ilos.iter().rposition(|e| e.abs() >= 0.1).unwrap_or(0) as f64 * DT;
    assert!(t < 30.0, "last beyond 0.1 m at {t} s");
}

#[test]
fn waypoints_switch_by_radius_and_the_last_ends_the_path() {
    let mut g = guidance(0.25);
    load(&mut g, &[(0.0, 0.0), (5.0, 0.0), (5.0, 5.0)]);
    g.start(&follow(3, false, false), (0.0, 0.0));
    let mut b = Body {
        x: 0.0,
        y: 0.0,
        psi: 0.0,
    };
    let mut legs = vec![];
    for _ in 0..10_000 {
        match g.steer(DT, (b.x, b.y), (0.0, 0.0), U) {
            Some(s) => b.step(s.heading, (0.0, 0.0)),
            None => break,
        }
        let mut snap = GuideSnapshot::default();
        g.fill(&mut snap);
        if legs.last() != Some(&snap.leg) {
            legs.push(snap.leg);
        }
    }
    assert_eq!(g.state(), GuideState::Done);
    assert_eq!(legs, [1, 2]);
    assert!(
        (b.x - 5.0).hypot(b.y - 5.0) < 0.6,
        "ended at ({}, {})",
        b.x,
        b.y
    );
}

#[test]
fn a_looped_path_goes_round_and_a_goto_starts_from_here() {
    let mut g = guidance(0.25);
    load(&mut g, &[(3.0, 0.0), (3.0, 3.0), (0.0, 3.0)]);
    g.start(&follow(3, true, true), (0.0, 0.0));
    let mut b = Body {
        x: 0.0,
        y: 0.0,
        psi: 0.0,
    };
    let mut legs = vec![];
    for _ in 0..12_000 {
        let s = g
            .steer(DT, (b.x, b.y), (0.0, 0.0), U)
            .expect("a loop never ends");
        b.step(s.heading, (0.0, 0.0));
        let mut snap = GuideSnapshot::default();
        g.fill(&mut snap);
        assert_eq!(snap.waypoints, 3);
        if legs.last() != Some(&snap.leg) {
            legs.push(snap.leg);
        }
    }
    // From here to 0, then 1, 2, and round again from 0 (not from here).
    assert!(legs.len() >= 6, "{legs:?}");
    assert_eq!(legs[..6], [0, 1, 2, 0, 1, 2], "{legs:?}");
}

#[test]
fn bad_paths_are_refused_with_the_reason() {
    let mut cfg = Config::default();
    cfg.guidance.fence_radius = 10.0;
    let mut g = Guidance::new(&cfg);
    assert!(matches!(
        g.check_waypoint(&wp(1, 0.0, 0.0)),
        Err(PathRefusal::Order {
            got: 1,
            expected: 0
        })
    ));
    assert_eq!(
        g.check_waypoint(&wp(0, f64::NAN, 0.0)),
        Err(PathRefusal::NonFinite(0))
    );
    assert!(matches!(
        g.check_waypoint(&wp(0, 20.0, 0.0)),
        Err(PathRefusal::OutsideFence { index: 0, .. })
    ));
    let deep = Waypoint {
        depth: Some(50.0),
        ..wp(0, 1.0, 0.0)
    };
    assert!(matches!(
        g.check_waypoint(&deep),
        Err(PathRefusal::Depth { .. })
    ));
    load(&mut g, &[(1.0, 0.0)]);
    assert_eq!(
        g.check_waypoint(&wp(1, 1.0, 0.0)),
        Err(PathRefusal::SamePlace(1))
    );
    let at = Some((0.0, 0.0));
    assert_eq!(
        g.check_follow(&follow(2, false, false), at, PositionHealth::Fixed),
        Err(PathRefusal::Count { got: 2, loaded: 1 })
    );
    assert_eq!(
        g.check_follow(&follow(1, false, false), at, PositionHealth::Fixed),
        Err(PathRefusal::TooFew {
            loaded: 1,
            needed: 2
        })
    );
    assert_eq!(
        g.check_follow(&follow(1, false, true), at, PositionHealth::Lost),
        Err(PathRefusal::Position(PositionHealth::Lost))
    );
    assert!(matches!(
        g.check_follow(
            &follow(1, false, true),
            Some((11.0, 0.0)),
            PositionHealth::Fixed
        ),
        Err(PathRefusal::RobotOutsideFence { .. })
    ));
    assert_eq!(
        g.check_follow(&follow(1, false, true), None, PositionHealth::Fixed),
        Err(PathRefusal::NoSensor)
    );
    assert_eq!(
        g.check_follow(&follow(1, false, true), at, PositionHealth::DeadReckoning),
        Ok(())
    );
    // Every refusal says what was wrong in words.
    let text = PathRefusal::OutsideFence {
        index: 3,
        x: 20.0,
        y: 0.0,
    }
    .to_string();
    assert!(
        text.contains("waypoint 3") && text.contains("geofence"),
        "{text}"
    );
}

#[test]
fn leaving_the_fence_is_seen_once_on_the_way_out() {
    let mut cfg = Config::default();
    cfg.guidance.fence = vec![[-1.0, -1.0], [4.0, -1.0], [4.0, 4.0], [-1.0, 4.0]];
    cfg.validate().expect("a valid fence");
    let mut g = Guidance::new(&cfg);
    assert!(
        !g.left_fence(5.0, 0.0),
        "outside from the start: no crossing"
    );
    assert!(!g.left_fence(0.0, 0.0));
    assert!(!g.left_fence(3.9, 0.0));
    assert!(g.left_fence(4.1, 0.0));
    assert!(!g.left_fence(4.2, 0.0), "once");
}

/// The body's centre follows the leg, not the nose: with the nose on a
/// leg along +x and a current of 0.1 m/s to the left at 0.7 m/s, the
/// robot crabs right and its centre (0.5 m behind) is 0.5 × 0.1 / 0.7 m
/// left of the nose's track; no current, no correction; a forged NaN
/// current is no current.
#[test]
fn the_cross_track_error_is_the_centres() {
    let mut g = guidance(0.25);
    load(&mut g, &[(0.0, 0.0), (10.0, 0.0)]);
    g.start(&follow(2, false, false), (0.0, 0.0));
    let behind = Config::default().model.body().length / 2.0;
    g.steer(DT, (1.0, 0.0), (0.0, 0.1), 0.7).expect("following");
    assert!((g.cross - behind * 0.1 / 0.7).abs() < 1e-12, "{}", g.cross);
    // Along the leg, the centre is behind the nose by c cos(crab).
    let cos = (1.0 - (0.1f64 / 0.7).powi(2)).sqrt();
    assert!(
        (g.along - (1.0 - behind * cos)).abs() < 1e-12,
        "{}",
        g.along
    );
    g.steer(DT, (1.0, 0.0), (0.0, 0.0), 0.7).expect("following");
    assert_eq!(g.cross, 0.0);
    g.steer(DT, (1.0, 0.0), (f64::NAN, 0.1), 0.7)
        .expect("following");
    assert_eq!(g.cross, 0.0);
    // Too slow to crab: no correction.
    g.steer(DT, (1.0, 0.0), (0.0, 0.1), 0.05)
        .expect("following");
    assert_eq!(g.cross, 0.0);
}
