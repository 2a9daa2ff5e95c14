//! `/body`'s guide entity: the path being followed drawn in the world
//! frame, beside the body, with the position estimate's uncertainty.
//!
//! - **The legs.** A snapshot carries only the current leg
//!   ([`GuideSnapshot`]), so the scene remembers the legs it has seen, the
//!   last [`GUIDE_LEGS`] (the oldest forgotten first; a leg seen again, the
//!   same index and ends, as on a looped path, is kept once): past legs
//!   dim, the snapshot's leg bright. A guide that is off (no path since the
//!   daemon started: a daemon restarted under a live view) forgets them.
//! - **The cross-track error**, while following: the segment from the
//!   point the daemon measures it of (the body's centre, which follows
//!   the path: docs/autopilot.md) to its foot on the current leg's line,
//!   from the guide's `along_track_m` and `cross_track_m`.
//! - **The uncertainty**: a level disc at the estimated nose, its diameter
//!   twice `nav.position_sigma_m` (1σ each way), whenever there is an
//!   estimate (a head sensor's samples), whatever the position's health
//!   (dead-reckoned it shows how far the position may have drifted); its
//!   colour says the health.
//!
//! The guidance steers in the plane and the snapshot's legs have no depth:
//! everything is drawn at the estimate's depth (z = −`nav.depth_m`; 0
//! without an estimate), so the robot swims on its path in the 3D view and
//! the cross-track segment is level. Values that are not finite are not
//! drawn.

use std::collections::VecDeque;

use anguilla_ipc::{GuideSnapshot, GuideState, NavSnapshot, PositionHealth, StateSnapshot};

use crate::foxglove::{
    Color, CylinderPrimitive, GUIDE_LEGS, LINE_LIST, LinePrimitive, Pose, SceneEntity, Time,
    Vector3,
};

/// The uncertainty disc's thickness (m): flat, and still seen edge-on.
const DISC_THICKNESS: f64 = 0.01;

/// The past legs: dim yellow.
const PAST: Color = Color {
    r: 0.9,
    g: 0.8,
    b: 0.3,
    a: 0.35,
};
/// The current leg: bright yellow.
const CURRENT: Color = Color {
    r: 1.0,
    g: 0.85,
    b: 0.0,
    a: 1.0,
};
/// The cross-track error: red.
const CROSS_TRACK: Color = Color {
    r: 1.0,
    g: 0.15,
    b: 0.15,
    a: 1.0,
};

/// One leg of a path, its ends finite.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Leg {
    /// The waypoint it ends at.
    index: u16,
    /// Its start (x, y; m).
    from: [f32; 2],
    /// Its end (x, y; m).
    to: [f32; 2],
}

impl Leg {
    /// The snapshot's leg, if its ends are finite.
    fn of(g: &GuideSnapshot) -> Option<Self> {
        let leg = Self {
            index: g.leg,
            from: [g.from_x, g.from_y],
            to: [g.to_x, g.to_y],
        };
        leg.from
            .iter()
            .chain(&leg.to)
            .all(|v| v.is_finite())
            .then_some(leg)
    }

    /// Its ends at height `z`.
    fn ends(&self, z: f64) -> [Vector3; 2] {
        [self.from, self.to].map(|[x, y]| point([f64::from(x), f64::from(y)], z))
    }
}

fn point([x, y]: [f64; 2], z: f64) -> Vector3 {
    Vector3 { x, y, z }
}

/// The estimated nose (x, y, z up; m): where there is an estimate (a head
/// sensor's samples, as `/tf`'s head) and its position and depth are
/// finite.
fn estimate(n: &NavSnapshot) -> Option<[f64; 3]> {
    (n.samples > 0 && [n.x_m, n.y_m, n.depth_m].iter().all(|v| v.is_finite()))
        .then(|| [f64::from(n.x_m), f64::from(n.y_m), -f64::from(n.depth_m)])
}

/// The point the daemon measures the cross-track error of (the body's
/// centre) and its foot on the leg from `a` to `b`, from the guide's own
/// numbers: `along` the leg from `a`, `cross` to its left; `None` when
/// `a` and `b` coincide (no line) or a value is not finite. The TUI's
/// map draws the same segment with it.
pub fn centre_and_foot(
    a: [f64; 2],
    b: [f64; 2],
    along: f64,
    cross: f64,
) -> Option<([f64; 2], [f64; 2])> {
    let d = [b[0] - a[0], b[1] - a[1]];
    let l = d[0].hypot(d[1]);
    if !(l > 0.0 && l.is_finite()) {
        return None;
    }
    let u = [d[0] / l, d[1] / l];
    let f = [a[0] + along * u[0], a[1] + along * u[1]];
    let c = [f[0] - cross * u[1], f[1] + cross * u[0]];
    c.iter().chain(&f).all(|v| v.is_finite()).then_some((c, f))
}

