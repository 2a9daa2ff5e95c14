//! The header's head-sensor lines: the heading's compass strip, the
//! depth's gauge, the autopilot and the sensor's health, and the position
//! line (x, y, whether fixes hold them, the estimated current).

use anguilla_ipc::{HoldState, NavSnapshot, PositionHealth, SensorHealth};
use ratatui::style::{Color, Modifier, Style};
use ratatui::text::{Line, Span};

use super::sensor_name;
use crate::hold::{has_estimate, held, wrap_heading};

/// Degrees of heading per column of [`compass_strip`].
pub const COMPASS_DEG_PER_COLUMN: f64 = 5.0;

/// `a - b` in degrees, wrapped to -180 ..< 180 (positive: `a` is to the
/// left of `b`, headings increasing counter-clockwise).
fn heading_diff(a: f64, b: f64) -> f64 {
    (a - b + 180.0).rem_euclid(360.0) - 180.0
}

/// A compass strip `width` columns wide centred on `heading` (the centre
/// column is the nose), [`COMPASS_DEG_PER_COLUMN`] a column. Headings
/// increase to the **left**, as the robot sees them turning left (they are
/// counter-clockwise seen from above). The nose is a `│`; labels every
/// 30° (but where they would cover the nose or the target), a `·` every
/// 10°; `target`, if any, is a `◆`, or a `◀` / `▶` at the edge on its side
/// when it is off the strip.
pub fn compass_strip(heading: f64, target: Option<f64>, width: usize) -> String {
    let width = width.max(3);
    let centre = (width / 2) as f64;
    let mut cols = vec![' '; width];
    let column = |deg: f64| centre - (heading_diff(deg, heading) / COMPASS_DEG_PER_COLUMN).round();
    let target_col = target.map(|t| column(t).clamp(0.0, (width - 1) as f64));
    for k in 0..36 {
        let c = column(k as f64 * 10.0);
        if (0.0..width as f64).contains(&c) {
            cols[c as usize] = '·';
        }
    }
    for k in 0..12 {
        let label = (k * 30).to_string();
        let n = label.len() as f64;
        let first = column(k as f64 * 30.0) - ((n - 1.0) / 2.0).floor();
        let covers = |c: f64| (first..first + n).contains(&c);
        if first >= 0.0
            && first + n <= width as f64
            && !covers(centre)
            && !target_col.is_some_and(covers)
        {
            for (i, ch) in label.chars().enumerate() {
                cols[first as usize + i] = ch;
            }
        }
    }
    cols[centre as usize] = '│';
    if let Some(t) = target {
        let c = column(t);
        if c < 0.0 {
            cols[0] = '◀';
        } else if c >= width as f64 {
            cols[width - 1] = '▶';
        } else {
            cols[c as usize] = '◆';
        }
    }
    cols.into_iter().collect()
}

/// A depth gauge `width` columns wide: `0├`, the scale, `┤` and its full
/// scale in metres (at least 2 m, and a quarter beyond the deeper of
/// `depth` and `target`, rounded up to a metre), with the depth as `●`
/// and the target, if any, as `◆`.
pub fn depth_gauge(depth: f64, target: Option<f64>, width: usize) -> String {
    let deepest = depth.max(target.unwrap_or(0.0)).max(0.0);
    let full = (deepest * 1.25).ceil().max(2.0);
    let end = format!("┤{full:.0} m");
    let inner = width.saturating_sub(2 + end.chars().count()).max(3);
    let mut cols = vec!['─'; inner];
    let col = |v: f64| ((v.clamp(0.0, full) / full) * (inner - 1) as f64).round() as usize;
    if let Some(t) = target {
        cols[col(t)] = '◆';
    }
    cols[col(depth)] = '●';
    format!("0├{}{end}", cols.into_iter().collect::<String>())
}

