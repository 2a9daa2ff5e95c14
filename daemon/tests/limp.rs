//! A joint that goes limp while the robot swims is a fault, in every drive
//! family, whoever made it limp (issue 45): the attacks, on the rig's
//! simulated time (the controller and the family's simulated drives on an
//! in-process bus, stepped in lockstep).
//!
//! - a node that reboots mid-swim: a fault naming it and what it reported
//!   (Boot, or Disabled once booted);
//! - another sender's state-changing command to one of our drives (a
//!   one-byte Disable, `083#02`; an NMT reset; Set axis state Idle; Set
//!   zero, Enter motor mode): an E-stop from the bus, naming the joint;
//! - MIT: a reply with an error code, a faulted drive falling silent, a
//!   reply with every field at the top of its range;
//! - the second line (`anguilla_daemon::tracking`): a copier replaying a
//!   dead joint's last frames (frozen feedback) and a jammed joint
//!   (tracking error), in every family;
//! - the healthy swim beside them: no fault (the false-positive check).
//!
//! The same attacks against the daemon's real loop and the built-in robot
//! (real time, the swimming body's loads) are in
//! `tests/tests/liveness.rs`.

mod rig;

use anguilla_daemon::config::Config;
use anguilla_ipc::vocabulary::{Command, FaultKind, FaultSet, Mode, SwimParams};
use anguilla_protocol::Family;
use anguilla_protocol::frame::Frame;
use anguilla_protocol::{canopen, mit, odrive};
use rig::Rig;

/// Joint 3 (index 2): its report id is 3 in every family of the default
/// configuration (anguilla's node ids are 1..=joints).
const JOINT: usize = 2;
const REPORT_ID: u64 = 3;

fn config(drive: Family) -> Config {
    let mut cfg = Config::default();
    cfg.robot.drive = drive;
    // A CiA 402 drive heartbeats once configured by SDO, which takes the
    // rig about 0.5 s: past the default timeout (0.35 s), its boot would
    // latch "heartbeat lost" in Idle (where it changes nothing, but it
    // stays in the faults these tests read).
    cfg.control.heartbeat_timeout = 1.0;
    cfg.validate().expect("valid");
    cfg
}

/// A rig of `drive`'s family swimming F1 at full amplitude for a second,
/// client 1 holding control.
fn swimming(name: &str, drive: Family) -> Rig {
    swimming_with(name, &config(drive))
}

/// A rig of `cfg` swimming F1 at full amplitude for a second, client 1
/// holding control.
fn swimming_with(name: &str, cfg: &Config) -> Rig {
    let mut r = Rig::new(name, cfg);
    // Boot (CiA 402: configuration by SDO).
    r.run_for(0.6);
    assert_eq!(r.command(1, Command::TakeControl).accepted, 1);
    assert_eq!(r.command(1, Command::Enable).accepted, 1);
    r.run_for(0.3);
    assert_eq!(r.ctl.supervisor().mode(), Mode::Ready, "{name}");
    let swim = Command::Swim(SwimParams {
        amplitude: 1.0,
        frequency: 1.0,
        turn: 0.0,
        pitch: 0.0,
    });
    assert_eq!(r.command(1, swim).accepted, 1);
    keep_swimming(&mut r, 1.0);
    assert_eq!(r.ctl.supervisor().mode(), Mode::Swimming, "{name}");
    let f = r.ctl.supervisor().faults();
    assert!(f.is_empty(), "{name}: {f}");
    r
}

/// Runs `seconds` with the holder sending keep-alives (the command timeout
/// is 0.5 s).
fn keep_swimming(r: &mut Rig, seconds: f64) {
    let steps = (seconds / 0.2).ceil() as usize;
    for _ in 0..steps {
        r.command(1, Command::KeepAlive);
        r.run_for(0.2);
    }
}

/// Runs until the supervisor leaves Swimming (at most `seconds`) and
/// returns the faults.
fn until_not_swimming(r: &mut Rig, seconds: f64) -> FaultSet {
    let period = r.ctl.period_ns().as_nanos() as f64 * 1e-9;
    for i in 0..(seconds / period).ceil() as usize {
        if r.ctl.supervisor().mode() != Mode::Swimming {
            break;
        }
        if i % 20 == 0 {
            r.command(1, Command::KeepAlive);
        }
        r.step();
    }
    r.ctl.supervisor().faults()
}