fn line(points: Vec<Vector3>, thickness: f64, color: Color) -> LinePrimitive {
    LinePrimitive {
        line_type: LINE_LIST,
        pose: Pose::at(point([0.0, 0.0], 0.0)),
        thickness,
        scale_invariant: true,
        points,
        color,
        colors: [],
        indices: [],
    }
}

/// The disc's colour by the position's health: blue fixed, yellow stale,
/// red lost, grey dead-reckoned or waiting for a first fix; translucent.
fn disc_color(n: &NavSnapshot) -> Color {
    let (r, g, b) = match n.position_state() {
        Some(PositionHealth::Fixed) => (0.2, 0.55, 1.0),
        Some(PositionHealth::Stale) => (1.0, 0.8, 0.1),
        Some(PositionHealth::Lost) => (1.0, 0.2, 0.2),
        _ => (0.6, 0.6, 0.6),
    };
    Color { r, g, b, a: 0.3 }
}

/// What the guide entity keeps between snapshots: the legs seen, and
/// whether it drew anything yet.
#[derive(Debug, Clone)]
pub(crate) struct GuideTrail {
    legs: VecDeque<Leg>,
    drawn: bool,
}

impl GuideTrail {
    pub(crate) fn new() -> Self {
        Self {
            legs: VecDeque::with_capacity(GUIDE_LEGS),
            drawn: false,
        }
    }

    /// The guide entity at `s` (stamped `ns`): `None` until there is
    /// something to draw; from then on one every snapshot, empty when
    /// there is nothing (it replaces the one drawn before, whose lifetime
    /// is until replaced).
    pub(crate) fn entity(&mut self, s: &StateSnapshot, ns: u64) -> Option<SceneEntity> {
        let state = s.guide.guide_state();
        let current = match state {
            Some(GuideState::Off) => {
                self.legs.clear();
                None
            }
            // A state this anguilla does not know: nothing it can vouch for.
            None => None,
            Some(_) => Leg::of(&s.guide),
        };
        if let Some(leg) = current
            && !self.legs.contains(&leg)
        {
            if self.legs.len() == GUIDE_LEGS {
                self.legs.pop_front();
            }
            self.legs.push_back(leg);
        }
        let nose = estimate(&s.nav);
        let z = nose.map_or(0.0, |p| p[2]);
        let mut lines = Vec::new();
        let past: Vec<Vector3> = self
            .legs
            .iter()
            .filter(|l| Some(**l) != current)
            .flat_map(|l| l.ends(z))
            .collect();
        if !past.is_empty() {
            lines.push(line(past, 2.0, PAST));
        }
        if let Some(leg) = current {
            lines.push(line(leg.ends(z).into(), 4.0, CURRENT));
            let [a, b] = [leg.from, leg.to].map(|[x, y]| [f64::from(x), f64::from(y)]);
            let (along, cross) = (
                f64::from(s.guide.along_track_m),
                f64::from(s.guide.cross_track_m),
            );
            if state == Some(GuideState::Following)
                && let Some([_, _, z]) = nose
                && let Some((c, f)) = centre_and_foot(a, b, along, cross)
            {
                lines.push(line(vec![point(c, z), point(f, z)], 2.0, CROSS_TRACK));
            }
        }
        let sigma = f64::from(s.nav.position_sigma_m);
        let cylinders = match nose {
            Some([x, y, z]) if sigma.is_finite() && sigma > 0.0 => vec![CylinderPrimitive {
                pose: Pose::at(point([x, y], z)),
                size: point([2.0 * sigma, 2.0 * sigma], DISC_THICKNESS),
                bottom_scale: 1.0,
                top_scale: 1.0,
                color: disc_color(&s.nav),
            }],
            _ => Vec::new(),
        };
        self.drawn |= !lines.is_empty() || !cylinders.is_empty();
        self.drawn.then_some(SceneEntity {
            timestamp: Time::from_ns(ns),
            frame_id: "world",
            id: "guide",
            lifetime: Time { sec: 0, nsec: 0 },
            frame_locked: false,
            metadata: [],
            arrows: [],
            cubes: [],
            spheres: Vec::new(),
            cylinders,
            lines,
            triangles: [],
            texts: [],
            models: [],
        })
    }
}

