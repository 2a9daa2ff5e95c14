//! A control period allocates nothing: a counting global allocator watches
//! every `Controller::run_period` call (and the command path) while the rig
//! swims, turns, dives and stops, and with a head sensor while the
//! autopilot holds a heading and a depth and the sensor fails. The
//! simulated robot's half of each period is outside the counted region (it
//! is not daemon code).

use anguilla_testkit::lockstep;
mod rig;

use std::cell::Cell;

use anguilla_daemon::config::Config;
use anguilla_ipc::vocabulary::{Command, Mode, SwimParams};
use anguilla_protocol::Family;
use rig::Rig;

#[global_allocator]
static GLOBAL: anguilla_testkit::CountingAlloc = anguilla_testkit::CountingAlloc;

thread_local! {
    /// Allocator calls of the counted regions since the last reset.
    static COUNT: Cell<u64> = const { Cell::new(0) };
}

/// Runs `f`, adding its allocator calls on this thread to `COUNT`.
fn counted<T>(f: impl FnOnce() -> T) -> T {
    let (r, calls) = anguilla_testkit::count(f);
    COUNT.with(|n| n.set(n.get() + calls));
    r
}

/// Every drive family ([`Family::ALL`]), those that speak CAN FD on
/// classic CAN and CAN FD (CiA 402 drives are configured by SDO in the
/// warm-up).
#[test]
fn a_control_period_allocates_nothing() {
    let runs = Family::ALL.into_iter().flat_map(|f| {
        let fd = f
            .speaks_fd()
            .then(|| (format!("no-alloc-{}-fd", f.name()), f, true));
        [Some((format!("no-alloc-{}", f.name()), f, false)), fd]
            .into_iter()
            .flatten()
    });
    for (name, drive, fd) in runs {
        let name = name.as_str();
        let mut cfg = Config::default();
        cfg.bus.fd = fd;
        cfg.robot.drive = drive;
        cfg.validate().expect("valid");
        let mut r = Rig::new(name, &cfg);
        // Recording on: the tap's bounded channel must not allocate either.
        let (tap, records) = crossbeam_channel::bounded(1 << 16);
        r.ctl.set_tap(tap);
        // Warm-up outside the count: boot (and configuration), control,
        // enable.
        r.run_for(0.6);
        r.command(1, Command::TakeControl);
        r.command(1, Command::Enable);
        r.run_for(0.3);
        records.try_iter().for_each(drop);
        assert_eq!(r.ctl.supervisor().mode(), Mode::Ready, "{name}");
        COUNT.with(|n| n.set(0));
        let phases = [
            (0.0, 0.0, 1.0),  // swim
            (1.5, 0.0, 1.0),  // turn
            (0.0, 0.8, 1.0),  // dive
            (0.0, 0.0, -1.0), // stop
        ];
        for (turn, pitch, amplitude) in phases {
            let cmd = if amplitude < 0.0 {
                Command::Stop
            } else {
                Command::Swim(SwimParams {
                    amplitude,
                    frequency: 1.0,
                    turn,
                    pitch,
                })
            };
            counted(|| r.command(1, cmd));
            for i in 0..200 {
                counted(|| r.ctl.run_period(r.now, &mut r.host));
                r.nodes_step();
                records.try_iter().for_each(drop);
                if i % 20 == 0 {
                    counted(|| r.command(1, Command::KeepAlive));
                }
            }
        }
        // A refused command formats its reason without allocating too.
        counted(|| r.command(2, Command::Enable));
        assert!(r.ctl.counters().refused >= 1);
        let n = COUNT.with(|n| n.get());
        assert_eq!(n, 0, "{n} allocations in 800 control periods ({name})");
        assert!(r.ctl.snapshot().sequence > 800);
        assert_eq!(r.ctl.tap_dropped(), 0);
    }
}