fn reboot_joint(r: &mut Rig) {
    let now = r.now;
    match r.nodes.get_mut(JOINT) {
        Some(n) => n.reboot(now),
        None => r.joints[JOINT].reboot(now),
    }
}

/// The attack: joint 3's drives reboot mid-swim. Before issue 45 the
/// anguilla, CiA 402 and ODrive masters showed the joint Boot/Disabled and
/// the robot swam on. MIT drives have no state to report: a rebooted MIT
/// drive is caught by what it does (`the_second_line` below).
#[test]
fn a_joint_that_reboots_mid_swim_faults_naming_it() {
    for drive in [Family::Anguilla, Family::Cia402, Family::Odrive] {
        let name = format!("limp-reboot-{}", drive.name());
        let mut r = swimming(&name, drive);
        reboot_joint(&mut r);
        let f = until_not_swimming(&mut r, 1.0);
        assert_eq!(r.ctl.supervisor().mode(), Mode::Fault, "{name}: {f}");
        let limp = f.contains(FaultKind::NodeRebooted) || f.contains(FaultKind::NodeDisabled);
        assert!(limp, "{name}: {f}");
        assert_eq!(f.nodes, 1 << REPORT_ID, "{name}: joint 3 named: {f}");
        eprintln!("{name}: {f}");
        // Not a cause that lasts: the node is back (disabled), the reset
        // goes through and the robot enables again.
        r.run_for(0.5);
        assert_eq!(r.command(1, Command::Reset).accepted, 1, "{name}");
        r.run_for(0.6);
        assert_eq!(r.command(1, Command::Enable).accepted, 1, "{name}");
        r.run_for(0.6);
        assert_eq!(r.ctl.supervisor().mode(), Mode::Ready, "{name}");
    }
}

/// Another sender's state-changing commands to joint 3's drives (the
/// pitch drive, for the families with one drive per axis), by family.
fn foreign_commands(cfg: &Config) -> Vec<(&'static str, Frame)> {
    let pitch = cfg.axes()[JOINT][0].node;
    match cfg.robot.drive {
        // One byte, as `cansend can0 083#02` sends it: Command to node 3,
        // Disable. Enable and ClearFaults (01, 03) change state as well.
        Family::Anguilla => vec![
            ("disable", Frame::new_standard(0x083, &[0x02]).unwrap()),
            ("clear faults", Frame::new_standard(0x083, &[0x03]).unwrap()),
            ("enable", Frame::new_standard(0x083, &[0x01]).unwrap()),
        ],
        Family::Cia402 => {
            let node = Some(canopen::NodeId::new(pitch).unwrap());
            let nmt = |command| canopen::Message::Nmt { command, node }.encode();
            vec![
                ("NMT reset node", nmt(canopen::NmtCommand::ResetNode)),
                (
                    "NMT pre-operational",
                    nmt(canopen::NmtCommand::EnterPreOperational),
                ),
            ]
        }
        Family::Odrive => {
            let node = odrive::NodeId::new(pitch).unwrap();
            let m = |body| odrive::Message { node, body }.encode().unwrap();
            vec![
                (
                    "set axis state idle",
                    m(odrive::Body::SetAxisState(odrive::AxisState::Idle)),
                ),
                (
                    "clear errors",
                    m(odrive::Body::ClearErrors { identify: false }),
                ),
            ]
        }
        Family::Mit => {
            let node = mit::NodeId::new(pitch).unwrap();
            let m = |body| {
                mit::Message { node, body }
                    .encode(&mit::DEFAULT_RANGES)
                    .unwrap()
            };
            vec![
                ("set zero", m(mit::Body::SetZero)),
                ("enter motor mode", m(mit::Body::EnterMotorMode)),
            ]
        }
    }
}

