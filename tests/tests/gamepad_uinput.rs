//! `anguilla joy` reading a real evdev device: a virtual gamepad made with
//! the kernel's uinput, with the buttons and axes of joy's default mapping
//! (as `anguilla joy --print-mapping` prints it), drives `anguilla run` (the
//! built-in simulated robot). Everything is checked in the daemon's
//! published state, through a client that only watches:
//!
//! - sticks and buttons without the deadman do nothing;
//! - deadman + start enables; the stick swims, the gait follows the sticks;
//! - the deadman released: one smooth stop (Stopping, then Ready), then
//!   joy says nothing more, so the daemon lets its control lapse;
//! - the E-stop button latches E-stop; reset and enable from the pad;
//! - unplugged while swimming: joy says so, the robot stops, joy runs on;
//! - `--device /dev/input/eventN`: joy refuses another device that takes
//!   the node meanwhile, and takes the pad back when it returns there;
//! - without `--device`: joy scans again and finds the pad replugged on
//!   another node.
//!
//! The tests are ignored under plain `cargo test` (they need
//! `/dev/uinput`); `scripts/vcan-vm` runs them in a VM whose kernel has
//! uinput. Run where there is none, they fail naming why.

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Command as Proc, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anguilla_ipc::{Cause, Client, Mode, StateSnapshot};
use anguilla_system_tests::Watchdog;
use anguilla_system_tests::process::{Killed, anguilla_bin, connect, poll_until};
use anguilla_teleop::app::Limits;
use anguilla_teleop::joy::JoyMapping;
use evdev::uinput::VirtualDevice;
use evdev::{
    AbsInfo, AbsoluteAxisCode, AttributeSet, EventType, InputEvent, KeyCode, UinputAbsSetup,
};

/// Bounds, not speed goals: the VM emulates its CPU (TCG) on a shared
/// 2-core machine, where enabling twelve simulated nodes takes seconds.
const T: Duration = Duration::from_secs(60);

/// The two tests each create gamepads, which the other's joy (scanning
/// `/dev/input` without `--device`) could pick up: one at a time.
static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

/// Whether uinput is usable here; the test fails naming why not
/// (anguilla_testkit::require: an ignored test that is run runs).
fn uinput_available() -> bool {
    let opened = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open("/dev/uinput");
    anguilla_testkit::require(opened.is_ok(), || {
        format!(
            "/dev/uinput cannot be opened ({}; scripts/vcan-vm runs this test for real)",
            opened
                .as_ref()
                .err()
                .map(|e| e.to_string())
                .unwrap_or_default()
        )
    });
    true
}

/// joy's default mapping, read back from `anguilla joy --print-mapping`.
fn printed_mapping() -> JoyMapping {
    let out = Proc::new(anguilla_bin())
        .args(["joy", "--print-mapping"])
        .output()
        .expect("anguilla joy --print-mapping runs");
    assert!(out.status.success(), "{out:?}");
    let text = String::from_utf8(out.stdout).unwrap();
    let m = JoyMapping::from_toml(&text, Limits::default()).expect("the printed mapping reads");
    assert_eq!(m, JoyMapping::default());
    m
}

/// A uinput device and its event node.
struct Virtual {
    dev: VirtualDevice,
    node: PathBuf,
}

impl Virtual {
    /// Registers the device `builder` describes and waits for its node.
    fn create(builder: evdev::uinput::VirtualDeviceBuilder) -> Virtual {
        let mut dev = builder.build().expect("uinput device created");
        let mut nodes = dev.enumerate_dev_nodes_blocking().expect("its sysfs entry");
        let node = nodes
            .next()
            .expect("an event node (the evdev handler: CONFIG_INPUT_EVDEV, module evdev)")
            .expect("its sysfs entry reads");
        poll_until(
            &format!("{} in devtmpfs", node.display()),
            Duration::from_secs(10),
            || node.exists().then_some(()),
        );
        Virtual { dev, node }
    }

