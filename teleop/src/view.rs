//! The state view shared by `anguilla teleop` and `anguilla monitor`,
//! drawn with ratatui on any backend (a terminal, or `TestBackend` in tests).

use anguilla_ipc::{Cause, FaultSet, Hold, Mode, NavSnapshot, SensorHealth};
use anguilla_ipc::{GaitSnapshot, StateSnapshot};
use ratatui::Frame;
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Color, Modifier, Style};
use ratatui::symbols::Marker;
use ratatui::text::{Line, Span};
use ratatui::widgets::canvas::{Canvas, Line as CanvasLine};
use ratatui::widgets::{
    Axis, Bar, BarChart, BarGroup, Block, Chart, Dataset, GraphType, Paragraph, Wrap,
};

use crate::app::Intent;

mod lists;
mod map;
mod nav;
use crate::history::{History, Series};
use crate::hold::{held, wrap_heading};
use crate::keys::KEYS;
use crate::operator::Refused;
pub use lists::{residual_line, sensor_lines, sensor_name};
pub use map::{Map, map_title, render_map};
pub use nav::{
    COMPASS_DEG_PER_COLUMN, compass_strip, depth_gauge, nav_lines, path_line, position_line,
};

/// Smallest terminal the teleop view fits in (columns).
pub const MIN_WIDTH: u16 = 80;
/// Smallest terminal the teleop view fits in (rows).
pub const MIN_HEIGHT: u16 = 24;
/// Smallest height of the monitor view (it adds plots).
pub const MIN_HEIGHT_MONITOR: u16 = 36;

/// The name of a snapshot's mode code.
pub fn mode_name(mode: u8) -> &'static str {
    Mode::from_code(mode).map(Mode::name).unwrap_or("unknown")
}

/// The autopilot's mode by a snapshot's hold bits: "manual", "heading",
/// "depth" or "heading+depth".
pub fn autopilot_name(nav: &NavSnapshot) -> &'static str {
    held(nav).name()
}

/// The operator's holds in words: "heading 090.0°, depth 1.50 m", or
/// `None` for manual.
pub fn hold_text(h: &Hold) -> Option<String> {
    let parts: Vec<String> = h
        .heading
        .map(|d| format!("heading {:05.1}°", wrap_heading(d)))
        .into_iter()
        .chain(h.depth.map(|m| format!("depth {m:.2} m")))
        .collect();
    (!parts.is_empty()).then(|| parts.join(", "))
}

/// The name of a snapshot's cause code (the JSON token).
pub fn cause_name(cause: u8) -> &'static str {
    Cause::from_code(cause)
        .map(Cause::name)
        .unwrap_or("unknown")
}

/// A snapshot's cause code in an operator's words.
pub fn cause_words(cause: u8) -> &'static str {
    Cause::from_code(cause)
        .map(Cause::words)
        .unwrap_or("unknown cause")
}

fn mode_style(mode: u8) -> Style {
    let c = match Mode::from_code(mode) {
        Some(Mode::Swimming) => Color::Green,
        Some(Mode::Ready) => Color::Cyan,
        Some(Mode::Enabling | Mode::Stopping) => Color::Yellow,
        Some(Mode::Fault | Mode::EStop) => Color::Red,
        _ => Color::Gray,
    };
    Style::default().fg(c).add_modifier(Modifier::BOLD)
}

/// What one frame shows.
#[derive(Debug, Clone, Copy)]
pub struct ViewModel<'a> {
    /// Title (the tool's name).
    pub title: &'a str,
    /// The newest state, `None` before the daemon was heard.
    pub state: Option<&'a StateSnapshot>,
    /// This tool's client id, if it sends commands.
    pub me: Option<u128>,
    /// The operator's intent (teleop): shows the target and the keys.
    pub intent: Option<&'a Intent>,
    /// The last refused command.
    pub refused: Option<&'a Refused>,
    /// Plots (monitor).
    pub history: Option<&'a History>,
    /// The map of the path and the position, drawn in place of the side
    /// view and the torques while it has something to show.
    pub map: Option<&'a Map>,
    /// A line of status from the tool (connection, gamepad, ...).
    pub status: &'a str,
}

/// The smallest area `v` fits in.
pub fn min_size(v: &ViewModel) -> (u16, u16) {
    if v.history.is_some() {
        (MIN_WIDTH, MIN_HEIGHT_MONITOR)
    } else {
        (MIN_WIDTH, MIN_HEIGHT)
    }
}

