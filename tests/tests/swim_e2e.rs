//! End to end: the daemon's real-time loop drives the simulated robot (twelve
//! vertebra nodes and the swimming body) on an in-process bus with CAN wire
//! time, and an operator client on iceoryx2 makes it swim, turn and stop.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use anguilla_daemon::config::Config;
use anguilla_daemon::run;
use anguilla_drivers::mem::MemBus;
use anguilla_ipc::Client;
use anguilla_ipc::{Command, Mode, SwimParams};
use anguilla_protocol::message::Variant;
use anguilla_sim::robot::{RobotConfig, RunningSim, SimRobot};
use anguilla_system_tests::process::{REPLY, tracking};

struct System {
    client: Client,
    sim: Option<RunningSim>,
    daemon: Option<run::Running>,
}

impl System {
    fn start(name: &str) -> Self {
        let mut cfg = Config::default();
        cfg.ipc.prefix = format!("anguilla-test/{name}-{}", std::process::id());
        // The simulated robot shares this process's CPU, as the built-in
        // one does: its timeouts (tests/lib.rs `family_config` says why).
        cfg.relax_for_builtin();
        let bus = MemBus::builder(name)
            .bitrate(cfg.bus.bitrate)
            .capacity(4096)
            .build();
        let clock = bus.clock();
        let rc = RobotConfig {
            variant: Variant::Classic,
            boot_time: Duration::from_millis(50),
            ..RobotConfig::with_joints(12)
        };
        let sim = SimRobot::on_mem(rc, bus.participant(), clock.now())
            .expect("robot")
            .spawn(clock)
            .expect("robot thread");
        let prefix = cfg.ipc.prefix.clone();
        let daemon = run::spawn(
            cfg,
            Box::new(bus.participant()),
            Arc::new(AtomicBool::new(false)),
        )
        .expect("daemon");
        let client = Client::new(&prefix, "e2e-operator").expect("client");
        Self {
            client,
            sim: Some(sim),
            daemon: Some(daemon),
        }
    }

    fn ok(&mut self, cmd: Command) {
        let r = self.client.request(cmd, REPLY).expect("reply");
        assert_eq!(r.accepted, 1, "{} refused: {}", cmd.name(), r.reason());
    }

    /// Keeps the command alive for `seconds`, returning the last state.
    fn hold(&mut self, cmd: Command, seconds: f64) -> anguilla_ipc::StateSnapshot {
        *self.hold_all(cmd, seconds).last().expect("state published")
    }

    /// Keeps sending `cmd` for `seconds`; every state received, with the
    /// time since the start.
    fn hold_all(&mut self, cmd: Command, seconds: f64) -> Vec<anguilla_ipc::StateSnapshot> {
        let end = Instant::now() + Duration::from_secs_f64(seconds);
        let mut all = Vec::new();
        while Instant::now() < end {
            self.client.send(cmd).expect("send");
            if let Ok(Some(s)) = self.client.wait_state(Duration::from_millis(100)) {
                all.push(s);
            }
            self.client.replies(|_| {}).ok();
        }
        all
    }

    fn wait_mode(&mut self, mode: Mode, timeout: f64) {
        let end = anguilla_testkit::Deadline::new(Duration::from_secs_f64(timeout));
        while !end.passed() {
            self.client.send(Command::KeepAlive).ok();
            if let Ok(Some(s)) = self.client.wait_state(Duration::from_millis(100))
                && s.mode == mode as u8
            {
                return;
            }
            self.client.replies(|_| {}).ok();
        }
        panic!("mode {mode} not reached within {timeout} s");
    }
}

impl Drop for System {
    fn drop(&mut self) {
        if let Some(d) = self.daemon.take() {
            d.request_stop();
            let _ = d.join();
        }
        if let Some(s) = self.sim.take() {
            let _ = s.stop();
        }
    }
}

