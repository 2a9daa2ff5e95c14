//! The `/log` channel's lines: what changed between two snapshots (the
//! mode, faults, refusals, holds, the surface, torque residuals, sensors).

use anguilla_ipc::{
    Cause, FaultSet, GuideSnapshot, GuideState, HoldState, Mode, NavSnapshot, PositionHealth,
    SensorHealth, StateSnapshot,
};

/// What changed between two snapshots, as log lines (level, text):
/// foxglove.Log levels 2 info, 3 warning, 4 error.
pub(crate) fn log_lines(last: Option<&StateSnapshot>, s: &StateSnapshot) -> Vec<(u8, String)> {
    let mut out = Vec::new();
    let mode = Mode::from_code(s.mode).map_or("unknown", Mode::name);
    let cause = Cause::from_code(s.cause).map_or("unknown", Cause::name);
    if last.is_none_or(|l| l.mode != s.mode) {
        let level = match Mode::from_code(s.mode) {
            Some(Mode::Fault | Mode::EStop) => 4,
            _ => 2,
        };
        out.push((level, format!("mode {mode} (cause: {cause})")));
    }
    let faults = FaultSet {
        kinds: s.fault_kinds,
        nodes: s.fault_nodes,
    };
    if last.is_some_and(|l| l.fault_kinds != s.fault_kinds || l.fault_nodes != s.fault_nodes)
        && !faults.is_empty()
    {
        out.push((4, format!("faults: {faults}")));
    }
    if let Some(l) = last
        && s.refused_commands > l.refused_commands
    {
        out.push((
            3,
            format!(
                "{} command(s) refused ({} since start)",
                s.refused_commands - l.refused_commands,
                s.refused_commands
            ),
        ));
    }
    if let Some(l) = last
        && s.nav.hold_exit != l.nav.hold_exit
        && s.nav.hold_exit != 0
    {
        let why = SensorHealth::from_code(s.nav.hold_exit).map_or("unknown", SensorHealth::name);
        out.push((3, format!("the autopilot let go: head sensor {why}")));
    }
    // A hold that stops converging (or cannot), or converges again; the
    // robot at the surface, or back under.
    if let Some(l) = last {
        for (now, was, words) in [
            (
                s.nav.heading_hold,
                l.nav.heading_hold,
                s.nav.heading_words(),
            ),
            (s.nav.depth_hold, l.nav.depth_hold, s.nav.depth_words()),
        ] {
            if let Some(line) = hold_line(now, was, words) {
                out.push(line);
            }
        }
        if s.nav.surfaced != l.nav.surfaced {
            out.push(surface_line(s.nav.surfaced != 0, s.nav.depth_m));
        }
        if let Some(line) = position_line(&s.nav, &l.nav) {
            out.push(line);
        }
        if let Some(line) = guide_line(&s.guide, &l.guide) {
            out.push(line);
        }
    }
    // A joint whose torque-residual alarm rose or cleared, named with its
    // axis and sign.
    if let Some(l) = last {
        let n = (s.joint_count as usize).min(s.joints.len());
        for (j, (now, was)) in s.joints[..n].iter().zip(&l.joints).enumerate() {
            if now.residual_alarm == was.residual_alarm {
                continue;
            }
            use anguilla_ipc::residual_bits as rb;
            for (axis, on, below, r) in [
                (
                    "pitch",
                    rb::PITCH,
                    rb::PITCH_BELOW,
                    now.pitch_torque_residual,
                ),
                ("yaw", rb::YAW, rb::YAW_BELOW, now.yaw_torque_residual),
            ] {
                let (a, b) = (
                    now.residual_alarm & (on | below),
                    was.residual_alarm & (on | below),
                );
                if a == b {
                    continue;
                }
                if a & on != 0 {
                    let sign = if a & below != 0 { "less" } else { "more" };
                    out.push((
                        3,
                        format!(
                            "joint {} {axis}: torque residual {r:+.2}, the joint needs {sign} \
                             torque than the model predicts (a snag, fouling, a failing \
                             actuator, a tether pulling?)",
                            j + 1
                        ),
                    ));
                } else {
                    out.push((
                        2,
                        format!(
                            "joint {} {axis}: torque residual back within its band",
                            j + 1
                        ),
                    ));
                }
            }
        }
    }
    // A sensor whose health changed, named by its kind and node id (after
    // the start: its first health is in `/anguilla/sensors`).
    if let Some(l) = last {
        for (e, was) in s.sensors.iter().zip(&l.sensors) {
            if e.kind == 0 || (e.kind, e.id, e.health) == (was.kind, was.id, was.health) {
                continue;
            }
            let kind = e
                .sensor_kind()
                .map_or("unknown sensor", anguilla_ipc::SensorKind::name);
            let health = SensorHealth::from_code(e.health);
            let level = match health {
                Some(SensorHealth::Ok | SensorHealth::Waiting) => 2,
                _ => 3,
            };
            let health = health.map_or("unknown", SensorHealth::name);
            out.push((level, format!("sensor {kind} (node {}): {health}", e.id)));
        }
    }
    out
}