/// Draws `v` over the whole frame, or a clear message when it is too small.
pub fn render(frame: &mut Frame, v: &ViewModel) {
    let area = frame.area();
    let (w, h) = min_size(v);
    if area.width < w || area.height < h {
        let msg = format!(
            "{}: the terminal is too small ({}×{}); it needs at least {w}×{h}. Enlarge it, or press q to quit.",
            v.title, area.width, area.height
        );
        frame.render_widget(Paragraph::new(msg).wrap(Wrap { trim: true }), area);
        return;
    }
    let nav = v
        .state
        .map(|s| {
            let mut lines = nav_lines(&s.nav, area.width.saturating_sub(2) as usize);
            lines.extend(position_line(&s.nav));
            lines.extend(path_line(&s.guide));
            lines.extend(sensor_lines(s));
            lines.extend(residual_line(s));
            lines
        })
        .unwrap_or_default();
    // The rows the header's lines take, wrapped to the frame's width (a
    // position line longer than a narrow terminal takes two).
    let nav_rows = Paragraph::new(nav.clone())
        .wrap(Wrap { trim: true })
        .line_count(area.width.saturating_sub(2));
    let [header, body, footer] = Layout::vertical([
        Constraint::Length(3 + nav_rows as u16),
        Constraint::Min(10),
        Constraint::Length(1),
    ])
    .areas(area);
    render_header(frame, header, v, nav);
    frame.render_widget(
        Paragraph::new(v.status).style(Style::default().fg(Color::DarkGray)),
        footer,
    );
    let (upper, plots) = if v.history.is_some() {
        let [u, p] = Layout::vertical([Constraint::Length(20), Constraint::Min(10)]).areas(body);
        (u, Some(p))
    } else {
        (body, None)
    };
    let [left, right] =
        Layout::horizontal([Constraint::Percentage(50), Constraint::Percentage(50)]).areas(upper);
    match v.map.filter(|m| m.shown(v.state)) {
        Some(map) => {
            let [top, below] =
                Layout::vertical([Constraint::Length(7), Constraint::Min(5)]).areas(left);
            render_body(frame, top, v.state, true);
            render_map(frame, below, map, v.state);
        }
        None => {
            let [top, side, bars] = Layout::vertical([
                Constraint::Length(7),
                Constraint::Length(5),
                Constraint::Min(5),
            ])
            .areas(left);
            render_body(frame, top, v.state, true);
            render_body(frame, side, v.state, false);
            render_torques(frame, bars, v.state);
        }
    }
    if v.intent.is_some() {
        let key_rows = KEYS.len().div_ceil(2) as u16 + 2;
        let [status, keys] =
            Layout::vertical([Constraint::Min(8), Constraint::Length(key_rows)]).areas(right);
        render_status(frame, status, v);
        render_keys(frame, keys);
    } else {
        render_status(frame, right, v);
    }
    if let (Some(area), Some(h)) = (plots, v.history) {
        render_plots(frame, area, h);
    }
}

fn render_header(frame: &mut Frame, area: Rect, v: &ViewModel, nav: Vec<Line<'static>>) {
    let mut spans = vec![];
    match v.state {
        None => spans.push(Span::styled(
            "waiting for the daemon…",
            Style::default().fg(Color::Yellow),
        )),
        Some(s) => {
            spans.push(Span::raw("mode "));
            spans.push(Span::styled(
                mode_name(s.mode).to_uppercase(),
                mode_style(s.mode),
            ));
            spans.push(Span::raw(format!(" ({})", cause_words(s.cause))));
            spans.push(Span::raw("  control: "));
            let holder = match s.holder() {
                None => "nobody".to_string(),
                Some(h) if Some(h) == v.me => "YOU".to_string(),
                Some(h) => format!("client {:08x}", h as u32),
            };
            spans.push(Span::styled(
                holder,
                Style::default().add_modifier(Modifier::BOLD),
            ));
            let faults = FaultSet {
                kinds: s.fault_kinds,
                nodes: s.fault_nodes,
            };
            spans.push(Span::raw("  faults: "));
            let fs = if faults.is_empty() {
                Style::default()
            } else {
                Style::default().fg(Color::Red).add_modifier(Modifier::BOLD)
            };
            spans.push(Span::styled(faults.to_string(), fs));
            if s.feedforward_dropped != 0 {
                spans.push(Span::styled(
                    "  feedforward dropped",
                    Style::default().fg(Color::Red),
                ));
            }
        }
    }
    let mut lines = vec![Line::from(spans)];
    lines.extend(nav);
    frame.render_widget(
        Paragraph::new(lines)
            .block(Block::bordered().title(format!(" {} ", v.title)))
            .wrap(Wrap { trim: true }),
        area,
    );
}