#[test]
fn the_robot_swims_turns_and_stops_under_the_daemon() {
    let mut sys = System::start("e2e-swim");
    // Every node has booted and reports Disabled (protocol state 1).
    let end = anguilla_testkit::Deadline::new(Duration::from_secs(10));
    loop {
        let booted = sys
            .client
            .wait_state(Duration::from_millis(100))
            .ok()
            .flatten()
            .is_some_and(|s| {
                s.joints[..12]
                    .iter()
                    .all(|j| j.node_alive == 1 && j.node_state == 1)
            });
        if booted {
            break;
        }
        assert!(!end.passed(), "the simulated nodes did not boot");
    }
    sys.ok(Command::TakeControl);
    sys.ok(Command::Enable);
    sys.wait_mode(Mode::Ready, 5.0);
    let forward = Command::Swim(SwimParams {
        amplitude: 1.0,
        frequency: 1.0,
        turn: 0.0,
        pitch: 0.0,
    });
    sys.ok(forward);
    let s = sys.hold(forward, 6.0);
    assert_eq!(s.mode, Mode::Swimming as u8);
    let truth = sys.sim.as_ref().unwrap().truth();
    // The simulated robot swims head first (F1 at full amplitude: the
    // model's 12-joint robot reaches about 0.37 m/s in steady state; after
    // 6 s from rest it is still accelerating).
    assert!(
        truth.forward_speed > 0.15,
        "simulated speed {} m/s",
        truth.forward_speed
    );
    // The model's prediction is in the same range as what the robot does.
    let predicted = s.predicted_head_speed as f64;
    assert!(
        (predicted - truth.forward_speed).abs() < 0.5 * truth.forward_speed,
        "predicted {predicted} vs simulated {}",
        truth.forward_speed
    );
    eprintln!(
        "after 6 s of F1: simulated speed {:.3} m/s, predicted {predicted:.3} m/s",
        truth.forward_speed
    );
    // The joints track their setpoints: the tail's measured yaw against
    // its command at the lag that fits best (tests::process::tracking).
    let (worst, lag, n) = tracking(&mut sys.client, 11, 2.0, forward);
    assert!(
        worst < 0.08,
        "tail yaw tracking error {worst} rad (median) at its best lag {lag} ms ({n} states)"
    );
    // Turn: the head's yaw changes.
    let yaw0 = truth.yaw;
    let turn = Command::Swim(SwimParams {
        amplitude: 1.0,
        frequency: 1.0,
        turn: 1.5,
        pitch: 0.0,
    });
    sys.ok(turn);
    let states = sys.hold_all(turn, 2.5);
    let during = *states.last().expect("state published");
    let yaw1 = sys.sim.as_ref().unwrap().truth().yaw;
    let turned = (yaw1 - yaw0 + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI)
        - std::f64::consts::PI;
    // A positive turn is to the left: yaw (about e3, up) increases, and the
    // model predicts a positive turn rate too.
    assert!(turned > 0.3, "turned {turned} rad");
    // The predicted rate oscillates with the undulation (it can be negative
    // at some instants): its mean over the last gait period (1 s) is
    // positive, whatever instant the last state fell on.
    let last_second = &states[states.len().saturating_sub(states.len() * 2 / 5)..];
    let mean_rate = last_second
        .iter()
        .map(|s| s.predicted_turn_rate as f64)
        .sum::<f64>()
        / last_second.len() as f64;
    assert!(mean_rate > 0.0, "mean predicted turn rate {mean_rate}");
    eprintln!(
        "turn +1.5 /m for 2.5 s: head yaw changed by {:+.1}°, predicted turn rate {:+.2} rad/s \
         (mean of the last second; {:+.2} at the last state)",
        turned.to_degrees(),
        mean_rate,
        during.predicted_turn_rate
    );
    // Dive: a positive pitch curvature takes the head down (e3 is up).
    let z0 = sys.sim.as_ref().unwrap().truth().position[2];
    let dive = Command::Swim(SwimParams {
        amplitude: 1.0,
        frequency: 1.0,
        turn: 0.0,
        pitch: 0.8,
    });
    sys.ok(dive);
    sys.hold(dive, 2.5);
    let z1 = sys.sim.as_ref().unwrap().truth().position[2];
    eprintln!(
        "pitch +0.8 /m for 2.5 s: head depth changed by {:+.3} m",
        z1 - z0
    );
    assert!(z1 - z0 < -0.05, "dived {} m", z1 - z0);
    // Stop: ramps down to Ready, body straight.
    sys.ok(Command::Stop);
    sys.wait_mode(Mode::Ready, 15.0);
    let straight = sys.sim.as_ref().unwrap().truth().joints;
    let bent = straight
        .iter()
        .flatten()
        .fold(0.0f64, |m, a| m.max(a.abs()));
    assert!(bent < 0.05, "joints straight after the stop: {bent} rad");
}
