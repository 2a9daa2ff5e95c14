//! The top view's map: the path, the position estimate with its σ, the
//! track swum and the cross-track error, seen from above in the
//! estimate's local frame (x to the right, y up, headings
//! counter-clockwise from x as `nav.heading_deg`).
//!
//! A [`Map`] keeps what one snapshot does not carry: the legs the daemon
//! has been seen to follow, the estimate's recent track, and the whole
//! path when the tool was given it (`teleop --path`).

use anguilla_ipc::{GuideState, PositionHealth, StateSnapshot};
use ratatui::Frame;
use ratatui::layout::Rect;
use ratatui::style::{Color, Style};
use ratatui::symbols::Marker;
use ratatui::text::Span;
use ratatui::widgets::Block;
use ratatui::widgets::canvas::{Canvas, Circle, Line as CanvasLine, Points};

/// The most legs a map remembers (the oldest are forgotten).
pub const MAX_LEGS: usize = 64;
/// The most points of the track a map remembers.
pub const MAX_TRACK: usize = 600;
/// The track keeps a point once the estimate moved this far (m).
pub const TRACK_STEP_M: f64 = 0.05;

/// A leg: from, to (m).
type Leg = ((f64, f64), (f64, f64));

/// What the map remembers between snapshots.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Map {
    /// The whole path, when the tool knows it (its waypoints, in order).
    path: Vec<(f64, f64)>,
    /// Whether the path loops back to its first waypoint.
    looped: bool,
    /// The legs seen followed, oldest first.
    legs: Vec<Leg>,
    /// The estimate's track, oldest first.
    track: Vec<(f64, f64)>,
    last_ns: Option<u64>,
}

fn finite(v: f32) -> Option<f64> {
    v.is_finite().then_some(f64::from(v))
}

/// Whether the snapshot's estimate has a position (a position sensor's
/// fixes, not dead reckoning alone).
fn positioned(s: &StateSnapshot) -> bool {
    matches!(
        s.nav.position_state(),
        Some(PositionHealth::Fixed | PositionHealth::Stale | PositionHealth::Lost)
    )
}

/// Whether a path is, or was, followed.
fn guided(s: &StateSnapshot) -> bool {
    !matches!(s.guide.guide_state(), Some(GuideState::Off))
}

impl Map {
    /// A map that draws the whole of `path` (`teleop --path`).
    pub fn with_path(path: &[(f64, f64)], looped: bool) -> Self {
        Self {
            path: path.to_vec(),
            looped,
            ..Self::default()
        }
    }

    /// Draws `path` (the waypoints sent, in the estimate's frame) from
    /// now on.
    pub fn set_path(&mut self, path: &[(f64, f64)], looped: bool) {
        self.path = path.to_vec();
        self.looped = looped;
    }

    /// Takes in a snapshot (one already seen, by its time, is skipped).
    pub fn update(&mut self, s: &StateSnapshot) {
        if self.last_ns == Some(s.time_ns) {
            return;
        }
        self.last_ns = Some(s.time_ns);
        let g = &s.guide;
        if guided(s)
            && let (Some(fx), Some(fy), Some(tx), Some(ty)) = (
                finite(g.from_x),
                finite(g.from_y),
                finite(g.to_x),
                finite(g.to_y),
            )
        {
            let leg = ((fx, fy), (tx, ty));
            // Each leg once (a looped path comes round to the same ones).
            if !self.legs.contains(&leg) {
                if self.legs.len() == MAX_LEGS {
                    self.legs.remove(0);
                }
                self.legs.push(leg);
            }
        }
        if (guided(s) || positioned(s))
            && let (Some(x), Some(y)) = (finite(s.nav.x_m), finite(s.nav.y_m))
        {
            let far = self
                .track
                .last()
                .is_none_or(|&(lx, ly)| (x - lx).hypot(y - ly) >= TRACK_STEP_M);
            if far {
                if self.track.len() == MAX_TRACK {
                    self.track.remove(0);
                }
                self.track.push((x, y));
            }
        }
    }

    /// Whether the map has anything to draw for `s`: a path followed (or
    /// known), or a position from fixes.
    pub fn shown(&self, s: Option<&StateSnapshot>) -> bool {
        !self.path.is_empty() || s.is_some_and(|s| guided(s) || positioned(s))
    }