    /// A gamepad with the mapping's buttons and axes (plus the usual other
    /// face buttons and the left stick's X), 16-bit sticks centred.
    fn gamepad(m: &JoyMapping, name: &'static str) -> Virtual {
        let mut keys = AttributeSet::<KeyCode>::new();
        for k in [
            m.deadman,
            m.estop,
            m.enable,
            m.disable,
            m.reset,
            KeyCode::BTN_SOUTH,
            KeyCode::BTN_WEST,
            KeyCode::BTN_TR,
            KeyCode::BTN_MODE,
        ] {
            keys.insert(k);
        }
        // Value, min, max, fuzz, flat, resolution: an Xbox pad's sticks.
        let stick = AbsInfo::new(0, -32768, 32767, 16, 128, 0);
        let mut b = VirtualDevice::builder()
            .expect("/dev/uinput opens")
            .name(name)
            .with_keys(&keys)
            .expect("keys");
        let mut axes = vec![AbsoluteAxisCode::ABS_X];
        for a in [m.speed.code, m.turn.code, m.pitch.code] {
            if !axes.contains(&a) {
                axes.push(a);
            }
        }
        for a in axes {
            b = b
                .with_absolute_axis(&UinputAbsSetup::new(a, stick))
                .expect("axis");
        }
        Virtual::create(b)
    }

    /// A keyboard (no deadman button, no stick): not a gamepad.
    fn keyboard() -> Virtual {
        let mut keys = AttributeSet::<KeyCode>::new();
        for k in [KeyCode::KEY_A, KeyCode::KEY_B, KeyCode::KEY_ENTER] {
            keys.insert(k);
        }
        Virtual::create(
            VirtualDevice::builder()
                .expect("/dev/uinput opens")
                .name("anguilla test keyboard")
                .with_keys(&keys)
                .expect("keys"),
        )
    }

    fn press(&mut self, code: KeyCode, pressed: bool) {
        let ev = InputEvent::new(EventType::KEY.0, code.code(), pressed as i32);
        self.dev.emit(&[ev]).expect("key event written");
    }

    /// Presses and releases `code`.
    fn click(&mut self, code: KeyCode) {
        self.press(code, true);
        self.press(code, false);
    }

    fn axis(&mut self, code: AbsoluteAxisCode, value: i32) {
        let ev = InputEvent::new(EventType::ABSOLUTE.0, code.0, value);
        self.dev.emit(&[ev]).expect("axis event written");
    }
}

/// `anguilla run` (the built-in simulated robot) under its own prefix, a
/// client that only watches its state, and `anguilla joy`.
struct Rig {
    prefix: String,
    watch: Client,
    joy: Option<Killed>,
    joy_lines: Arc<Mutex<Vec<String>>>,
    _daemon: Killed,
    dir: PathBuf,
}