/// The header's head-sensor lines for an area `width` columns wide: one
/// compact line without a sensor or before its first sample; else the
/// heading (compass strip, target), pitch and roll (roll alarm), then the
/// depth (gauge, rate, target), the autopilot and the sensor's health.
pub fn nav_lines(nav: &NavSnapshot, width: usize) -> Vec<Line<'static>> {
    let bad = Style::default().fg(Color::Red).add_modifier(Modifier::BOLD);
    let dim = Style::default().fg(Color::DarkGray);
    let health = sensor_name(nav.sensor);
    let health_style = if nav.sensor == SensorHealth::Ok as u8 {
        Style::default().fg(Color::Green)
    } else {
        bad
    };
    let hold = held(nav);
    let mut autopilot = vec![
        Span::raw("  autopilot "),
        Span::styled(hold.name(), Style::default().add_modifier(Modifier::BOLD)),
    ];
    if !hold.is_active() && nav.hold_exit != 0 {
        autopilot.push(Span::styled(
            format!(" (let go: {})", sensor_name(nav.hold_exit)),
            bad,
        ));
    }
    // How each held quantity is doing, as the daemon judges it: a failure
    // (not converging, cannot) in red.
    for (code, what) in [(nav.heading_hold, "hdg"), (nav.depth_hold, "depth")] {
        match HoldState::from_code(code) {
            Some(HoldState::Off) => {}
            Some(h) => autopilot.push(Span::styled(
                format!(" {what} {}", h.name()),
                if h.failed() { bad } else { dim },
            )),
            None => autopilot.push(Span::styled(format!(" {what} hold state {code}"), bad)),
        }
    }
    if nav.sensor == 0 {
        return vec![Line::from(Span::styled(
            "no head sensor (heading and depth hold unavailable)",
            dim,
        ))];
    }
    if !has_estimate(nav) {
        let mut spans = vec![
            Span::raw("head sensor "),
            Span::styled(health, health_style),
            Span::raw(": no sample yet"),
        ];
        spans.extend(autopilot);
        return vec![Line::from(spans)];
    }
    let heading = wrap_heading(nav.heading_deg as f64);
    let mut l1 = format!("hdg {heading:05.1}°");
    if let Some(t) = hold.heading {
        l1.push_str(&format!(" → {:05.1}°", wrap_heading(t)));
    }
    let attitude = format!("  pitch {:+.1}°  roll {:+.1}°", nav.pitch_deg, nav.roll_deg);
    let alarm = "  ROLL ALARM";
    let used = l1.chars().count() + 1 + attitude.chars().count() + alarm.len();
    let strip_width = (width.saturating_sub(used + 1) | 1).clamp(9, 37);
    let strip = compass_strip(heading, hold.heading, strip_width);
    let (before, rest) = strip.split_at(
        strip
            .char_indices()
            .nth(strip_width / 2)
            .map_or(0, |(i, _)| i),
    );
    let mut nose = rest.chars();
    let nose_char = nose.next().unwrap_or(' ').to_string();
    let mut line1 = vec![
        Span::raw(format!("{l1} ")),
        Span::styled(before.to_string(), Style::default().fg(Color::Cyan)),
        Span::styled(nose_char, Style::default().add_modifier(Modifier::REVERSED)),
        Span::styled(nose.collect::<String>(), Style::default().fg(Color::Cyan)),
        Span::raw(attitude),
    ];
    if nav.roll_alarm != 0 {
        line1.push(Span::styled(alarm, bad));
    }
    let depth = nav.depth_m as f64;
    let mut d = format!("depth {depth:.2} m");
    if let Some(t) = hold.depth {
        d.push_str(&format!(" → {t:.2} m"));
    }
    let rate = nav.depth_rate as f64;
    d.push_str(&format!(
        " {}{:.2} m/s",
        if rate >= 0.0 { '↓' } else { '↑' },
        rate.abs()
    ));
    let sensor = vec![Span::raw("  sensor "), Span::styled(health, health_style)];
    let used = d.chars().count()
        + autopilot
            .iter()
            .chain(&sensor)
            .map(|s| s.content.chars().count())
            .sum::<usize>();
    let mut line2 = vec![Span::raw(d)];
    if nav.surfaced != 0 {
        line2.push(Span::styled(" SURFACED", bad));
    }
    let room = width.saturating_sub(used + 2);
    if room >= 14 {
        line2.push(Span::styled(
            format!(" {}", depth_gauge(depth, hold.depth, room.min(30))),
            Style::default().fg(Color::Cyan),
        ));
    }
    line2.extend(autopilot);
    line2.extend(sensor);
    vec![Line::from(line1), Line::from(line2)]
}