/// The head sensor's frames, the estimate and the autopilot, a tail IMU's
/// frames beside them, and a USBL's fixes off the bus (its reader thread
/// is not the period's): a period with a heading and a depth held and
/// fixes taken allocates nothing, nor does a sensor falling silent and
/// ending the hold.
#[test]
fn a_period_with_the_autopilot_allocates_nothing() {
    use anguilla_ipc::Hold;
    use anguilla_protocol::position_fix::Fix;
    let mut cfg = lockstep::config();
    cfg.sensor.tail_imu = 40;
    let probe = std::net::UdpSocket::bind("127.0.0.1:0").expect("a port");
    let usbl = probe.local_addr().expect("its address");
    drop(probe);
    cfg.sensor.usbl = Some(anguilla_daemon::sensors::usbl::UsblConfig {
        source: format!("udp:{usbl}"),
        ..Default::default()
    });
    cfg.validate().expect("valid");
    let sender = std::net::UdpSocket::bind("127.0.0.1:0").expect("a sender");
    let fix = Fix {
        x: 0.1,
        y: 0.0,
        sigma: 0.5,
        age: 0.0,
    }
    .sentence();
    let mut rig = lockstep::Rig::new(&cfg, 9, [0.0; 3]);
    rig.swim(1.0);
    rig.run(3.0, |_| {});
    COUNT.with(|n| n.set(0));
    let hold = Command::Hold(Hold {
        heading: Some(90.0),
        depth: Some(1.2),
    });
    let r = counted(|| rig.command(hold));
    assert_eq!(r.accepted, 1, "{}", r.reason());
    let mut periods = 0;
    for phase in 0..2 {
        if phase == 1 {
            rig.scenario_from_now("0 sensor silent");
        }
        for k in 0..300 {
            let taken = |rig: &lockstep::Rig| rig.state().sensors[2].samples;
            let before = taken(&rig);
            if k % 50 == 0 {
                sender.send_to(fix.as_bytes(), usbl).expect("a fix sent");
            }
            let now = rig.advance();
            counted(|| rig.control(now));
            periods += 1;
            // The reader thread runs on wall time, the rig on its own:
            // counted periods go on until the fix is taken (a deadline, not
            // a guess at how long the thread takes).
            let end = std::time::Instant::now() + std::time::Duration::from_secs(10);
            while k % 50 == 0 && taken(&rig) == before && std::time::Instant::now() < end {
                std::thread::sleep(std::time::Duration::from_millis(1));
                let now = rig.advance();
                counted(|| rig.control(now));
                periods += 1;
            }
        }
    }
    let s = rig.state();
    assert_eq!(s.nav.hold, 0, "the silent sensor ended the hold");
    // The tail IMU was read all along (its samples counted, in the list).
    assert_eq!(s.sensors[1].kind, anguilla_ipc::SensorKind::TailImu as u8);
    assert!(s.sensors[1].samples > 500, "{}", s.sensors[1].samples);
    // Every one of the USBL's 12 fixes was taken in a counted period.
    assert_eq!(s.sensors[2].kind, anguilla_ipc::SensorKind::Usbl as u8);
    assert_eq!(s.sensors[2].samples, 12, "fixes taken");
    assert_eq!(s.cause, anguilla_ipc::vocabulary::Cause::SensorLost.code());
    // A refused hold (the sensor is silent) formats its reason in place.
    let r = counted(|| rig.command(hold));
    assert_eq!(r.accepted, 0);
    let n = COUNT.with(|n| n.get());
    assert_eq!(
        n, 0,
        "{n} allocations in {periods} periods with the autopilot"
    );
}

/// Path following: loading waypoints, following them through legs with
/// the estimate's position (fixes handed in), a refused waypoint (its
/// reason formatted in place), the geofence crossed: no allocation.
#[test]
fn a_period_following_a_path_allocates_nothing() {
    use anguilla_daemon::sensors::Observation;
    use anguilla_ipc::vocabulary::{Follow, Waypoint};
    let mut cfg = lockstep::config();
    cfg.guidance.fence_radius = 6.0;
    cfg.validate().expect("valid");
    let mut rig = lockstep::Rig::new(&cfg, 11, [0.0, 0.05, 0.0]);
    rig.ok(Command::TakeControl);
    rig.ok(Command::Enable);
    assert!(rig.run_until(5.0, |r| r.state().mode == Mode::Ready as u8));
    COUNT.with(|n| n.set(0));
    let points = [(0.0, 0.0), (2.0, 0.0), (2.0, 2.0), (0.0, 2.0), (-2.0, 2.0)];
    for (i, &(x, y)) in points.iter().enumerate() {
        let w = Command::Waypoint(Waypoint {
            index: i as u32,
            x,
            y,
            depth: None,
        });
        let r = counted(|| rig.command(w));
        assert_eq!(r.accepted, 1, "{}", r.reason());
    }
    let outside = Command::Waypoint(Waypoint {
        index: 5,
        x: 10.0,
        y: 0.0,
        depth: None,
    });
    let r = counted(|| rig.command(outside));
    assert_eq!(r.accepted, 0, "outside the fence");
    let follow = Command::Follow(Follow {
        swim: SwimParams {
            amplitude: 1.0,
            frequency: 1.0,
            turn: 0.0,
            pitch: 0.0,
        },
        count: points.len() as u32,
        looped: true,
        from_here: false,
        resume: false,
    });
    let r = counted(|| rig.command(follow));
    assert_eq!(r.accepted, 1, "{}", r.reason());
    let mut legs = std::collections::BTreeSet::new();
    for k in 0..6000 {
        let now = rig.advance();
        counted(|| rig.control(now));
        if k % 10 == 0 {
            let p = rig.truth().position;
            let fix = Observation::PositionFix {
                at: now,
                x: p[0],
                y: p[1],
                sigma: 0.05,
            };
            counted(|| rig.ctl.observe(&fix));
        }
        legs.insert(rig.state().guide.leg);
        if k % 20 == 0 {
            let r = counted(|| rig.command(Command::KeepAlive));
            assert_eq!(r.accepted, 1);
        }
    }
    assert!(legs.len() >= 3, "legs swum: {legs:?}");
    let n = COUNT.with(|n| n.get());
    assert_eq!(n, 0, "{n} allocations following a path");
}