#[cfg(test)]
mod tests {
    use serde_json::Value;

    use super::*;
    use crate::schema::{all, check};
    use crate::{Scene, TOPICS};

    /// `/body` and `/tf` of each snapshot, every message checked against
    /// its channel's schema and free of `null` (a float that was not
    /// finite).
    fn body(scene: &mut Scene, s: &StateSnapshot) -> (Value, Value) {
        let schemas = all();
        let (mut body, mut tf) = (Value::Null, Value::Null);
        for (ch, v) in scene.messages(s) {
            if let Err(e) = check(&schemas[ch].1, &v) {
                panic!("{}: {e}\n{v}", TOPICS[ch]);
            }
            match ch {
                3 => tf = v,
                4 => body = v,
                _ => continue,
            }
        }
        for v in [&body, &tf] {
            assert!(!v.to_string().contains("null"), "{v}");
        }
        (body, tf)
    }

    fn guide(body: &Value) -> Option<&Value> {
        let e = body["entities"].as_array().unwrap();
        assert_eq!(e[0]["id"], "body");
        assert!(e.len() <= 2);
        e.get(1).inspect(|g| {
            assert_eq!(
                (&g["id"], &g["frame_id"]),
                (&"guide".into(), &"world".into())
            );
        })
    }

    fn xyz(p: &Value) -> [f64; 3] {
        ["x", "y", "z"].map(|k| p[k].as_f64().unwrap())
    }

    fn points(line: &Value) -> Vec<[f64; 3]> {
        line["points"].as_array().unwrap().iter().map(xyz).collect()
    }

    /// A snapshot following leg `leg` from `from` to `to`, the estimated
    /// nose at `nose` (x, y) 1.5 m deep, σ 0.4 m.
    fn following(leg: u16, from: [f32; 2], to: [f32; 2], nose: [f32; 2]) -> StateSnapshot {
        let mut s = StateSnapshot {
            time_ns: 1_000_000 * u64::from(leg),
            ..StateSnapshot::default()
        };
        s.nav.samples = 10;
        (s.nav.x_m, s.nav.y_m, s.nav.depth_m) = (nose[0], nose[1], 1.5);
        s.nav.position_sigma_m = 0.4;
        s.nav.position_health = PositionHealth::Fixed as u8;
        let g = &mut s.guide;
        (g.state, g.leg, g.waypoints) = (GuideState::Following as u8, leg, 3);
        [g.from_x, g.from_y, g.to_x, g.to_y] = [from[0], from[1], to[0], to[1]];
        // The daemon's own numbers for the nose: its offset from the
        // leg's line, positive left.
        let d = [f64::from(to[0] - from[0]), f64::from(to[1] - from[1])];
        let p = [f64::from(nose[0] - from[0]), f64::from(nose[1] - from[1])];
        let l = d[0].hypot(d[1]);
        g.cross_track_m = ((d[0] * p[1] - d[1] * p[0]) / l) as f32;
        g.along_track_m = ((d[0] * p[0] + d[1] * p[1]) / l) as f32;
        s
    }