    /// The legs seen followed, oldest first.
    pub fn legs(&self) -> usize {
        self.legs.len()
    }

    /// The points of the track.
    pub fn track(&self) -> &[(f64, f64)] {
        &self.track
    }

    /// The area to draw, ((x min, x max), (y min, y max)) in metres: every
    /// point of the path, the legs, the track and the estimate's σ circle
    /// with a margin, widened so that a metre is as long across as up on
    /// a canvas of `cols` × `rows` cells (a cell is about twice as tall as
    /// it is wide).
    pub fn bounds(&self, s: Option<&StateSnapshot>, cols: u16, rows: u16) -> [[f64; 2]; 2] {
        let mut pts: Vec<(f64, f64)> = self.path.clone();
        for &(a, b) in &self.legs {
            pts.extend([a, b]);
        }
        pts.extend(self.track.iter().copied());
        if let Some(s) = s
            && let (Some(x), Some(y)) = (finite(s.nav.x_m), finite(s.nav.y_m))
        {
            let r = finite(s.nav.position_sigma_m)
                .unwrap_or(0.0)
                .clamp(0.0, 1e3);
            pts.extend([(x - r, y - r), (x + r, y + r)]);
        }
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for (x, y) in pts {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
        if x0 > x1 {
            (x0, x1, y0, y1) = (0.0, 0.0, 0.0, 0.0);
        }
        // A margin, and at least 2 m across.
        let m = 0.1 * (x1 - x0).max(y1 - y0) + 0.5;
        let (mut w, mut h) = (x1 - x0 + 2.0 * m, y1 - y0 + 2.0 * m);
        let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
        // Metres per unit of screen: a column is half a row.
        let (sw, sh) = (f64::from(cols.max(1)) * 0.5, f64::from(rows.max(1)));
        if w / sw > h / sh {
            h = w / sw * sh;
        } else {
            w = h / sh * sw;
        }
        [[cx - w / 2.0, cx + w / 2.0], [cy - h / 2.0, cy + h / 2.0]]
    }
}

/// The title of the map: what is drawn, and the cross-track error while
/// a path is followed.
pub fn map_title(s: Option<&StateSnapshot>) -> String {
    match s {
        Some(s)
            if s.guide.guide_state() == Some(GuideState::Following)
                && s.guide.cross_track_m.is_finite() =>
        {
            format!(
                " top view (map): cross-track {:+.2} m ",
                s.guide.cross_track_m
            )
        }
        _ => " top view (map): path, track, estimate ±σ ".to_string(),
    }
}

/// Draws the map of `s` in `area`.
pub fn render_map(frame: &mut Frame, area: Rect, map: &Map, s: Option<&StateSnapshot>) {
    let cols = area.width.saturating_sub(2);
    let rows = area.height.saturating_sub(2);
    let [xb, yb] = map.bounds(s, cols, rows);
    let span = (xb[1] - xb[0]).max(yb[1] - yb[0]);
    let mut path: Vec<Leg> = map.path.windows(2).map(|w| (w[0], w[1])).collect();
    if map.looped && map.path.len() > 2 {
        path.push((map.path[map.path.len() - 1], map.path[0]));
    }
    let legs = map.legs.clone();
    let track = map.track.clone();
    let s = s.copied();
    let canvas = Canvas::default()
        .block(Block::bordered().title(map_title(s.as_ref())))
        .marker(Marker::Braille)
        .x_bounds(xb)
        .y_bounds(yb)
        .paint(move |ctx| {
            let seg = |ctx: &mut ratatui::widgets::canvas::Context, (a, b): Leg, color| {
                ctx.draw(&CanvasLine::new(a.0, a.1, b.0, b.1, color));
            };
            for &l in &path {
                seg(ctx, l, Color::DarkGray);
            }
            for &l in &legs {
                seg(ctx, l, Color::Gray);
            }
            ctx.draw(&Points {
                coords: &track,
                color: Color::Blue,
            });
            let Some(s) = s else { return };
            let (Some(x), Some(y)) = (finite(s.nav.x_m), finite(s.nav.y_m)) else {
                return;
            };
            let following = s.guide.guide_state() == Some(GuideState::Following);
            let g = &s.guide;
            let current = [g.from_x, g.from_y, g.to_x, g.to_y].map(finite);
            if following && let [Some(fx), Some(fy), Some(tx), Some(ty)] = current {
                let leg = ((fx, fy), (tx, ty));
                seg(ctx, leg, Color::Cyan);
                let (along, cross) = (
                    f64::from(s.guide.along_track_m),
                    f64::from(s.guide.cross_track_m),
                );
                let ends = [[leg.0.0, leg.0.1], [leg.1.0, leg.1.1]];
                if let Some(([cx, cy], [fx, fy])) =
                    anguilla_view::centre_and_foot(ends[0], ends[1], along, cross)
                {
                    seg(ctx, ((cx, cy), (fx, fy)), Color::Red);
                }
            }
            let sigma = finite(s.nav.position_sigma_m).unwrap_or(0.0);
            if positioned(&s) && sigma > 0.0 {
                ctx.draw(&Circle {
                    x,
                    y,
                    radius: sigma,
                    color: Color::Yellow,
                });
            }
            if let Some(h) = finite(s.nav.heading_deg) {
                let (sin, cos) = h.to_radians().sin_cos();
                let l = 0.08 * span;
                ctx.draw(&CanvasLine::new(
                    x,
                    y,
                    x + l * cos,
                    y + l * sin,
                    Color::LightGreen,
                ));
            }
            ctx.print(
                x,
                y,
                Span::styled("●", Style::default().fg(Color::LightGreen)),
            );
        });
    frame.render_widget(canvas, area);
}

#[cfg(test)]
mod tests {
    use super::*;
    use ratatui::Terminal;
    use ratatui::backend::TestBackend;