/// Points of the body's centre line from the head (x = 0, swimming to
/// +x) to the tail, bending by the joint angles: `angle(j)` of joint `j`.
/// A positive angle puts the tail towards -y (`sign` 1.0) or +y (-1.0):
/// seen from above with the head on the right, a left turn (positive yaw)
/// curves the tail up the screen; seen from the side, a dive (positive
/// pitch) curves it down.
fn body_line(n: usize, sign: f64, angle: impl Fn(usize) -> f64) -> Vec<(f64, f64)> {
    let seg = 1.0 / (n as f64 + 1.0);
    let mut pts = Vec::with_capacity(n + 2);
    let (mut x, mut y, mut heading) = (0.0f64, 0.0f64, std::f64::consts::PI);
    pts.push((x, y));
    for j in 0..=n {
        x += seg * heading.cos();
        y += seg * heading.sin();
        pts.push((x, y));
        if j < n {
            heading += sign * angle(j);
        }
    }
    pts
}

fn render_body(frame: &mut Frame, area: Rect, s: Option<&StateSnapshot>, top: bool) {
    let title = if top {
        " top view (yaw) — commanded, measured "
    } else {
        " side view (pitch) "
    };
    let (cmd, meas) = match s {
        Some(s) => {
            let n = (s.joint_count as usize).min(s.joints.len());
            let j = &s.joints;
            if top {
                (
                    body_line(n, -1.0, |i| j[i].commanded_yaw as f64),
                    body_line(n, -1.0, |i| j[i].measured_yaw as f64),
                )
            } else {
                (
                    body_line(n, 1.0, |i| j[i].commanded_pitch as f64),
                    body_line(n, 1.0, |i| j[i].measured_pitch as f64),
                )
            }
        }
        None => (vec![], vec![]),
    };
    let canvas = Canvas::default()
        .block(Block::bordered().title(title))
        .marker(Marker::Braille)
        .x_bounds([-1.05, 0.05])
        .y_bounds([-0.4, 0.4])
        .paint(move |ctx| {
            for (pts, color) in [(&cmd, Color::DarkGray), (&meas, Color::LightGreen)] {
                for w in pts.windows(2) {
                    ctx.draw(&CanvasLine::new(w[0].0, w[0].1, w[1].0, w[1].1, color));
                }
            }
            if let Some(&(x, y)) = meas.first() {
                ctx.print(
                    x - 0.02,
                    y,
                    Span::styled("●", Style::default().fg(Color::Yellow)),
                );
            }
        });
    frame.render_widget(canvas, area);
}

fn render_torques(frame: &mut Frame, area: Rect, s: Option<&StateSnapshot>) {
    let block = Block::bordered().title(" |measured yaw torque| per joint (mN·m) ");
    let Some(s) = s else {
        frame.render_widget(block, area);
        return;
    };
    let n = (s.joint_count as usize).min(s.joints.len());
    let bars: Vec<Bar> = s.joints[..n]
        .iter()
        .enumerate()
        .map(|(i, j)| {
            let mnm = (j.measured_yaw_torque.abs() * 1000.0).round() as u64;
            Bar::default()
                .value(mnm)
                .label(Line::from(format!("{}", i + 1)))
                .text_value(String::new())
        })
        .collect();
    let width = if n == 0 {
        1
    } else {
        ((area.width.saturating_sub(2)) / n as u16)
            .saturating_sub(1)
            .clamp(1, 5)
    };
    frame.render_widget(
        BarChart::default()
            .block(block)
            .data(BarGroup::default().bars(&bars))
            .bar_width(width)
            .bar_gap(1)
            .bar_style(Style::default().fg(Color::Magenta)),
        area,
    );
}

fn gait_line(label: &str, g: &GaitSnapshot) -> Line<'static> {
    Line::from(format!(
        "{label:<7} amp {:.2}  {:.2} Hz  turn {:+.2}/m  pitch {:+.2}/m",
        g.amplitude, g.frequency, g.turn, g.pitch
    ))
}

