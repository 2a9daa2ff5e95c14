//! The header's lists beyond the head sensor: the other sensors of the
//! snapshot's list and the torque-residual alarms, each a line, from the
//! vocabulary's tables alone.

use anguilla_ipc::{SensorHealth, StateSnapshot};
use ratatui::style::{Color, Modifier, Style};
use ratatui::text::{Line, Span};

/// The name of a snapshot's sensor health code.
pub fn sensor_name(code: u8) -> &'static str {
    SensorHealth::from_code(code)
        .map(SensorHealth::name)
        .unwrap_or("unknown")
}

/// One line per sensor of the snapshot's list beyond the head sensor
/// (which the nav lines show): its kind, node, health and values, as the
/// vocabulary's [`anguilla_ipc::SensorKind`] names them.
pub fn sensor_lines(s: &StateSnapshot) -> Vec<Line<'static>> {
    s.sensors
        .iter()
        .filter(|e| e.kind != 0 && e.kind != anguilla_ipc::SensorKind::HeadNav as u8)
        .map(|e| {
            let kind = e.sensor_kind().map_or_else(
                || format!("sensor kind {}", e.kind),
                |k| k.name().to_string(),
            );
            let ok = e.health == SensorHealth::Ok as u8;
            let mut spans = vec![
                Span::raw(format!("{kind} (node {}): ", e.id)),
                Span::styled(
                    sensor_name(e.health),
                    if ok {
                        Style::default().fg(Color::Green)
                    } else {
                        Style::default().fg(Color::Red)
                    },
                ),
            ];
            if e.samples > 0 {
                for (name, unit, v) in e.named_values() {
                    spans.push(Span::raw(format!("  {name} {v:.2} {unit}")));
                }
            }
            Line::from(spans)
        })
        .collect()
}

/// The torque-residual alarms, if any: one line naming each alarmed
/// joint, axis and residual.
pub fn residual_line(s: &StateSnapshot) -> Option<Line<'static>> {
    let alarms: Vec<String> = s
        .residual_alarms()
        .map(|(j, axis, r)| format!("joint {j} {axis} {r:+.2}"))
        .collect();
    (!alarms.is_empty()).then(|| {
        Line::from(Span::styled(
            format!("TORQUE RESIDUAL {}", alarms.join(", ")),
            Style::default().fg(Color::Red).add_modifier(Modifier::BOLD),
        ))
    })
}