/// The log line (level, text) for a hold state that went from `was` to
/// `now`, `words` its state in words: a hold that stops converging (a
/// warning) or converges again; none for other changes.
pub fn hold_line(now: u8, was: u8, words: Option<String>) -> Option<(u8, String)> {
    let failed = |c: u8| HoldState::from_code(c).is_some_and(HoldState::failed);
    let words = words?;
    if failed(now) && now != was {
        Some((3, format!("hold {words}")))
    } else if failed(was) && !failed(now) && now != HoldState::Off as u8 {
        Some((2, format!("hold {words}")))
    } else {
        None
    }
}

/// The log line (level, text) for the position's health going from
/// `was`'s to `now`'s: a stale fix a warning, a lost one an error, a fix
/// again information; none when it did not change.
pub fn position_line(now: &NavSnapshot, was: &NavSnapshot) -> Option<(u8, String)> {
    if now.position_health == was.position_health {
        return None;
    }
    let sigma = now.position_sigma_m;
    let age = f64::from(now.fix_age_ms) / 1e3;
    Some(match now.position_state() {
        Some(PositionHealth::Stale) => (
            3,
            format!("position: fix stale ({age:.1} s old), dead-reckoned, σ {sigma:.2} m"),
        ),
        Some(PositionHealth::Lost) => (
            4,
            format!(
                "position: fix lost ({age:.1} s old), dead-reckoned, σ {sigma:.2} m: not fit \
                 to steer by"
            ),
        ),
        Some(h @ (PositionHealth::Fixed | PositionHealth::Waiting)) => {
            (2, format!("position: {h}, σ {sigma:.2} m"))
        }
        Some(PositionHealth::DeadReckoning) => (2, "position: dead reckoning".to_string()),
        None => (3, format!("position: health {}", now.position_health)),
    })
}

/// The log line (level, text) for a path that started, moved on to its
/// next leg or ended between `was` and `now`: a path stopped (fix lost,
/// fence) an error, the rest information; none when neither its state
/// nor its leg changed.
pub fn guide_line(now: &GuideSnapshot, was: &GuideSnapshot) -> Option<(u8, String)> {
    if (now.state, now.leg) == (was.state, was.leg) {
        return None;
    }
    let state = now.guide_state();
    let leg = || {
        format!(
            "leg to waypoint {} of {} ({:.2}, {:.2}) m",
            now.leg, now.waypoints, now.to_x, now.to_y
        )
    };
    Some(match state {
        Some(GuideState::Following) => (2, format!("path: following, {}", leg())),
        Some(g @ (GuideState::FixLost | GuideState::Fence)) => (
            4,
            format!("path {g}, {:.2} m off the {}", now.cross_track_m, leg()),
        ),
        Some(g @ (GuideState::Done | GuideState::Interrupted | GuideState::Off)) => {
            (2, format!("path {g}"))
        }
        None => (3, format!("path: state {}", now.state)),
    })
}