fn render_status(frame: &mut Frame, area: Rect, v: &ViewModel) {
    let mut lines: Vec<Line> = vec![];
    if let Some(i) = v.intent {
        let p = i.params();
        lines.push(Line::from(vec![
            Span::styled("you ask ", Style::default().add_modifier(Modifier::BOLD)),
            Span::raw(format!(
                "amp {:.2}  {:.2} Hz  turn {:+.2}/m  pitch {:+.2}/m  {}",
                p.amplitude,
                p.frequency,
                p.turn,
                p.pitch,
                if i.swimming() { "swim" } else { "rest" }
            )),
        ]));
        if let Some(h) = hold_text(&i.hold()) {
            lines.push(Line::from(format!(
                "you hold {h}{}",
                if i.swimming() { "" } else { " (armed)" }
            )));
        }
    }
    // The last refusal before the statistics: it is what the operator must
    // read when the panel is short.
    match v.refused {
        Some(r) => lines.push(Line::from(vec![
            Span::styled(
                format!("refused '{}': ", r.name()),
                Style::default().fg(Color::Red).add_modifier(Modifier::BOLD),
            ),
            Span::raw(r.reason.clone()),
        ])),
        None => lines.push(Line::from("no command refused")),
    }
    if let Some(s) = v.state {
        let l = &s.loop_stats;
        let b = &s.bus;
        let us = |ns: u32| ns as f64 / 1000.0;
        lines.push(gait_line("target", &s.gait_target));
        lines.push(gait_line("actual", &s.gait_actual));
        lines.push(Line::from(format!(
            "predicted head {:+.3} m/s, turn {:+.3} rad/s",
            s.predicted_head_speed, s.predicted_turn_rate
        )));
        lines.push(Line::from(format!(
            "loop {:.0} µs: jitter p50 {:.0} p99 {:.0} max {:.0} µs; compute p99 {:.0} µs; {} periods, {} overruns",
            us(l.period_ns),
            us(l.jitter_p50_ns),
            us(l.jitter_p99_ns),
            us(l.jitter_max_ns),
            us(l.compute_p99_ns),
            l.periods,
            l.overruns
        )));
        // Anything but error-active shouts.
        let bus_state = match b.state {
            0 | 1 => anguilla_ipc::bus_state_name(b.state).to_string(),
            _ => anguilla_ipc::bus_state_name(b.state).to_uppercase(),
        };
        lines.push(Line::from(format!(
            "bus {bus_state}: tx {} rx {} dropped {} rx lost {} malformed {} errors {} bus-off {}",
            b.tx_frames,
            b.rx_frames,
            b.tx_dropped,
            b.rx_overruns,
            b.malformed,
            b.errors,
            b.bus_off_count
        )));
        let alive = s.joints[..(s.joint_count as usize).min(s.joints.len())]
            .iter()
            .filter(|j| j.node_alive != 0)
            .count();
        lines.push(Line::from(format!(
            "nodes alive {alive}/{}; clamped {} refused {} silent-stops {}",
            s.joint_count, s.clamped_setpoints, s.refused_commands, s.operator_silent_stops
        )));
    }
    frame.render_widget(
        Paragraph::new(lines)
            .block(Block::bordered().title(" state "))
            .wrap(Wrap { trim: true }),
        area,
    );
}

fn render_keys(frame: &mut Frame, area: Rect) {
    let half = KEYS.len().div_ceil(2);
    let col = |keys: &[(&str, &str, &str)]| -> Vec<Line<'static>> {
        keys.iter()
            .map(|(k, what, _)| {
                Line::from(vec![
                    Span::styled(format!("{k:>5} "), Style::default().fg(Color::Cyan)),
                    Span::raw(what.to_string()),
                ])
            })
            .collect()
    };
    let block = Block::bordered().title(" keys ");
    let inner = block.inner(area);
    frame.render_widget(block, area);
    let [a, b] =
        Layout::horizontal([Constraint::Percentage(50), Constraint::Percentage(50)]).areas(inner);
    frame.render_widget(Paragraph::new(col(&KEYS[..half])), a);
    frame.render_widget(Paragraph::new(col(&KEYS[half..])), b);
}

fn chart<'a>(title: String, series: &[(&'a Series, &'a str, Color)]) -> Chart<'a> {
    let mut t = (f64::INFINITY, f64::NEG_INFINITY);
    let mut y = (f64::INFINITY, f64::NEG_INFINITY);
    let mut sets = vec![];
    for (s, name, color) in series {
        if let (Some(first), Some(last)) = (s.points().first(), s.points().last()) {
            t = (t.0.min(first.0), t.1.max(last.0));
        }
        if let Some((lo, hi)) = s.y_range() {
            y = (y.0.min(lo), y.1.max(hi));
        }
        sets.push(
            Dataset::default()
                .name(*name)
                .marker(Marker::Braille)
                .graph_type(GraphType::Line)
                .style(Style::default().fg(*color))
                .data(s.points()),
        );
    }
    if !t.0.is_finite() {
        t = (0.0, 1.0);
        y = (0.0, 1.0);
    }
    if y.1 - y.0 < 1e-9 {
        y = (y.0 - 0.5, y.1 + 0.5);
    }
    let pad = 0.05 * (y.1 - y.0);
    let y = (y.0 - pad, y.1 + pad);
    Chart::new(sets)
        .block(Block::bordered().title(title))
        .x_axis(Axis::default().bounds([t.0, t.1.max(t.0 + 1e-3)]))
        .y_axis(
            Axis::default()
                .bounds([y.0, y.1])
                .labels([format!("{:.2}", y.0), format!("{:.2}", y.1)]),
        )
}

