//! Keyboard mapping of `anguilla teleop`: crossterm key events to [`Action`]s.

use crossterm::event::{KeyCode, KeyEvent, KeyEventKind, KeyModifiers};

use crate::app::Action;

/// The keys: (keys, short label on screen, longer description for the README).
pub const KEYS: &[(&str, &str, &str)] = &[
    (
        "↑/↓",
        "faster/slower",
        "swim amplitude up / down (from ready, ↑ starts swimming; down to 0 stops)",
    ),
    (
        "]/[",
        "freq up/down",
        "undulation frequency up / down (0.1 Hz steps)",
    ),
    (
        "←/→",
        "turn L / R",
        "turn left / right (0.25 /m steps); with a heading held, move the held heading 5° left / right",
    ),
    (
        "w/s",
        "dive / climb",
        "pitch down / up (0.25 /m steps); with a depth held, move the held depth 0.1 m deeper / shallower",
    ),
    (
        "h/p",
        "hold hdg/depth",
        "heading hold / depth hold on or off: captures the heading or depth estimated now (needs the head sensor; ends with the swim; at rest, armed for the next swim)",
    ),
    ("c", "straighten", "zero turn and pitch"),
    ("space", "stop swim", "stop swimming smoothly"),
    (
        "x/!",
        "E-STOP",
        "emergency stop (latched until reset; works without control)",
    ),
    ("e", "enable", "enable the actuators"),
    ("d", "disable", "disable the actuators"),
    ("r", "reset", "clear a fault or an E-stop"),
    ("t/g", "take/give ctl", "take control / give it back"),
    (
        "f",
        "follow path",
        "follow the path of --path FILE (from ready or swimming); while following, pause it (swim on straight, by hand); again, resume it on its leg; space stops",
    ),
    (
        "q",
        "quit",
        "quit: stops the swim and releases control first (also Ctrl-C)",
    ),
];

/// The action of a key press, if the key means one. Releases are ignored
/// (only terminals with the kitty protocol report them); auto-repeat counts
/// as presses. Ctrl-C quits.
pub fn action_for(key: KeyEvent) -> Option<Action> {
    if key.kind == KeyEventKind::Release {
        return None;
    }
    if key.modifiers.contains(KeyModifiers::CONTROL) {
        return match key.code {
            KeyCode::Char('c') | KeyCode::Char('C') => Some(Action::Quit),
            _ => None,
        };
    }
    Some(match key.code {
        KeyCode::Up => Action::Faster,
        KeyCode::Down => Action::Slower,
        KeyCode::Char(']') => Action::FrequencyUp,
        KeyCode::Char('[') => Action::FrequencyDown,
        KeyCode::Left => Action::TurnLeft,
        KeyCode::Right => Action::TurnRight,
        KeyCode::Char('w') | KeyCode::Char('W') => Action::Dive,
        KeyCode::Char('s') | KeyCode::Char('S') => Action::Climb,
        KeyCode::Char('c') | KeyCode::Char('C') => Action::Straighten,
        KeyCode::Char('h') | KeyCode::Char('H') => Action::HoldHeading,
        KeyCode::Char('p') | KeyCode::Char('P') => Action::HoldDepth,
        KeyCode::Char(' ') => Action::Stop,
        KeyCode::Char('x') | KeyCode::Char('X') | KeyCode::Char('!') => Action::EStop,
        KeyCode::Char('e') | KeyCode::Char('E') => Action::Enable,
        KeyCode::Char('f') | KeyCode::Char('F') => Action::Follow,
        KeyCode::Char('d') | KeyCode::Char('D') => Action::Disable,
        KeyCode::Char('r') | KeyCode::Char('R') => Action::Reset,
        KeyCode::Char('t') | KeyCode::Char('T') => Action::TakeControl,
        KeyCode::Char('g') | KeyCode::Char('G') => Action::ReleaseControl,
        KeyCode::Char('q') | KeyCode::Char('Q') => Action::Quit,
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crossterm::event::KeyEventState;

    fn press(code: KeyCode) -> KeyEvent {
        KeyEvent::new(code, KeyModifiers::NONE)
    }

    #[test]
    fn every_action_has_a_key() {
        use Action::*;
        let cases = [
            (KeyCode::Up, Faster),
            (KeyCode::Down, Slower),
            (KeyCode::Char(']'), FrequencyUp),
            (KeyCode::Char('['), FrequencyDown),
            (KeyCode::Left, TurnLeft),
            (KeyCode::Right, TurnRight),
            (KeyCode::Char('w'), Dive),
            (KeyCode::Char('s'), Climb),
            (KeyCode::Char('c'), Straighten),
            (KeyCode::Char('h'), HoldHeading),
            (KeyCode::Char('P'), HoldDepth),
            (KeyCode::Char(' '), Stop),
            (KeyCode::Char('x'), EStop),
            (KeyCode::Char('!'), EStop),
            (KeyCode::Char('e'), Enable),
            (KeyCode::Char('d'), Disable),
            (KeyCode::Char('r'), Reset),
            (KeyCode::Char('t'), TakeControl),
            (KeyCode::Char('g'), ReleaseControl),
            (KeyCode::Char('q'), Quit),
            (KeyCode::Char('Q'), Quit),
        ];
        for (code, action) in cases {
            assert_eq!(action_for(press(code)), Some(action), "{code:?}");
        }
    }

    #[test]
    fn releases_and_unknown_keys_do_nothing_and_ctrl_c_quits() {
        let release = KeyEvent {
            code: KeyCode::Up,
            modifiers: KeyModifiers::NONE,
            kind: KeyEventKind::Release,
            state: KeyEventState::NONE,
        };
        assert_eq!(action_for(release), None);
        let repeat = KeyEvent {
            kind: KeyEventKind::Repeat,
            ..release
        };
        assert_eq!(action_for(repeat), Some(Action::Faster));
        assert_eq!(action_for(press(KeyCode::Char('z'))), None);
        assert_eq!(action_for(press(KeyCode::F(5))), None);
        let ctrl_c = KeyEvent::new(KeyCode::Char('c'), KeyModifiers::CONTROL);
        assert_eq!(action_for(ctrl_c), Some(Action::Quit));
        let ctrl_x = KeyEvent::new(KeyCode::Char('x'), KeyModifiers::CONTROL);
        assert_eq!(action_for(ctrl_x), None);
    }
}