    fn following(x: f32, y: f32, e: f32) -> StateSnapshot {
        let mut s = StateSnapshot {
            time_ns: 1,
            ..StateSnapshot::default()
        };
        s.guide.state = GuideState::Following as u8;
        s.guide.to_x = 10.0;
        s.guide.cross_track_m = e;
        s.guide.along_track_m = x;
        s.nav.x_m = x;
        s.nav.y_m = y;
        s.nav.position_health = PositionHealth::Fixed as u8;
        s.nav.position_sigma_m = 0.5;
        s
    }

    /// Legs are remembered once each, in order, and forgotten oldest
    /// first; the track keeps a point each 5 cm and at most MAX_TRACK.
    #[test]
    fn the_map_remembers_legs_and_a_bounded_track() {
        let mut m = Map::default();
        let mut s = following(0.0, 1.0, 1.0);
        assert!(!m.shown(None));
        assert!(m.shown(Some(&s)));
        m.update(&s);
        m.update(&s);
        assert_eq!((m.legs(), m.track().len()), (1, 1));
        s.time_ns = 2;
        s.nav.x_m = 0.01;
        m.update(&s);
        assert_eq!(m.track().len(), 1, "1 cm is not a step");
        for k in 0..(MAX_LEGS + 10) {
            s.time_ns += 1;
            s.guide.from_x = k as f32;
            s.guide.to_x = k as f32 + 1.0;
            s.nav.x_m = k as f32;
            m.update(&s);
        }
        assert_eq!(m.legs(), MAX_LEGS);
        assert_eq!(m.legs.last().unwrap().1, ((MAX_LEGS + 10) as f64, 0.0));
        // A looped path's next lap: the same legs, not kept again.
        s.time_ns += 1;
        (s.guide.from_x, s.guide.to_x) = (20.0, 21.0);
        m.update(&s);
        assert_eq!(m.legs(), MAX_LEGS);
        assert_eq!(m.legs.last().unwrap().1, ((MAX_LEGS + 10) as f64, 0.0));
        for k in 0..(MAX_TRACK + 10) {
            s.time_ns += 1;
            s.nav.y_m = k as f32;
            m.update(&s);
        }
        assert_eq!(m.track().len(), MAX_TRACK);
        // Off and dead reckoning: nothing to show, nothing kept; a forged
        // NaN is not a point.
        let mut off = StateSnapshot::default();
        off.nav.x_m = f32::NAN;
        assert!(!Map::default().shown(Some(&off)));
        let mut m = Map::default();
        off.guide.state = GuideState::Following as u8;
        off.time_ns = 1;
        m.update(&off);
        assert!(m.track().is_empty());
    }