    #[test]
    fn the_legs_seen_the_current_one_bright_and_the_cross_track_to_its_foot() {
        let mut scene = Scene::new(4);
        let leg1 = following(1, [0.0, 0.0], [10.0, 0.0], [4.0, 0.5]);
        let (b, _) = body(&mut scene, &leg1);
        let g = guide(&b).expect("a guide while following");
        let lines = g["lines"].as_array().unwrap();
        assert_eq!(
            lines.len(),
            2,
            "no past legs yet: the leg and the cross-track"
        );
        assert_eq!(
            points(&lines[0]),
            [[0.0, 0.0, -1.5], [10.0, 0.0, -1.5]],
            "at the estimate's depth"
        );
        // Leg 2 turns left at (10, 0), the nose 1.25 m right of it.
        let leg2 = following(2, [10.0, 0.0], [10.0, 8.0], [11.25, 3.0]);
        let (b, _) = body(&mut scene, &leg2);
        let g = guide(&b).unwrap();
        let lines = g["lines"].as_array().unwrap();
        assert_eq!(
            lines.len(),
            3,
            "past legs, the current one, the cross-track"
        );
        let (past, current, cross) = (&lines[0], &lines[1], &lines[2]);
        assert_eq!(points(past), [[0.0, 0.0, -1.5], [10.0, 0.0, -1.5]]);
        assert_eq!(points(current), [[10.0, 0.0, -1.5], [10.0, 8.0, -1.5]]);
        assert_ne!(past["color"], current["color"]);
        assert!(current["color"]["a"].as_f64() > past["color"]["a"].as_f64());
        assert!(current["thickness"].as_f64() > past["thickness"].as_f64());
        for l in lines {
            assert_eq!(l["type"], 2, "LINE_LIST");
            assert_eq!(l["points"].as_array().unwrap().len() % 2, 0);
        }
        let [p, f] = <[[f64; 3]; 2]>::try_from(points(cross)).unwrap();
        assert_eq!(p, [11.25, 3.0, -1.5], "from the estimated nose");
        // Its end on the leg's line (x = 10), square to it: the foot.
        assert!(
            (f[0] - 10.0).abs() < 1e-9 && (f[1] - 3.0).abs() < 1e-9,
            "{f:?}"
        );
        let length = (p[0] - f[0]).hypot(p[1] - f[1]);
        let cross_track = f64::from(leg2.guide.cross_track_m);
        assert!(
            (cross_track + 1.25).abs() < 1e-6,
            "right of the leg: negative"
        );
        // f32 snapshot values against f64 geometry: within 1e-6 m.
        assert!((length - cross_track.abs()).abs() < 1e-6, "{length}");
        // A leg seen again (a looped path) is kept once; leg 1 is current
        // again and drawn bright, not also dim.
        let (b, _) = body(&mut scene, &leg1);
        let lines = guide(&b).unwrap()["lines"].as_array().unwrap().clone();
        assert_eq!(points(&lines[0]), points(current));
        assert_eq!(points(&lines[1]), [[0.0, 0.0, -1.5], [10.0, 0.0, -1.5]]);
        // Done: the last leg still drawn, no cross-track.
        let mut done = leg2;
        done.guide.state = GuideState::Done as u8;
        let (b, _) = body(&mut scene, &done);
        let lines = guide(&b).unwrap()["lines"].as_array().unwrap().clone();
        assert_eq!(lines.len(), 2);
        assert_eq!(lines[1]["color"], current["color"]);
    }

    #[test]
    fn the_legs_remembered_are_bounded_and_forgotten_when_the_guide_is_off() {
        let mut scene = Scene::new(4);
        for k in 0..3 * GUIDE_LEGS as u16 {
            let x = f32::from(k);
            let (b, _) = body(
                &mut scene,
                &following(k, [x, 0.0], [x + 1.0, 0.0], [x, 0.0]),
            );
            let past = crate::to_json(&PAST);
            let lines = guide(&b).unwrap()["lines"].as_array().unwrap().clone();
            let n: usize = lines
                .iter()
                .filter(|l| l["color"] == past)
                .map(|l| points(l).len())
                .sum();
            assert_eq!(n, 2 * usize::from(k).min(GUIDE_LEGS - 1), "at leg {k}");
        }
        let mut off = following(0, [0.0; 2], [1.0, 0.0], [0.0; 2]);
        off.guide.state = GuideState::Off as u8;
        let (b, _) = body(&mut scene, &off);
        let lines = guide(&b).unwrap()["lines"].as_array().unwrap().clone();
        assert!(lines.is_empty(), "{lines:?}");
    }

    #[test]
    fn no_guide_without_a_path_or_an_estimate_and_the_disc_is_two_sigma() {
        let mut scene = Scene::new(4);
        let mut s = StateSnapshot::default();
        // Off, no head sensor: nothing to draw, no entity.
        for k in 0..3 {
            s.time_ns = k;
            s.nav.x_m = 2.0;
            s.nav.position_sigma_m = 0.5;
            let (b, _) = body(&mut scene, &s);
            assert!(guide(&b).is_none(), "{b}");
        }
        // An estimate: the disc alone, 2σ across, at the nose, level.
        s.nav.samples = 1;
        (s.nav.y_m, s.nav.depth_m) = (-3.0, 0.75);
        let (b, _) = body(&mut scene, &s);
        let g = guide(&b).expect("the uncertainty");
        assert!(g["lines"].as_array().unwrap().is_empty());
        let disc = &g["cylinders"][0];
        assert_eq!(xyz(&disc["pose"]["position"]), [2.0, -3.0, -0.75]);
        assert_eq!(xyz(&disc["pose"]["orientation"])[..], [0.0; 3]);
        let size = xyz(&disc["size"]);
        assert_eq!([size[0], size[1]], [1.0, 1.0], "diameter 2 × 0.5 m");
        assert!(size[2] < 0.1, "flat: {size:?}");
        assert!(disc["color"]["a"].as_f64().unwrap() < 1.0, "translucent");
        // The estimate gone: an empty guide replaces the disc drawn.
        s.nav.samples = 0;
        let (b, _) = body(&mut scene, &s);
        let g = guide(&b).expect("an empty guide, replacing the disc");
        assert!(g["cylinders"].as_array().unwrap().is_empty());
        assert!(g["lines"].as_array().unwrap().is_empty());
    }