/// The attack: another sender on the bus tells one of joint 3's drives to
/// change state mid-swim. Before issue 45 only a foreign E-stop frame was
/// an E-stop: a one-byte Disable left the joint limp and the robot swam
/// on, silently; a foreign Set zero or Enter motor mode was only counted.
#[test]
fn a_foreign_drive_command_mid_swim_is_an_estop_naming_the_joint() {
    for drive in Family::ALL {
        let cfg = config(drive);
        for (what, frame) in foreign_commands(&cfg) {
            let name = format!("limp-foreign-{}-{}", drive.name(), what.replace(' ', "-"));
            let mut r = swimming(&name, drive);
            let counted = r.ctl.drives().counters().foreign_commands;
            r.bus.inject(&frame);
            let f = until_not_swimming(&mut r, 0.2);
            assert_eq!(r.ctl.supervisor().mode(), Mode::EStop, "{name}: {f}");
            assert!(f.contains(FaultKind::ForeignCommand), "{name}: {f}");
            assert_eq!(f.nodes, 1 << REPORT_ID, "{name}: joint 3 named: {f}");
            assert_eq!(
                r.ctl.drives().counters().foreign_commands,
                counted + 1,
                "{name}: counted too"
            );
            eprintln!("{name}: {f}");
        }
    }
}

/// A reply from joint 3's pitch drive, as another sender (or the drive)
/// puts it on the bus: position, velocity, torque and the error code.
fn mit_reply(cfg: &Config, error: u8) -> Frame {
    mit_reply_of(cfg, 0, error)
}

/// A reply from joint 3's drive of `axis` (0 pitch, 1 yaw).
fn mit_reply_of(cfg: &Config, axis: usize, error: u8) -> Frame {
    mit::Message {
        node: mit::NodeId::new(cfg.axes()[JOINT][axis].node).unwrap(),
        body: mit::Body::Reply(mit::Reply {
            position: 0.0,
            velocity: 0.0,
            torque: 0.0,
            status: Some(mit::Status {
                temperature: 30,
                error,
            }),
        }),
    }
    .encode(&mit::DEFAULT_RANGES)
    .unwrap()
}

/// One control period with `frame` put on the bus after the controller's
/// frames and before the drives answer them: the drives' own replies
/// follow it, as they would a drive's one bad reply.
fn step_with(r: &mut Rig, frame: &Frame) {
    r.ctl.run_period(r.now, &mut r.host);
    r.bus.inject(frame);
    r.nodes_step();
}

/// The attack (issue 45): one MIT reply carrying an error code, the
/// drive's next replies clean. Before, motor mode ended for good with no
/// fault (the drive shown Disabled) and its replies were no longer
/// counted. Now the code is latched until faults are cleared: a fault
/// naming the joint, with its code, whatever the replies after it say.
#[test]
fn mit_a_reply_with_an_error_code_is_a_fault_until_cleared() {
    let name = "limp-mit-error-code";
    let cfg = config(Family::Mit);
    let mut r = swimming(name, Family::Mit);
    step_with(&mut r, &mit_reply(&cfg, mit::error_code::OVER_CURRENT));
    let f = until_not_swimming(&mut r, 0.2);
    assert_eq!(r.ctl.supervisor().mode(), Mode::Fault, "{f}");
    assert_eq!(f.to_string(), "actuator fault (node 3)");
    // A second of clean replies later, still faulted, with the code.
    r.run_for(1.0);
    let j = r.ctl.drives().joint(JOINT);
    assert_eq!(j.state, Some(anguilla_protocol::message::NodeState::Fault));
    assert_eq!(j.errors, u32::from(mit::error_code::OVER_CURRENT));
    // Cleared by the operator's reset, the robot enables again.
    assert_eq!(r.command(1, Command::Reset).accepted, 1);
    r.run_for(0.5);
    assert_eq!(r.command(1, Command::Enable).accepted, 1);
    r.run_for(0.5);
    assert_eq!(r.ctl.supervisor().mode(), Mode::Ready, "{name}");
}