    /// The bounds hold every point with a margin, and a metre is as long
    /// across as up.
    #[test]
    fn the_bounds_hold_the_path_and_keep_metres_square() {
        let m = Map::with_path(&[(0.0, 0.0), (20.0, 0.0), (20.0, 5.0)], false);
        let s = following(3.0, -2.0, -2.0);
        let [xb, yb] = m.bounds(Some(&s), 60, 10);
        assert!(xb[0] < 0.0 && xb[1] > 20.0 && yb[0] < -2.5 && yb[1] > 5.0);
        let per_col = (xb[1] - xb[0]) / 60.0;
        let per_row = (yb[1] - yb[0]) / 10.0;
        assert!(
            (per_row / per_col - 2.0).abs() < 1e-9,
            "{per_col} {per_row}"
        );
        let [xb, yb] = Map::default().bounds(None, 40, 40);
        assert!(xb[1] - xb[0] >= 1.0 && yb[1] - yb[0] >= 1.0);
    }

    fn cells(m: &Map, s: &StateSnapshot) -> (String, Vec<Vec<char>>) {
        let mut t = Terminal::new(TestBackend::new(50, 12)).unwrap();
        t.draw(|f| render_map(f, f.area(), m, Some(s))).unwrap();
        let b = t.backend().buffer();
        let rows: Vec<Vec<char>> = (0..b.area.height)
            .map(|y| {
                (0..b.area.width)
                    .map(|x| b[(x, y)].symbol().chars().next().unwrap_or(' '))
                    .collect()
            })
            .collect();
        let text = rows
            .iter()
            .map(|r| r.iter().collect::<String>())
            .collect::<Vec<_>>()
            .join("\n");
        (text, rows)
    }

    /// Following a leg along y = 0 from 2 m to its left: the leg is a
    /// row of dots below the robot, the cross-track segment joins them,
    /// the title says the error.
    #[test]
    fn the_map_draws_the_leg_the_robot_and_the_cross_track_error() {
        let mut m = Map::default();
        let s = following(5.0, 2.0, 2.0);
        m.update(&s);
        let (text, rows) = cells(&m, &s);
        assert!(text.contains("top view (map)"), "{text}");
        assert!(text.contains("cross-track +2.00 m"), "{text}");
        let robot = rows
            .iter()
            .position(|r| r.contains(&'●'))
            .unwrap_or_else(|| panic!("no robot in\n{text}"));
        let col = rows[robot].iter().position(|&c| c == '●').unwrap();
        // The leg: the row with the most drawn cells, below the robot.
        let drawn = |r: &Vec<char>| r[1..r.len() - 1].iter().filter(|&&c| c != ' ').count();
        let leg = (1..rows.len() - 1)
            .max_by_key(|&i| drawn(&rows[i]))
            .unwrap();
        assert!(
            leg > robot,
            "the leg (row {leg}) is below the robot (row {robot})\n{text}"
        );
        assert!(drawn(&rows[leg]) > 20, "{text}");
        // The cross-track segment: drawn cells in the robot's column (the
        // marker's cell and the dots' may differ by one) between them.
        for r in rows.iter().take(leg).skip(robot + 1) {
            assert!(
                r[col - 1..=col + 1].iter().any(|&c| c != ' '),
                "the segment is broken in\n{text}"
            );
        }
    }

    /// The title has no error once the path is done; a forged NaN
    /// position draws no robot and does not panic.
    #[test]
    fn a_done_path_has_no_error_and_a_nan_position_no_robot() {
        let mut s = following(1.0, 1.0, 0.5);
        s.guide.state = GuideState::Done as u8;
        assert!(!map_title(Some(&s)).contains("cross-track"));
        s.nav.x_m = f32::NAN;
        s.nav.position_sigma_m = f32::INFINITY;
        let mut m = Map::default();
        m.update(&s);
        let (text, _) = cells(&m, &s);
        assert!(!text.contains('●'), "{text}");
    }