    #[test]
    fn values_that_are_not_finite_are_not_drawn() {
        let mut scene = Scene::new(4);
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            // Each one value forged in an otherwise good snapshot.
            for k in 0..7 {
                let mut s = following(2, [10.0, 0.0], [10.0, 8.0], [11.25, 3.0]);
                let g = &mut s.guide;
                let n = &mut s.nav;
                *[
                    &mut g.from_x,
                    &mut g.to_y,
                    &mut n.x_m,
                    &mut n.y_m,
                    &mut n.depth_m,
                    &mut n.position_sigma_m,
                    &mut g.cross_track_m,
                ][k] = bad;
                let (b, _) = body(&mut scene, &s);
                let g = guide(&b).unwrap();
                let has = |c: Color| {
                    let c = crate::to_json(&c);
                    g["lines"]
                        .as_array()
                        .unwrap()
                        .iter()
                        .any(|l| l["color"] == c)
                };
                let disc = !g["cylinders"].as_array().unwrap().is_empty();
                let drawn = (has(CURRENT), has(CROSS_TRACK), disc);
                let want = match k {
                    // A leg's end: neither the leg nor its cross-track.
                    0 | 1 => (false, false, true),
                    // The nose or its depth: no cross-track, no disc.
                    2..=4 => (true, false, false),
                    // σ: no disc.
                    5 => (true, true, false),
                    // The cross-track error: not drawn.
                    _ => (true, false, true),
                };
                assert_eq!(drawn, want, "value {k} {bad}: {g}");
            }
        }
        // A leg of no length: no line to be square to.
        let s = following(3, [1.0, 1.0], [1.0, 1.0], [2.0, 2.0]);
        let (b, _) = body(&mut scene, &s);
        let lines = guide(&b).unwrap()["lines"].as_array().unwrap().clone();
        let cross = crate::to_json(&CROSS_TRACK);
        assert!(lines.iter().all(|l| l["color"] != cross), "{lines:?}");
    }

    /// The segment starts where the daemon measures the error, the
    /// body's centre, not at the nose: a crabbing robot's nose is off the
    /// leg while its centre is on it.
    #[test]
    fn the_cross_track_is_drawn_from_the_point_it_is_of() {
        let mut scene = Scene::new(12);
        let mut s = following(2, [10.0, 0.0], [10.0, 8.0], [11.25, 3.0]);
        s.guide.cross_track_m = -1.18;
        let (b, _) = body(&mut scene, &s);
        let g = guide(&b).unwrap();
        let cross = crate::to_json(&CROSS_TRACK);
        let seg = g["lines"]
            .as_array()
            .unwrap()
            .iter()
            .find(|l| l["color"] == cross)
            .expect("a cross-track segment");
        let [c, f] = <[[f64; 3]; 2]>::try_from(points(seg)).unwrap();
        assert!(
            (c[0] - 11.18).abs() < 1e-5 && (c[1] - 3.0).abs() < 1e-5,
            "{c:?}"
        );
        assert!(
            (f[0] - 10.0).abs() < 1e-5 && (f[1] - 3.0).abs() < 1e-5,
            "{f:?}"
        );
    }

    /// The centre from the guide's along and cross, left of the leg, and
    /// its foot on it; nothing for a leg of no length or a NaN.
    #[test]
    fn the_centre_and_its_foot_come_from_the_guides_numbers() {
        let (a, b) = ([0.0, 0.0], [10.0, 0.0]);
        assert_eq!(
            centre_and_foot(a, b, 3.0, 4.0),
            Some(([3.0, 4.0], [3.0, 0.0]))
        );
        let ([cx, cy], [fx, fy]) =
            centre_and_foot(a, [2.0, 2.0], 2f64.sqrt(), 2f64.sqrt()).unwrap();
        let near = |a: f64, b: f64| (a - b).abs() < 1e-12;
        assert!(near(fx, 1.0) && near(fy, 1.0) && near(cx, 0.0) && near(cy, 2.0));
        assert_eq!(centre_and_foot([1.0, 1.0], [1.0, 1.0], 1.0, 1.0), None);
        assert_eq!(centre_and_foot(a, b, f64::NAN, 1.0), None);
    }
}