fn render_plots(frame: &mut Frame, area: Rect, h: &History) {
    let [r1, r2] =
        Layout::vertical([Constraint::Percentage(50), Constraint::Percentage(50)]).areas(area);
    let [a, b] =
        Layout::horizontal([Constraint::Percentage(50), Constraint::Percentage(50)]).areas(r1);
    let [c, d] =
        Layout::horizontal([Constraint::Percentage(50), Constraint::Percentage(50)]).areas(r2);
    let j = h.joint + 1;
    frame.render_widget(
        chart(
            format!(" joint {j} yaw (rad): commanded, measured "),
            &[
                (&h.commanded_angle, "cmd", Color::DarkGray),
                (&h.measured_angle, "meas", Color::LightGreen),
            ],
        ),
        a,
    );
    frame.render_widget(
        chart(
            format!(" joint {j} yaw torque (N·m): predicted, measured "),
            &[
                (&h.predicted_torque, "pred", Color::DarkGray),
                (&h.measured_torque, "meas", Color::Magenta),
            ],
        ),
        b,
    );
    frame.render_widget(
        chart(
            " predicted head speed (m/s) ".into(),
            &[(&h.head_speed, "speed", Color::Cyan)],
        ),
        c,
    );
    frame.render_widget(
        chart(
            " loop jitter p99 (µs) ".into(),
            &[(&h.jitter_p99, "p99", Color::Yellow)],
        ),
        d,
    );
}

/// The text of a rendered buffer, one line per row, trailing spaces
/// trimmed (for tests and the screenshot in docs/operating.md).
pub fn buffer_text(buf: &ratatui::buffer::Buffer) -> String {
    let a = buf.area;
    let mut out = String::new();
    for y in a.top()..a.bottom() {
        let mut line = String::new();
        for x in a.left()..a.right() {
            line.push_str(buf[(x, y)].symbol());
        }
        out.push_str(line.trim_end());
        out.push('\n');
    }
    out
}