/// The log line (level, text) for the robot reaching the surface (by the
/// daemon's estimate, a warning) or leaving it.
pub fn surface_line(surfaced: bool, depth: f32) -> (u8, String) {
    if surfaced {
        (3, format!("surfaced: the depth estimate is {depth:.2} m"))
    } else {
        (2, format!("back under the surface: depth {depth:.2} m"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A path's start, each new leg and its end are `/log` lines; a path
    /// stopped by a lost fix is an error.
    #[test]
    fn a_path_s_legs_and_its_end_are_logged() {
        let was = GuideSnapshot::default();
        let mut now = GuideSnapshot {
            state: GuideState::Following as u8,
            leg: 1,
            waypoints: 4,
            to_x: 5.0,
            ..Default::default()
        };
        let (level, line) = guide_line(&now, &was).expect("a line");
        assert_eq!(level, 2);
        assert!(
            line.contains("following, leg to waypoint 1 of 4 (5.00, 0.00)"),
            "{line}"
        );
        assert_eq!(guide_line(&now, &now), None, "no change, no line");
        let before = now;
        now.state = GuideState::FixLost as u8;
        let (level, line) = guide_line(&now, &before).expect("a line");
        assert_eq!(level, 4);
        assert!(line.contains("position fix lost"), "{line}");
    }

    /// The position's health changing is a `/log` line: a stale fix a
    /// warning, a lost one an error, fixed again information; no change,
    /// no line.
    #[test]
    fn the_positions_health_is_logged_as_it_changes() {
        let mut last = StateSnapshot::default();
        last.nav.position_health = PositionHealth::Fixed as u8;
        let mut s = last;
        assert!(log_lines(Some(&last), &s).is_empty());
        s.nav.position_health = PositionHealth::Stale as u8;
        s.nav.fix_age_ms = 6200;
        s.nav.position_sigma_m = 0.8;
        assert_eq!(
            log_lines(Some(&last), &s),
            [(
                3,
                "position: fix stale (6.2 s old), dead-reckoned, σ 0.80 m".to_string()
            )]
        );
        last = s;
        s.nav.position_health = PositionHealth::Lost as u8;
        s.nav.fix_age_ms = 31_000;
        let lines = log_lines(Some(&last), &s);
        assert_eq!(lines.len(), 1);
        assert_eq!(lines[0].0, 4);
        assert!(
            lines[0].1.starts_with("position: fix lost (31.0 s old)"),
            "{lines:?}"
        );
        last = s;
        s.nav.position_health = PositionHealth::Fixed as u8;
        assert_eq!(log_lines(Some(&last), &s)[0].0, 2);
    }

    /// A sensor's change of health is a `/log` line naming its kind and
    /// node; an unchanged one says nothing.
    #[test]
    fn a_sensor_that_changes_health_is_named_in_the_log() {
        let mut a = StateSnapshot::default();
        a.sensors[1] = anguilla_ipc::SensorEntry {
            kind: anguilla_ipc::SensorKind::TailImu as u8,
            id: 40,
            health: SensorHealth::Ok as u8,
            ..Default::default()
        };
        let mut b = a;
        assert!(log_lines(Some(&a), &b).is_empty());
        b.sensors[1].health = SensorHealth::Silent as u8;
        assert_eq!(
            log_lines(Some(&a), &b),
            [(3, "sensor tail-imu (node 40): silent".to_string())]
        );
        assert_eq!(
            log_lines(Some(&b), &a),
            [(2, "sensor tail-imu (node 40): ok".to_string())]
        );
    }

    /// Issue 46: a hold that stops converging is a warning naming its
    /// values; converging and holding are not news, converging again is;
    /// the robot at the surface is a warning, back under a note.
    #[test]
    fn a_hold_that_stops_converging_and_surfacing_are_logged() {
        let mut a = StateSnapshot::default();
        a.nav.depth_hold = HoldState::Converging as u8;
        a.nav.depth_m = 2.5;
        a.nav.depth_target_m = 1.2;
        let mut b = a;
        b.nav.depth_hold = HoldState::Holding as u8;
        assert!(log_lines(Some(&a), &b).is_empty());
        b.nav.depth_hold = HoldState::NotConverging as u8;
        assert_eq!(
            log_lines(Some(&a), &b),
            [(
                3,
                "hold not converging: depth 2.50 m for 1.20 m".to_string()
            )]
        );
        assert_eq!(
            log_lines(Some(&b), &a),
            [(2, "hold converging: depth 2.50 m for 1.20 m".to_string())]
        );
        let mut c = b;
        c.nav.depth_hold = HoldState::Surface as u8;
        c.nav.surfaced = 1;
        c.nav.depth_m = 0.01;
        assert_eq!(
            log_lines(Some(&b), &c),
            [
                (
                    3,
                    "hold cannot: at the surface: depth 0.01 m for 1.20 m".to_string()
                ),
                (3, "surfaced: the depth estimate is 0.01 m".to_string())
            ]
        );
        // Released: no line for the hold.
        let mut d = c;
        d.nav.depth_hold = 0;
        d.nav.surfaced = 0;
        assert_eq!(
            log_lines(Some(&c), &d),
            [(2, "back under the surface: depth 0.01 m".to_string())]
        );
    }
}