    /// The whole teleop view, at its smallest: the map takes the side
    /// view's and the torques' place while a path is followed, and gives
    /// it back without a path or a position.
    #[test]
    fn the_view_shows_the_map_only_while_it_has_something_to_draw() {
        let intent = crate::app::Intent::new(crate::app::Limits::default());
        let draw = |s: &StateSnapshot, m: &Map| {
            let v = crate::view::ViewModel {
                title: "anguilla teleop",
                state: Some(s),
                me: None,
                intent: Some(&intent),
                refused: None,
                history: None,
                map: Some(m),
                status: "",
            };
            let mut t = Terminal::new(TestBackend::new(80, 24)).unwrap();
            t.draw(|f| crate::view::render(f, &v)).unwrap();
            let b = t.backend().buffer();
            (0..b.area.height)
                .map(|y| {
                    (0..b.area.width)
                        .map(|x| b[(x, y)].symbol().to_string())
                        .collect::<String>()
                })
                .collect::<Vec<_>>()
                .join("\n")
        };
        let mut s = following(5.0, 2.0, 2.0);
        s.nav.sensor = anguilla_ipc::SensorHealth::Ok as u8;
        s.nav.samples = 10;
        let mut m = Map::default();
        m.update(&s);
        let text = draw(&s, &m);
        assert!(
            text.contains("top view (map): cross-track +2.00 m"),
            "{text}"
        );
        // The position line wraps at 80 columns; the header grows and the
        // path line after it is still there.
        assert!(
            text.contains("model speed") && text.contains("path following"),
            "{text}"
        );
        assert!(!text.contains("side view"), "{text}");
        let text = draw(&StateSnapshot::default(), &Map::default());
        assert!(!text.contains("top view (map)"), "{text}");
        assert!(text.contains("side view (pitch)"), "{text}");
        // A path given to the tool is drawn before it is followed.
        let m = Map::with_path(&[(0.0, 0.0), (4.0, 0.0)], false);
        assert!(draw(&StateSnapshot::default(), &m).contains("top view (map)"));
    }

    /// docs/autopilot.md's picture of the map: the lawn-mower's second
    /// leg, the robot 0.4 m off it after the first.
    #[test]
    fn docs_map_screenshot_is_current() {
        let path = [
            (0.0, 0.0),
            (30.0, 0.0),
            (30.0, 25.0),
            (0.0, 25.0),
            (0.0, 0.0),
        ];
        let mut m = Map::with_path(&path, false);
        let mut s = crate::view::sample_snapshot();
        s.guide.state = GuideState::Following as u8;
        s.guide.waypoints = 5;
        s.nav.position_health = PositionHealth::Fixed as u8;
        s.nav.position_fixes = 40;
        s.nav.position_sigma_m = 0.8;
        (s.nav.current_x, s.nav.current_y, s.nav.current_sigma) = (-0.1, 0.0, 0.01);
        s.nav.speed_scale = 1.039;
        s.guide.leg = 1;
        s.guide.to_x = 30.0;
        for k in 0..=30 {
            s.time_ns = k;
            s.nav.x_m = k as f32;
            s.nav.y_m = -2.0 * (-(k as f32) / 6.0).exp();
            m.update(&s);
        }
        s.guide.leg = 2;
        (s.guide.from_x, s.guide.from_y, s.guide.to_x, s.guide.to_y) = (30.0, 0.0, 30.0, 25.0);
        for k in 0..=12 {
            s.time_ns = 100 + k;
            s.nav.x_m = 30.4 + 0.6 * (-(k as f32) / 3.0).exp();
            s.nav.y_m = k as f32;
            m.update(&s);
        }
        s.nav.heading_deg = 90.0;
        s.guide.cross_track_m = -0.40;
        s.guide.heading_deg = 92.0;
        s.guide.to_go_m = 13.0;
        s.guide.along_track_m = 12.0;
        s.guide.leg_length_m = 25.0;
        let intent = crate::app::Intent::new(crate::app::Limits::default());
        let v = crate::view::ViewModel {
            title: "anguilla teleop",
            state: Some(&s),
            me: None,
            intent: Some(&intent),
            refused: None,
            history: None,
            map: Some(&m),
            status: "prefix 'anguilla' · watching: press t to take control",
        };
        let mut t = Terminal::new(TestBackend::new(100, 34)).unwrap();
        t.draw(|f| crate::view::render(f, &v)).unwrap();
        let text = crate::view::buffer_text(t.backend().buffer());
        let path = format!("{}/../docs/autopilot.md", env!("CARGO_MANIFEST_DIR"));
        anguilla_testkit::generated_block(
            std::path::Path::new(&path),
            "teleop-map-screenshot",
            &format!("```text\n{text}```\n"),
        );
    }
}