/// After a fault ended motor mode, the drive's replies are still owed and
/// counted: if it then falls silent, "no feedback" names it (before, the
/// count stopped with motor mode). The heartbeat timeout is set long so
/// that only the reply count can find it; both of the joint's drives
/// fault (a joint is silent when either drive is).
#[test]
fn mit_a_faulted_drive_that_falls_silent_is_silent() {
    let mut cfg = config(Family::Mit);
    cfg.control.heartbeat_timeout = 10.0;
    cfg.validate().expect("valid");
    let mut r = swimming_with("limp-mit-silent-after-fault", &cfg);
    for axis in [0, 1] {
        step_with(
            &mut r,
            &mit_reply_of(&cfg, axis, mit::error_code::OVER_TEMPERATURE),
        );
    }
    r.run_for(0.1);
    assert_eq!(r.ctl.supervisor().mode(), Mode::Fault);
    r.joints[JOINT].set_silent(true);
    let periods = f64::from(cfg.control.feedback_timeout + 5);
    r.run_for(periods * r.ctl.period_ns().as_nanos() as f64 * 1e-9);
    let f = r.ctl.supervisor().faults();
    assert!(f.contains(FaultKind::FeedbackLost), "{f}");
    assert!(!f.contains(FaultKind::HeartbeatLost), "{f}");
    assert_eq!(f.nodes, 1 << REPORT_ID, "{f}");
}

/// A reply with every field at the top of its range (all ones: an unread
/// encoder, or a forger's) is counted and said once, naming the drive.
#[test]
fn mit_a_reply_at_the_top_of_every_range_is_counted_and_said() {
    let cfg = config(Family::Mit);
    let mut r = swimming("limp-mit-saturated", Family::Mit);
    let node = cfg.axes()[JOINT][0].node;
    let ones = Frame::new_standard(0, &[node, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 30, 0]).unwrap();
    while r.ctl.take_drive_notice().is_some() {}
    assert_eq!(r.ctl.drives().counters().saturated, 0);
    step_with(&mut r, &ones);
    step_with(&mut r, &ones);
    r.step(); // the controller reads the second
    assert_eq!(r.ctl.drives().counters().saturated, 2);
    let n = r.ctl.take_drive_notice().expect("said");
    assert_eq!(
        n,
        anguilla_daemon::drive::Notice::SaturatedReply {
            joint: JOINT as u8,
            axis: 0,
            node
        }
    );
    assert!(n.to_string().contains("top of its range"), "{n}");
    assert_eq!(r.ctl.take_drive_notice(), None, "once per drive");
}

/// The copier (issue 45): joint 3's drives die, and another sender on the
/// bus replays their last frames byte for byte after every period, with
/// heartbeats whose counter advances (a careful forger). Every liveness
/// check passes (feedback arrives each period, heartbeats are flawless);
/// the feedback does not move while the setpoints do: "feedback frozen",
/// naming joint 3, and nothing else.
#[test]
fn a_copier_of_a_dead_joints_last_frames_is_frozen_feedback() {
    for drive in Family::ALL {
        let name = format!("limp-copier-{}", drive.name());
        let mut r = swimming(&name, drive);
        // The joint's frames of a few periods, the last one per id (MIT:
        // per drive, every reply is on id 0).
        r.capture = Some(JOINT);
        let mut last: Vec<Frame> = Vec::new();
        for _ in 0..10 {
            r.command(1, Command::KeepAlive);
            r.step();
            for f in r.captured.clone() {
                let same = |g: &Frame| g.id() == f.id() && g.data().first() == f.data().first();
                last.retain(|g| !same(g));
                last.push(f);
            }
        }
        r.capture = None;
        // Its heartbeat (the family's liveness message) is forged with a
        // counter; everything else is replayed as it was.
        let mut hb = Vec::new();
        device(&r, JOINT).impostor_heartbeat(
            anguilla_protocol::message::NodeState::Enabled,
            0,
            &mut |f| hb.push(f),
        );
        if drive != Family::Mit {
            last.retain(|f| hb.iter().all(|h| h.id() != f.id()));
        }
        assert!(!last.is_empty(), "{name}: frames to copy");
        match r.nodes.get_mut(JOINT) {
            Some(n) => n.set_silent(true),
            None => r.joints[JOINT].set_silent(true),
        }
        let period = r.ctl.period_ns().as_nanos() as f64 * 1e-9;
        let mut counter = 0u8;
        for k in 0..(1.0 / period) as usize {
            if r.ctl.supervisor().mode() != Mode::Swimming {
                break;
            }
            if k % 20 == 0 {
                r.command(1, Command::KeepAlive);
            }
            r.ctl.run_period(r.now, &mut r.host);
            for f in &last {
                r.bus.inject(f);
            }
            if k % 5 == 0 && drive != Family::Mit {
                counter = counter.wrapping_add(1);
                let mut forged = Vec::new();
                device(&r, JOINT).impostor_heartbeat(
                    anguilla_protocol::message::NodeState::Enabled,
                    counter,
                    &mut |f| forged.push(f),
                );
                for f in &forged {
                    r.bus.inject(f);
                }
            }
            r.nodes_step();
        }
        let f = r.ctl.supervisor().faults();
        assert_eq!(r.ctl.supervisor().mode(), Mode::Fault, "{name}: {f}");
        assert!(f.contains(FaultKind::FeedbackFrozen), "{name}: {f}");
        assert_eq!(f.nodes, 1 << REPORT_ID, "{name}: {f}");
        eprintln!("{name}: {f}");
    }
}