/// A snapshot of a robot swimming and turning, for tests and the docs.
pub fn sample_snapshot() -> StateSnapshot {
    let mut s = StateSnapshot {
        joint_count: 12,
        sequence: 41_250,
        time_ns: 41_250_000_000,
        mode: Mode::Swimming as u8,
        cause: 1,
        holder_lo: 0x5eed_0000_0000_0001,
        predicted_head_speed: 0.142,
        predicted_turn_rate: 0.087,
        gait_target: GaitSnapshot {
            amplitude: 0.6,
            frequency: 1.0,
            turn: 0.5,
            pitch: 0.0,
        },
        gait_actual: GaitSnapshot {
            amplitude: 0.6,
            frequency: 1.0,
            turn: 0.41,
            pitch: 0.0,
        },
        ..Default::default()
    };
    s.loop_stats.period_ns = 1_000_000;
    s.loop_stats.jitter_p50_ns = 9_000;
    s.loop_stats.jitter_p99_ns = 48_000;
    s.loop_stats.jitter_max_ns = 160_000;
    s.loop_stats.compute_p99_ns = 85_000;
    s.loop_stats.periods = 41_250;
    s.nav = NavSnapshot {
        sensor: SensorHealth::Ok as u8,
        hold: anguilla_ipc::hold_bits::HEADING,
        heading_deg: 87.3,
        pitch_deg: -2.1,
        roll_deg: 3.4,
        depth_m: 1.23,
        depth_rate: 0.04,
        temperature: 14.5,
        heading_target_deg: 90.0,
        samples: 4125,
        ..Default::default()
    };
    s.bus.tx_frames = 536_250;
    s.bus.rx_frames = 1_031_240;
    for (i, j) in s.joints[..12].iter_mut().enumerate() {
        let x = (i + 1) as f32 / 13.0;
        let phase = 2.0 * std::f32::consts::PI * x * 1.3;
        j.commanded_yaw = 0.04 + 0.18 * x * phase.sin();
        j.measured_yaw = j.commanded_yaw - 0.01 * phase.cos();
        j.predicted_yaw_torque = 0.02 + 0.25 * x * (1.0 - x) * (phase + 0.5).sin();
        j.measured_yaw_torque = j.predicted_yaw_torque * 1.08;
        j.node_alive = 1;
        j.node_state = 2;
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::app::{Action, Limits};
    use ratatui::Terminal;
    use ratatui::backend::TestBackend;

    fn draw(w: u16, h: u16, v: &ViewModel) -> String {
        let mut t = Terminal::new(TestBackend::new(w, h)).unwrap();
        t.draw(|f| render(f, v)).unwrap();
        buffer_text(t.backend().buffer())
    }

    fn teleop_view<'a>(
        s: Option<&'a StateSnapshot>,
        i: &'a Intent,
        r: Option<&'a Refused>,
    ) -> ViewModel<'a> {
        ViewModel {
            title: "anguilla teleop",
            state: s,
            me: Some(0x5eed_0000_0000_0001),
            intent: Some(i),
            refused: r,
            history: None,
            map: None,
            status: "connected to 'anguilla'",
        }
    }

    #[test]
    fn teleop_view_shows_mode_holder_gait_keys_and_refusal() {
        let s = sample_snapshot();
        let mut i = Intent::new(Limits::default());
        for _ in 0..6 {
            i.apply(Action::Faster);
        }
        i.apply(Action::TurnLeft);
        i.apply(Action::TurnLeft);
        let r = Refused {
            kind: Some(anguilla_ipc::CommandKind::Enable),
            reason: "'enable' is not valid in mode e-stop: reset first".into(),
        };
        let text = draw(100, 30, &teleop_view(Some(&s), &i, Some(&r)));
        for want in [
            "anguilla teleop",
            "SWIMMING",
            "control: YOU",
            "faults: no fault",
            "you ask amp 0.60  1.00 Hz  turn +0.50/m",
            "target  amp 0.60",
            "actual  amp 0.60  1.00 Hz  turn +0.41/m",
            "predicted head +0.142 m/s",
            "overruns",
            "bus error-active",
            "refused 'enable':",
            "E-STOP",
            "q quit",
            "x/! E-STOP",
            "top view (yaw)",
            "side view (pitch)",
            "measured yaw torque",
        ] {
            assert!(text.contains(want), "missing {want:?} in\n{text}");
        }
    }

    #[test]
    fn the_compass_strip_puts_headings_to_the_left_as_they_increase() {
        // 5° a column, centre column 6 is the nose; "90" would cover it.
        let s = compass_strip(90.0, None, 13);
        assert_eq!(&s, "· · · │ · · ·", "{s:?}");
        // Wider: 120 to the left of 90, 60 to its right, 6 columns away.
        let s = compass_strip(90.0, None, 25);
        assert_eq!(s.chars().count(), 25);
        let col = |label: &str| s[..s.find(label).unwrap()].chars().count();
        assert_eq!((col("120"), col("│"), col("60")), (5, 12, 18), "{s:?}");
        let s = compass_strip(75.0, None, 25);
        assert_eq!(s[..s.find("90").unwrap()].chars().count(), 9, "{s:?}");
        // A target 10° to the left (a left turn increases the heading).
        let s: Vec<char> = compass_strip(90.0, Some(100.0), 13).chars().collect();
        assert_eq!(s[4], '◆', "{s:?}");
        // Across north: heading 358, target 3 is 5° to the left.
        let s: Vec<char> = compass_strip(358.0, Some(3.0), 13).chars().collect();
        assert_eq!(s[5], '◆', "{s:?}");
        // Off the strip: an arrow at the edge on its side.
        let s: Vec<char> = compass_strip(0.0, Some(90.0), 13).chars().collect();
        assert_eq!(s[0], '◀', "{s:?}");
        let s: Vec<char> = compass_strip(0.0, Some(270.0), 13).chars().collect();
        assert_eq!(s[12], '▶', "{s:?}");
    }

    #[test]
    fn the_depth_gauge_places_depth_and_target() {
        let g = depth_gauge(1.0, Some(1.5), 20);
        assert_eq!(g.chars().count(), 20, "{g}");
        assert!(g.starts_with("0├") && g.ends_with("┤2 m"), "{g}");
        let d = g.find('●').unwrap();
        let t = g.find('◆').unwrap();
        assert!(d < t, "deeper is further right: {g}");
        // Deeper than the default scale: the scale grows (5 m · 1.25, up).
        assert!(depth_gauge(5.0, None, 20).ends_with("┤7 m"));
        // At the surface, and a negative estimate, sit on 0.
        assert!(depth_gauge(-0.2, None, 20).starts_with("0├●"));
    }

    #[test]
    fn the_header_shows_heading_attitude_depth_autopilot_and_sensor() {
        let mut s = sample_snapshot();
        s.nav.hold |= anguilla_ipc::hold_bits::DEPTH;
        s.nav.depth_target_m = 1.5;
        s.nav.roll_alarm = 1;
        s.nav.roll_deg = -65.0;
        let i = Intent::new(Limits::default());
        let text = draw(100, 30, &teleop_view(Some(&s), &i, None));
        for want in [
            "hdg 087.3° → 090.0°",
            "pitch -2.1°  roll -65.0°  ROLL ALARM",
            "depth 1.23 m → 1.50 m ↓0.04 m/s",
            "autopilot heading+depth",
            "sensor ok",
            "◆",
        ] {
            assert!(text.contains(want), "missing {want:?} in\n{text}");
        }
        // Another sensor of the list: a line of its own, from its kind's
        // table.
        let mut t = s;
        t.sensors[1] = anguilla_ipc::SensorEntry {
            kind: anguilla_ipc::SensorKind::TailImu as u8,
            id: 40,
            health: SensorHealth::Stuck as u8,
            samples: 9,
            values: [12.5, 0.0, 0.0, 0.25, 0.0, 0.0, 14.0, 0.0],
            ..Default::default()
        };
        let text = draw(120, 32, &teleop_view(Some(&t), &i, None));
        assert!(
            text.contains("tail-imu (node 40): stuck  heading 12.50 deg  pitch 0.00 deg"),
            "{text}"
        );
        // At 80 columns everything but the gauge still fits on its line.
        let text = draw(80, 24, &teleop_view(Some(&s), &i, None));
        assert!(text.contains("hdg 087.3° → 090.0°"), "{text}");
        assert!(
            text.contains("autopilot heading+depth  sensor ok"),
            "{text}"
        );
        // The daemon's hold states (issue 46): a failure in words, and
        // the surface.
        let mut h = s;
        h.nav.depth_hold = anguilla_ipc::HoldState::Surface as u8;
        h.nav.heading_hold = anguilla_ipc::HoldState::Holding as u8;
        h.nav.surfaced = 1;
        let text = draw(140, 30, &teleop_view(Some(&h), &i, None));
        for want in [
            "autopilot heading+depth hdg holding depth cannot: at the surface",
            "SURFACED",
        ] {
            assert!(text.contains(want), "missing {want:?} in\n{text}");
        }
        // The autopilot let go: manual, and why.
        s.nav.hold = 0;
        s.nav.hold_exit = SensorHealth::Silent as u8;
        s.nav.sensor = SensorHealth::Silent as u8;
        s.nav.roll_alarm = 0;
        let text = draw(100, 30, &teleop_view(Some(&s), &i, None));
        assert!(
            text.contains("autopilot manual (let go: silent)  sensor silent"),
            "{text}"
        );
        assert!(
            !text.contains("ROLL ALARM") && !text.contains("→ 090.0°"),
            "{text}"
        );
    }

    #[test]
    fn without_a_head_sensor_one_line_says_so_instead_of_zeros() {
        let mut s = sample_snapshot();
        s.nav = NavSnapshot::default();
        let i = Intent::new(Limits::default());
        let text = draw(100, 30, &teleop_view(Some(&s), &i, None));
        assert!(text.contains("no head sensor"), "{text}");
        assert!(
            !text.contains("hdg 0") && !text.contains("depth 0.00"),
            "{text}"
        );
        assert_eq!(nav_lines(&s.nav, 98).len(), 1);
        // Configured, no sample yet: its health, no numbers.
        s.nav.sensor = SensorHealth::Waiting as u8;
        let text = draw(100, 30, &teleop_view(Some(&s), &i, None));
        assert!(
            text.contains("head sensor waiting: no sample yet"),
            "{text}"
        );
        assert!(!text.contains("hdg 0"), "{text}");
    }

    #[test]
    fn the_operators_holds_are_shown_armed_or_sent() {
        let s = sample_snapshot();
        let mut i = Intent::new(Limits::default());
        i.observe_nav(&s.nav);
        i.apply(Action::HoldHeading);
        i.apply(Action::HoldDepth);
        let text = draw(100, 30, &teleop_view(Some(&s), &i, None));
        assert!(
            text.contains("you hold heading 087.3°, depth 1.23 m (armed)"),
            "{text}"
        );
        assert_eq!(hold_text(&Hold::MANUAL), None);
    }

    #[test]
    fn another_holder_and_faults_are_named() {
        let mut s = sample_snapshot();
        s.set_holder(Some(0xabc));
        s.mode = Mode::Fault as u8;
        s.fault_kinds = 1;
        s.fault_nodes = 1 << 7;
        let i = Intent::new(Limits::default());
        let text = draw(100, 30, &teleop_view(Some(&s), &i, None));
        assert!(text.contains("FAULT"), "{text}");
        assert!(text.contains("client 00000abc"), "{text}");
        assert!(text.contains("heartbeat lost (node 7)"), "{text}");
        assert!(text.contains("no command refused"), "{text}");
    }

    #[test]
    fn before_the_daemon_is_heard_it_says_so() {
        let i = Intent::new(Limits::default());
        let text = draw(80, 24, &teleop_view(None, &i, None));
        assert!(text.contains("waiting for the daemon"), "{text}");
    }

    #[test]
    fn too_small_a_terminal_gets_a_clear_message() {
        let i = Intent::new(Limits::default());
        let s = sample_snapshot();
        let text = draw(60, 20, &teleop_view(Some(&s), &i, None));
        assert!(text.contains("too small (60×20)"), "{text}");
        assert!(text.contains("80×24"), "{text}");
        assert!(!text.contains("SWIMMING"));
        // The smallest size draws the whole view.
        let text = draw(80, 24, &teleop_view(Some(&s), &i, None));
        assert!(text.contains("SWIMMING") && text.contains("keys"), "{text}");
    }

    #[test]
    fn the_body_sketch_bends_with_the_joints() {
        let straight = body_line(3, 1.0, |_| 0.0);
        assert_eq!(straight.len(), 5);
        assert!((straight[4].0 + 1.0).abs() < 1e-12, "1 m long");
        assert!(straight.iter().all(|p| p.1.abs() < 1e-12));
        // A left turn seen from above: the tail curves up the screen.
        let left = body_line(3, -1.0, |_| 0.2);
        assert!(left[4].1 > 0.1, "tail at +y: {left:?}");
        // A dive seen from the side: the tail curves down.
        let dive = body_line(3, 1.0, |_| 0.2);
        assert!(dive[4].1 < -0.1, "tail at -y: {dive:?}");
        // Equal and opposite bends mirror the sketch.
        let bent = left;
        let other = body_line(3, -1.0, |_| -0.2);
        assert!((bent[4].1 + other[4].1).abs() < 1e-12);
    }

    /// The part `tag` of `file` (from the repository's root) is `generated`
    /// (`anguilla_testkit::generated_block`).
    fn check_doc_block(file: &str, tag: &str, generated: &str) {
        let path = format!("{}/../{file}", env!("CARGO_MANIFEST_DIR"));
        anguilla_testkit::generated_block(std::path::Path::new(&path), tag, generated);
    }

    #[test]
    fn docs_screenshot_and_readme_keys_are_current() {
        let s = sample_snapshot();
        let mut i = Intent::new(Limits::default());
        for _ in 0..6 {
            i.apply(Action::Faster);
        }
        i.apply(Action::TurnLeft);
        i.apply(Action::TurnLeft);
        let r = Refused {
            kind: Some(anguilla_ipc::CommandKind::Disable),
            reason: "'disable' is not valid in mode swimming: stop first, or e-stop".into(),
        };
        let mut v = teleop_view(Some(&s), &i, Some(&r));
        v.status = "prefix 'anguilla' · you hold control: sending your command at 10 Hz";
        let text = draw(100, 30, &v);
        check_doc_block(
            "docs/operating.md",
            "teleop-screenshot",
            &format!("```text\n{text}```\n"),
        );
        let keys: String = KEYS
            .iter()
            .map(|(k, _, long)| format!("| `{k}` | {long} |\n"))
            .collect();
        check_doc_block("README.md", "teleop-keys", &keys);
    }

    #[test]
    fn monitor_view_has_plots_and_no_keys() {
        let mut h = History::new(10.0, 11);
        let mut s = sample_snapshot();
        for k in 0..50 {
            s.time_ns = 40_000_000_000 + k * 100_000_000;
            s.joints[11].commanded_yaw = (k as f32 * 0.3).sin() * 0.2;
            s.joints[11].measured_yaw = (k as f32 * 0.3 - 0.1).sin() * 0.2;
            h.push(&s);
        }
        let v = ViewModel {
            title: "anguilla monitor",
            state: Some(&s),
            me: None,
            intent: None,
            refused: None,
            history: Some(&h),
            map: None,
            status: "read-only",
        };
        let text = draw(100, 40, &v);
        for want in [
            "joint 12 yaw (rad)",
            "yaw torque (N·m)",
            "head speed",
            "loop jitter p99",
        ] {
            assert!(text.contains(want), "missing {want:?} in\n{text}");
        }
        assert!(!text.contains(" keys "), "{text}");
        let small = draw(100, 30, &v);
        assert!(small.contains("too small"), "{small}");
    }
}