/// The position line, with a position sensor: x, y and their
/// uncertainty, whether fixes hold them (a stale fix yellow, a lost one
/// red) and the estimated current.
pub fn position_line(nav: &NavSnapshot) -> Option<Line<'static>> {
    let health = nav.position_state();
    if nav.sensor == 0 || health == Some(PositionHealth::DeadReckoning) {
        return None;
    }
    let style = match health {
        Some(PositionHealth::Fixed) => Style::default().fg(Color::Green),
        Some(PositionHealth::Stale | PositionHealth::Waiting) => Style::default().fg(Color::Yellow),
        _ => Style::default().fg(Color::Red).add_modifier(Modifier::BOLD),
    };
    let name = health.map_or("unknown", PositionHealth::name);
    let age = nav
        .fix_age_s()
        .map_or(String::new(), |a| format!(" {a:.1} s ago"));
    let (cx, cy) = (f64::from(nav.current_x), f64::from(nav.current_y));
    Some(Line::from(vec![
        Span::raw(format!(
            "x {:+.2} m  y {:+.2} m  ±{:.2} m  ",
            nav.x_m, nav.y_m, nav.position_sigma_m
        )),
        Span::styled(format!("{name}{age}"), style),
        Span::raw(format!(
            "  current {:.2} m/s toward {:05.1}° ±{:.2}  model speed ×{:.3}",
            cx.hypot(cy),
            wrap_heading(cy.atan2(cx).to_degrees()),
            nav.current_sigma,
            nav.speed_scale
        )),
    ]))
}

/// The path line, once a path was followed: its state (stopped red and
/// bold), the leg, the cross-track error and how far to the leg's end.
pub fn path_line(g: &anguilla_ipc::GuideSnapshot) -> Option<Line<'static>> {
    use anguilla_ipc::GuideState;
    let state = g.guide_state();
    if state == Some(GuideState::Off) {
        return None;
    }
    let style = match state {
        Some(GuideState::Following) => Style::default().fg(Color::Green),
        Some(s) if s.failed() => Style::default().fg(Color::Red).add_modifier(Modifier::BOLD),
        _ => Style::default(),
    };
    let name = state.map_or("unknown", GuideState::name);
    Some(Line::from(vec![
        Span::raw("path "),
        Span::styled(name.to_string(), style),
        Span::raw(format!(
            "  leg to {}/{} ({:+.1}, {:+.1}) m  {:.1} m to go  cross-track {:+.2} m  heading {:05.1}°",
            g.leg, g.waypoints, g.to_x, g.to_y, g.to_go_m, g.cross_track_m, g.heading_deg
        )),
    ]))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A path followed is a line with its leg and cross-track error; a
    /// path stopped for a lost fix is red and bold; none before a path.
    #[test]
    fn the_path_line_says_where_on_the_path_the_robot_is() {
        use anguilla_ipc::{GuideSnapshot, GuideState};
        assert!(path_line(&GuideSnapshot::default()).is_none());
        let mut g = GuideSnapshot {
            state: GuideState::Following as u8,
            leg: 2,
            waypoints: 4,
            to_x: 10.0,
            to_y: 3.0,
            to_go_m: 4.5,
            cross_track_m: -0.12,
            heading_deg: 92.0,
            ..Default::default()
        };
        let text = |l: &Line| {
            l.spans
                .iter()
                .map(|s| s.content.to_string())
                .collect::<String>()
        };
        let l = path_line(&g).expect("a line");
        assert_eq!(
            text(&l),
            "path following  leg to 2/4 (+10.0, +3.0) m  4.5 m to go  cross-track -0.12 m  heading 092.0°"
        );
        g.state = GuideState::FixLost as u8;
        let l = path_line(&g).expect("a line");
        assert_eq!(l.spans[1].style.fg, Some(Color::Red));
    }

    /// With a position sensor the line says x, y, their σ, the fix's
    /// state and age and the current; a lost fix is red and bold; without
    /// one (dead reckoning) there is no line.
    #[test]
    fn the_position_line_says_whether_fixes_hold_it() {
        let mut nav = NavSnapshot {
            sensor: SensorHealth::Ok as u8,
            x_m: 1.5,
            y_m: -0.25,
            position_sigma_m: 0.3,
            position_fixes: 4,
            fix_age_ms: 6500,
            position_health: PositionHealth::Stale as u8,
            current_y: 0.1,
            current_sigma: 0.02,
            speed_scale: 1.04,
            ..NavSnapshot::default()
        };
        let text = |l: &Line| {
            l.spans
                .iter()
                .map(|s| s.content.as_ref())
                .collect::<String>()
        };
        let l = position_line(&nav).expect("a line");
        assert_eq!(
            text(&l),
            "x +1.50 m  y -0.25 m  ±0.30 m  fix stale 6.5 s ago  current 0.10 m/s toward 090.0° ±0.02  model speed ×1.040"
        );
        assert_eq!(l.spans[1].style.fg, Some(Color::Yellow));
        nav.position_health = PositionHealth::Lost as u8;
        let l = position_line(&nav).expect("a line");
        assert_eq!(l.spans[1].style.fg, Some(Color::Red));
        nav.position_health = PositionHealth::DeadReckoning as u8;
        assert!(position_line(&nav).is_none());
    }
}