/// A joint jammed (its feedback still live) while the robot
/// swims and turns hard: its measured yaw stays beyond the tracking band
/// from its setpoint for the tracking time: "tracking error", naming it.
#[test]
fn a_jammed_joint_is_a_tracking_error() {
    for drive in Family::ALL {
        let name = format!("limp-jammed-{}", drive.name());
        let mut r = swimming(&name, drive);
        // The tail joint: the largest swing.
        let tail = r.ctl.setpoints().len() - 1;
        // Its encoder still reads, with a little noise (without, a jammed
        // joint's feedback would be the same bit for bit: frozen).
        let faults = match r.nodes.get_mut(tail) {
            Some(n) => n.axis_faults_mut(1),
            None => r.joints[tail].axis_faults_mut(1),
        };
        faults.stuck = true;
        faults.extra_noise = 2e-3;
        let turn = Command::Swim(SwimParams {
            amplitude: 1.0,
            frequency: 0.5,
            turn: 2.0,
            pitch: 0.0,
        });
        assert_eq!(r.command(1, turn).accepted, 1);
        let f = until_not_swimming(&mut r, 10.0);
        assert!(f.contains(FaultKind::TrackingError), "{name}: {f}");
        let id = if drive.drive_per_axis() {
            tail as u64 + 1
        } else {
            u64::from(config(drive).node_ids()[tail])
        };
        assert_eq!(f.nodes, 1 << id, "{name}: {f}");
        eprintln!("{name}: {f}");
    }
}

/// Joint `j`'s simulated drives, whatever the family.
fn device(r: &Rig, j: usize) -> &dyn anguilla_sim::device::JointDevice {
    match r.nodes.get(j) {
        Some(n) => n,
        None => r.joints[j].as_ref(),
    }
}

/// The false-positive check: every family swims 10 s, turning and
/// pitching, then stops, with no fault.
#[test]
fn a_healthy_swim_is_no_fault() {
    for drive in Family::ALL {
        let name = format!("limp-healthy-{}", drive.name());
        let mut r = swimming(&name, drive);
        for (turn, pitch) in [(0.0, 0.0), (2.0, 0.0), (-2.0, 0.8), (0.0, -0.8)] {
            let cmd = Command::Swim(SwimParams {
                amplitude: 1.0,
                frequency: 1.5,
                turn,
                pitch,
            });
            assert_eq!(r.command(1, cmd).accepted, 1, "{name}");
            keep_swimming(&mut r, 2.5);
        }
        assert_eq!(r.command(1, Command::Stop).accepted, 1);
        keep_swimming(&mut r, 3.0);
        let f = r.ctl.supervisor().faults();
        assert!(f.is_empty(), "{name}: {f}");
        assert_eq!(r.ctl.supervisor().mode(), Mode::Ready, "{name}");
        eprintln!(
            "{name}: worst tracking error {:.3} rad (band {})",
            r.ctl.worst_tracking_error(),
            anguilla_daemon::tracking::TRACKING_BAND
        );
    }
}