impl Rig {
    fn start(name: &str) -> Rig {
        let dir = std::env::temp_dir().join(format!("anguilla-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let prefix = format!("anguilla-gamepad/{name}-{}", std::process::id());
        let config = dir.join("anguilla.toml");
        std::fs::write(
            &config,
            format!(
                // As in vcan_daemon.rs, for an emulated CPU: a 50 Hz loop,
                // heartbeats allowed 2 s, the nodes' watchdog 1 s. joy
                // sends every 100 ms; a 1 s command timeout keeps a joy
                // the emulation delays from counting as silent.
                "[control]\nrate-hz = 50.0\nheartbeat-timeout = 2.0\nenable-timeout = 10.0\n\
                 node-watchdog = 1.0\ncommand-timeout = 1.0\n[ipc]\nprefix = \"{prefix}\"\n"
            ),
        )
        .unwrap();
        let daemon = Killed(
            Proc::new(anguilla_bin())
                .args(["run", "--quiet", "--config"])
                .arg(&config)
                .stdout(Stdio::null())
                .spawn()
                .expect("anguilla run starts"),
        );
        let watch = connect(&prefix, "gamepad-watch");
        let mut rig = Rig {
            prefix,
            watch,
            joy: None,
            joy_lines: Arc::default(),
            _daemon: daemon,
            dir,
        };
        rig.until("the daemon idle", |s| s.mode == Mode::Idle as u8);
        rig
    }

    /// Starts `anguilla joy` with `args`, its stderr collected.
    fn start_joy(&mut self, args: &[&str]) {
        let mut child = Proc::new(anguilla_bin())
            .args(["joy", "--prefix", &self.prefix])
            .args(args)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("anguilla joy starts");
        let err = child.stderr.take().unwrap();
        let lines = self.joy_lines.clone();
        std::thread::spawn(move || {
            for l in BufReader::new(err).lines().map_while(Result::ok) {
                eprintln!("  | {l}");
                lines.lock().unwrap().push(l);
            }
        });
        self.joy = Some(Killed(child));
    }

    /// How many lines joy has written so far.
    fn said(&self) -> usize {
        self.joy_lines.lock().unwrap().len()
    }

    /// Waits for a line of joy's (from line `from` on) containing every
    /// one of `parts`; returns it.
    fn joy_says(&mut self, from: usize, parts: &[&str]) -> String {
        poll_until(&format!("anguilla joy saying {parts:?}"), T, || {
            self.assert_joy_runs();
            let lines = self.joy_lines.lock().unwrap();
            lines
                .iter()
                .skip(from)
                .find(|l| parts.iter().all(|p| l.contains(p)))
                .cloned()
        })
    }

    fn joy_output(&self) -> String {
        self.joy_lines.lock().unwrap().join("\n")
    }

    fn assert_joy_runs(&mut self) {
        let joy = &mut self.joy.as_mut().expect("joy started").0;
        if let Some(status) = joy.try_wait().unwrap() {
            panic!(
                "anguilla joy exited ({status}); it said:\n{}",
                self.joy_output()
            );
        }
    }

    /// Watches the state (sending nothing) until `f` holds; panics naming
    /// `what`, the last state and joy's output otherwise.
    fn until(&mut self, what: &str, mut f: impl FnMut(&StateSnapshot) -> bool) -> StateSnapshot {
        let end = anguilla_testkit::Deadline::new(T);
        let mut last = None;
        while !end.passed() {
            if let Some(s) = self.watch.wait_state(Duration::from_millis(100)).unwrap() {
                if f(&s) {
                    return s;
                }
                last = Some(s);
            }
        }
        panic!(
            "{what}: not within {T:?}; last mode {:?} cause {:?} holder {:?}; joy said:\n{}",
            last.map(|s| s.mode),
            last.map(|s| s.cause),
            last.map(|s| s.holder()),
            self.joy_output()
        );
    }

    /// Every state for `d` (sending nothing).
    fn states_for(&mut self, d: Duration) -> Vec<StateSnapshot> {
        let end = Instant::now() + d;
        let mut out = vec![];
        while Instant::now() < end {
            if let Some(s) = self.watch.wait_state(Duration::from_millis(50)).unwrap() {
                out.push(s);
            }
        }
        out
    }

    /// Watches a swim end: asserts one smooth stop by a command (Stopping,
    /// then Ready; no e-stop, no silence stop) and returns the states seen.
    /// The daemon keeps only the newest states for a watcher, so a
    /// Stopping shorter than a poll could be missed: callers stop from a
    /// swing of at least 0.3, which takes over half a second to ramp down
    /// (`gait.amplitude-rate` 0.5/s).
    fn one_stop(&mut self, what: &str) -> Vec<StateSnapshot> {
        let mut seen = vec![];
        self.until(&format!("ready after {what}"), |s| {
            seen.push(*s);
            s.mode == Mode::Ready as u8
        });
        let mut path = mode_path(&seen);
        if path.first() == Some(&Mode::Swimming) {
            path.remove(0); // states from before the stop took effect
        }
        assert_eq!(
            path,
            [Mode::Stopping, Mode::Ready],
            "{what}: one smooth stop"
        );
        let stopping = seen.iter().find(|s| s.mode == Mode::Stopping as u8);
        assert_eq!(
            stopping.and_then(|s| Cause::from_code(s.cause)),
            Some(Cause::Command),
            "{what}: stopped by joy's stop, not by its silence"
        );
        assert_eq!(seen.last().unwrap().operator_silent_stops, 0, "{what}");
        seen
    }

    /// With the deadman held: enable, wait for Ready.
    fn enable(&mut self, pad: &mut Virtual, m: &JoyMapping) {
        pad.click(m.enable);
        self.until("ready after start (deadman held)", |s| {
            s.mode == Mode::Ready as u8
        });
    }
}

impl Drop for Rig {
    fn drop(&mut self) {
        self.joy = None;
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// Modes in the order they were seen, repeats collapsed.
fn mode_path(states: &[StateSnapshot]) -> Vec<Mode> {
    let mut path: Vec<Mode> = vec![];
    for s in states {
        let m = Mode::from_code(s.mode).expect("a mode code");
        if path.last() != Some(&m) {
            path.push(m);
        }
    }
    path
}

/// The amplitude joy asks for with the speed stick at `raw` (of
/// -32768..=32767, pushed forward is negative): the inverted position
/// with the default 0.15 deadzone cut out, as docs/operating.md's mapping table
/// describes it. Written out here rather than with joy's functions.
fn amplitude_at(raw: i32) -> f64 {
    let x = -(2.0 * (raw as f64 + 32768.0) / 65535.0 - 1.0);
    ((x - 0.15) / 0.85).clamp(0.0, 1.0)
}

#[test]
#[ignore = "needs /dev/uinput (virtual gamepads): scripts/vcan-vm runs it"]
fn joy_drives_from_a_uinput_gamepad_stops_once_estops_and_survives_replug() {
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    if !uinput_available() {
        return;
    }
    let _dog = Watchdog::new("gamepad uinput (--device)", Duration::from_secs(400));
    let m = printed_mapping();
    let mut rig = Rig::start("device");
    let limits = Limits::from_snapshot(&rig.until("a state", |_| true).limits);
    let mut pad = Virtual::gamepad(&m, "anguilla test gamepad");
    let node = pad.node.to_str().unwrap().to_string();
    rig.start_joy(&["--device", &node]);
    rig.joy_says(0, &["using anguilla test gamepad", &node]);

    // Without the deadman: the stick pushed, start pressed, nothing.
    pad.axis(m.speed.code, -32768);
    pad.click(m.enable);
    let quiet = rig.states_for(Duration::from_secs(2));
    assert!(!quiet.is_empty(), "states while the deadman is up");
    for s in &quiet {
        assert_eq!(s.mode, Mode::Idle as u8, "no enable without the deadman");
        assert_eq!(s.holder(), None, "no control without the deadman");
    }
    pad.axis(m.speed.code, 0);

    // Deadman: control; start: enable; the stick: swim.
    pad.press(m.deadman, true);
    let s = rig.until("control taken by the deadman", |s| s.holder().is_some());
    let joy_id = s.holder().unwrap();
    rig.enable(&mut pad, &m);
    pad.axis(m.speed.code, -32768);
    pad.axis(m.turn.code, -32768);
    let s = rig.until("swimming at full speed, turning left", |s| {
        s.mode == Mode::Swimming as u8 && s.gait_target.amplitude == 1.0
    });
    assert_eq!(s.holder(), Some(joy_id));
    assert_eq!(s.gait_target.turn, limits.max_turn as f32, "full left");
    assert_eq!(s.gait_target.pitch, 0.0, "pitch stick centred");
    assert_eq!(s.gait_target.frequency, m.frequency as f32);
    // The gait follows the stick: half forward, turn stick centred,
    // pitch stick full forward (dive).
    pad.axis(m.speed.code, -16384);
    pad.axis(m.turn.code, 0);
    pad.axis(m.pitch.code, -32768);
    let want = amplitude_at(-16384);
    // f32 in the snapshot: 1e-6; the stick's raw step is 1/65535 of the
    // range, which the expected value already includes.
    let s = rig.until("the gait following the sticks", |s| {
        ((s.gait_target.amplitude as f64) - want).abs() < 1e-5 && s.gait_target.turn == 0.0
    });
    assert_eq!(s.gait_target.pitch, limits.max_pitch as f32, "full dive");
    rig.until("the body swinging", |s| s.gait_actual.amplitude > 0.3);

    // Deadman released: one smooth stop, then silence: no keep-alive, so
    // the daemon lets joy's control lapse (control-release-timeout, 3 s).
    pad.press(m.deadman, false);
    rig.one_stop("the deadman's release");
    let lapsed = rig.until("control lapsed after the stop", |s| s.holder().is_none());
    assert_eq!(lapsed.mode, Mode::Ready as u8);
    assert_eq!(lapsed.operator_silent_stops, 0);
    assert_eq!(lapsed.refused_commands, 0, "{}", rig.joy_output());

    // The operator lets the sticks go too (else the next deadman press
    // would ask for a swim at once, which the daemon refuses until Ready).
    pad.axis(m.speed.code, 0);
    pad.axis(m.pitch.code, 0);

    // E-stop button, deadman up: latched.
    pad.click(m.estop);
    rig.until("e-stop from the button", |s| s.mode == Mode::EStop as u8);
    let latched = rig.states_for(Duration::from_secs(2));
    assert!(
        latched.iter().all(|s| s.mode == Mode::EStop as u8),
        "latched: {:?}",
        mode_path(&latched)
    );
    // Reset and enable from the pad.
    pad.press(m.deadman, true);
    pad.click(m.reset);
    rig.until("idle after reset", |s| s.mode == Mode::Idle as u8);
    rig.enable(&mut pad, &m);
    pad.axis(m.speed.code, -32768);
    rig.until("swimming again", |s| {
        s.mode == Mode::Swimming as u8 && s.gait_actual.amplitude > 0.3
    });

    // Unplugged while swimming: joy says so and sends one stop; it runs on.
    let from = rig.said();
    let old_node = pad.node.clone();
    drop(pad);
    rig.one_stop("the unplug");
    rig.joy_says(from, &["the gamepad disappeared (one stop sent)"]);
    rig.joy_says(from, &["no gamepad found", "cannot open", &node]);

    // Another device takes the node: --device names a node, and joy does
    // not drive with a keyboard.
    let from = rig.said();
    let kbd = Virtual::keyboard();
    assert_eq!(
        kbd.node, old_node,
        "the kernel gives the lowest free event node"
    );
    rig.joy_says(
        from,
        &[
            &node,
            "anguilla test keyboard",
            &format!("no {:?} button", m.deadman),
        ],
    );
    assert!(!rig.joy_output()[..].contains("using anguilla test keyboard"));

    // The pad back on its node: joy takes it again and drives.
    drop(kbd);
    let from = rig.said();
    let mut pad = Virtual::gamepad(&m, "anguilla test gamepad");
    assert_eq!(pad.node, old_node, "replugged on the same node");
    rig.joy_says(from, &["using anguilla test gamepad", &node]);
    pad.press(m.deadman, true);
    pad.axis(m.speed.code, -32768);
    rig.until("swimming after the replug", |s| {
        s.mode == Mode::Swimming as u8
    });
    pad.press(m.deadman, false);
    let s = rig.until("ready after the last release", |s| {
        s.mode == Mode::Ready as u8
    });
    assert_eq!(s.operator_silent_stops, 0);
    assert_eq!(s.refused_commands, 0, "joy said:\n{}", rig.joy_output());
    rig.assert_joy_runs();
}

#[test]
#[ignore = "needs /dev/uinput (virtual gamepads): scripts/vcan-vm runs it"]
fn joy_without_a_device_finds_the_pad_replugged_on_another_node() {
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    if !uinput_available() {
        return;
    }
    let _dog = Watchdog::new("gamepad uinput (scan)", Duration::from_secs(300));
    let m = printed_mapping();
    let others: Vec<PathBuf> = evdev::enumerate()
        .filter(|(_, d)| {
            d.supported_keys().is_some_and(|k| k.contains(m.deadman))
                && d.supported_absolute_axes()
                    .is_some_and(|a| a.contains(m.speed.code))
        })
        .map(|(p, _)| p)
        .collect();
    if !others.is_empty() {
        // A real pad would be found first; the test needs to know which.
        anguilla_testkit::require(false, || {
            format!("gamepads already plugged in ({others:?}) would be scanned first")
        });
        return;
    }
    let mut rig = Rig::start("scan");
    // A keyboard is there from the start: never taken for a pad.
    let kbd = Virtual::keyboard();
    rig.start_joy(&[]);
    rig.joy_says(0, &["no gamepad found", "no readable /dev/input/event*"]);
    let mut pad = Virtual::gamepad(&m, "anguilla test gamepad 2");
    let first = pad.node.clone();
    rig.joy_says(
        0,
        &["using anguilla test gamepad 2", first.to_str().unwrap()],
    );
    pad.press(m.deadman, true);
    rig.until("control", |s| s.holder().is_some());
    rig.enable(&mut pad, &m);
    pad.axis(m.speed.code, -32768);
    rig.until("swimming", |s| {
        s.mode == Mode::Swimming as u8 && s.gait_actual.amplitude > 0.3
    });

    // Unplugged while swimming; a second keyboard takes the freed node, so
    // the pad comes back on another one.
    let from = rig.said();
    drop(pad);
    rig.one_stop("the unplug");
    rig.joy_says(from, &["the gamepad disappeared (one stop sent)"]);
    let kbd2 = Virtual::keyboard();
    let mut pad = Virtual::gamepad(&m, "anguilla test gamepad 2");
    assert_ne!(pad.node, first, "the pad is back on another node");
    let second = pad.node.to_str().unwrap().to_string();
    rig.joy_says(from, &["using anguilla test gamepad 2", &second]);
    pad.press(m.deadman, true);
    pad.axis(m.speed.code, -32768);
    rig.until("swimming after the replug", |s| {
        s.mode == Mode::Swimming as u8
    });
    pad.press(m.deadman, false);
    let s = rig.until("ready after the release", |s| s.mode == Mode::Ready as u8);
    assert_eq!(s.operator_silent_stops, 0);
    assert_eq!(s.refused_commands, 0, "joy said:\n{}", rig.joy_output());
    let output = rig.joy_output();
    assert!(!output.contains("using anguilla test keyboard"), "{output}");
    drop((kbd, kbd2));
}