/// A joint left limp beyond its limit (moved by hand, or by the water while
/// disabled) is held where it is on enable and brought back along the
/// posture profile, in every family (`docs/safety.md`: "straightened from
/// wherever the limp joints were"; `docs/drives.md`: the MIT drive "holds
/// where it is"). Before, the first setpoint in Ready was clamped to the
/// limit: a 0.3 rad step that the MIT drive's stiff gains followed at once.
#[test]
fn a_limp_joint_beyond_its_limit_is_held_where_it_is_on_enable() {
    for drive in Family::ALL {
        let name = format!("limp-beyond-limit-{}", drive.name());
        let cfg = config(drive);
        let limit = cfg.limits.angle;
        let dt = r_dt(&cfg);
        // The posture profile's speed (a quarter of the velocity limit),
        // plus 1 mrad a period for encoder noise.
        let speed = cfg.limits.velocity * 0.25;
        let step = speed * dt + 1e-3;
        let mut r = Rig::new(&name, &cfg);
        r.run_for(0.6);
        let beyond = [limit + 0.3, -(limit + 0.3)];
        if let Some(n) = r.nodes.get_mut(JOINT) {
            anguilla_sim::device::JointDevice::set_pose(n, beyond);
        } else {
            r.joints[JOINT].set_pose(beyond);
        }
        r.run_for(0.1);
        let at_rest = [
            device(&r, JOINT).kinematics(0).0,
            device(&r, JOINT).kinematics(1).0,
        ];
        for (a, b) in at_rest.iter().zip(beyond) {
            assert!(
                (a - b).abs() < 0.01,
                "{name}: limp joint moved: {at_rest:?}"
            );
        }
        assert_eq!(r.command(1, Command::TakeControl).accepted, 1);
        assert_eq!(r.command(1, Command::Enable).accepted, 1);
        let mut last: Option<[f32; 2]> = None;
        let mut ready_for = 0.0;
        let mut periods = 0;
        let mut worst = 0.0f64;
        while ready_for < 0.3 {
            r.step();
            periods += 1;
            assert!(periods < 2000, "{name}: not Ready after {periods} periods");
            let mode = r.ctl.supervisor().mode();
            assert!(
                matches!(mode, Mode::Enabling | Mode::Ready),
                "{name}: {mode:?}, faults {}",
                r.ctl.supervisor().faults()
            );
            let truth = [
                device(&r, JOINT).kinematics(0).0,
                device(&r, JOINT).kinematics(1).0,
            ];
            if mode == Mode::Enabling {
                for (a, b) in truth.iter().zip(at_rest) {
                    assert!(
                        (a - b).abs() < 0.02,
                        "{name}: joint {} moved while enabling: {truth:?} from {at_rest:?}",
                        JOINT + 1
                    );
                }
                continue;
            }
            ready_for += dt;
            let sp = r.ctl.setpoints()[JOINT].map(|s| s.position);
            // The joint follows a profile, not a step: no faster than
            // twice the posture speed (a drive's own lag and overshoot).
            for ax in 0..2 {
                let v = device(&r, JOINT).kinematics(ax).1.abs();
                worst = worst.max(v);
                assert!(
                    v <= 2.0 * speed,
                    "{name}: joint {} axis {ax} at {} rad/s (posture speed {speed}), \
                     at {} for a setpoint {}",
                    JOINT + 1,
                    v,
                    truth[ax],
                    sp[ax]
                );
            }
            let from = last.unwrap_or([at_rest[0] as f32, at_rest[1] as f32]);
            for ax in 0..2 {
                let moved = (sp[ax] - from[ax]).abs() as f64;
                assert!(
                    moved <= step + if last.is_none() { 0.02 } else { 0.0 },
                    "{name}: joint {} axis {ax}: setpoint {} after {}: a step of {moved:.3} rad \
                     (the posture profile allows {step:.4} a period)",
                    JOINT + 1,
                    sp[ax],
                    from[ax]
                );
            }
            last = Some(sp);
        }
        // Brought back: on its way to straight, inside the held angle.
        let sp = r.ctl.setpoints()[JOINT].map(|s| s.position.abs() as f64);
        assert!(
            sp.iter().all(|&p| p < limit + 0.3 - 0.1),
            "{name}: setpoints {sp:?} after 0.3 s in Ready"
        );
        eprintln!(
            "{name}: held at {at_rest:?}, after 0.3 s in Ready {sp:?}, \
             fastest {worst:.2} rad/s"
        );
    }
}

/// The control period of `cfg`, in seconds.
fn r_dt(cfg: &Config) -> f64 {
    anguilla_daemon::control::period_ns(cfg).as_nanos() as f64 * 1e-9
}
