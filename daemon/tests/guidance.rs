//! Path following on the simulated robot in lockstep: the whole loop
//! (estimate, guidance, heading hold, model feed-forward, the simulated
//! body in a current the daemon does not know).

use anguilla_ipc::vocabulary::{Cause, Command, GuideState, Mode};
use anguilla_testkit::guided::{Fixes, follow, line_run, ready, run_until};
use anguilla_testkit::lockstep::{Rig, config};

#[test]
fn a_line_is_joined_from_two_metres_off_through_a_cross_current() {
    // The current pushes away from the line (−x) at 0.1 m/s, across it.
    let f = line_run(&config(), 7, [-0.1, 0.0], Fixes::truth(7), 120.0, 60.0);
    eprintln!("{f:?}");
    assert!(f.last_far < 40.0, "beyond 0.1 m at {} s", f.last_far);
    assert!(f.rms < 0.08, "RMS {} m", f.rms);
    assert!(
        f.along_speed > 0.3,
        "along the line at {} m/s",
        f.along_speed
    );
    assert!(
        f.current_error_60 < 0.05,
        "current off by {} m/s",
        f.current_error_60
    );
}

#[test]
fn a_path_ends_at_its_last_waypoint_and_the_swim_stops() {
    let cfg = config();
    let mut rig = Rig::new(&cfg, 3, [0.0; 3]);
    let mut fixes = Fixes::truth(3);
    ready(&mut rig, &mut fixes);
    // A goto: from here to (3, 2).
    follow(&mut rig, &[(3.0, 2.0)], false, true);
    let done = run_until(&mut rig, &mut fixes, 60.0, |r| {
        r.state().guide.guide_state() != Some(GuideState::Following)
    });
    assert!(done, "still following after 60 s");
    let s = *rig.state();
    assert_eq!(s.guide.guide_state(), Some(GuideState::Done));
    let (x, y) = (f64::from(s.nav.x_m), f64::from(s.nav.y_m));
    assert!((x - 3.0).hypot(y - 2.0) <= 0.6, "ended at ({x}, {y})");
    assert!(run_until(&mut rig, &mut fixes, 30.0, |r| r.state().mode
        == Mode::Ready as u8));
    assert_eq!(
        rig.state().cause,
        Cause::PathDone.code(),
        "why the swim ended"
    );
}

#[test]
fn only_the_holder_loads_a_path_and_any_command_of_its_own_ends_it() {
    use anguilla_ipc::{CommandRequest, Envelope, Waypoint};
    let cfg = config();
    let mut rig = Rig::new(&cfg, 4, [0.0; 3]);
    let mut fixes = Fixes::truth(4);
    ready(&mut rig, &mut fixes);
    // Another client: refused, for authority, before anything of the path.
    let other = |rig: &mut Rig, cmd: Command| {
        rig.ctl.command(
            anguilla_ipc::vocabulary::Nanos::from_secs_f64(rig.time()),
            &Envelope {
                origin: 2,
                node: 2,
                request: CommandRequest::new(cmd, 1),
            },
        )
    };
    let w = Waypoint {
        index: 0,
        x: 1e9,
        y: 0.0,
        depth: None,
    };
    let r = other(&mut rig, Command::Waypoint(w));
    assert_eq!(r.accepted, 0);
    assert!(r.reason().contains("holds control"), "{}", r.reason());
    // The holder's bad waypoint is refused with the reason.
    let mut cfg2 = cfg.clone();
    cfg2.guidance.fence_radius = 20.0;
    let mut fenced = Rig::new(&cfg2, 4, [0.0; 3]);
    let mut f2 = Fixes::truth(4);
    ready(&mut fenced, &mut f2);
    let r = fenced.command(Command::Waypoint(Waypoint { x: 25.0, ..w }));
    assert_eq!(r.accepted, 0);
    assert!(
        r.reason().contains("outside the geofence"),
        "{}",
        r.reason()
    );
    // A path followed; the operator's swim ends it, the swim goes on.
    follow(&mut rig, &[(0.0, 0.0), (50.0, 0.0)], false, false);
    run_until(&mut rig, &mut fixes, 3.0, |_| false);
    assert_eq!(rig.state().guide.guide_state(), Some(GuideState::Following));
    rig.ok(Command::Swim(anguilla_ipc::SwimParams {
        amplitude: 1.0,
        frequency: 1.0,
        turn: 0.0,
        pitch: 0.0,
    }));
    rig.period();
    assert_eq!(
        rig.state().guide.guide_state(),
        Some(GuideState::Interrupted)
    );
    assert_eq!(rig.state().mode, Mode::Swimming as u8);
    // Resumed on its leg (a resume of another path's count is refused).
    let resume = |count| {
        Command::Follow(anguilla_ipc::Follow {
            swim: anguilla_ipc::SwimParams {
                amplitude: 1.0,
                frequency: 1.0,
                turn: 0.0,
                pitch: 0.0,
            },
            count,
            looped: false,
            from_here: false,
            resume: true,
        })
    };
    let r = rig.command(resume(3));
    assert_eq!(r.accepted, 0);
    assert!(r.reason().contains("not 3"), "{}", r.reason());
    rig.ok(resume(2));
    rig.period();
    assert_eq!(rig.state().guide.guide_state(), Some(GuideState::Following));
    assert_eq!(rig.state().guide.leg, 1);
    // Nothing to resume while following.
    let r = rig.command(resume(2));
    assert!(r.reason().contains("no path to resume"), "{}", r.reason());
    // Followed again; an E-stop ends it at once.
    follow(&mut rig, &[(0.0, 0.0), (50.0, 0.0)], false, false);
    rig.period();
    assert_eq!(rig.state().guide.guide_state(), Some(GuideState::Following));
    rig.ok(Command::EStop);
    rig.period();
    assert_eq!(rig.state().mode, Mode::EStop as u8);
    assert_eq!(
        rig.state().guide.guide_state(),
        Some(GuideState::Interrupted)
    );
}

#[test]
fn crossing_the_geofence_stops_the_swim() {
    let mut cfg = config();
    cfg.guidance.fence_radius = 3.0;
    cfg.validate().expect("valid");
    let mut rig = Rig::new(&cfg, 5, [0.0; 3]);
    let mut fixes = Fixes::truth(5);
    ready(&mut rig, &mut fixes);
    // A path whose waypoints are inside, swum past its end by hand.
    rig.ok(Command::Swim(anguilla_ipc::SwimParams {
        amplitude: 1.0,
        frequency: 1.0,
        turn: 0.0,
        pitch: 0.0,
    }));
    let stopped = run_until(&mut rig, &mut fixes, 60.0, |r| {
        r.state().mode != Mode::Swimming as u8
    });
    assert!(stopped, "still swimming after 60 s");
    let s = *rig.state();
    assert_eq!(s.cause, Cause::Fence.code());
    assert_eq!(s.mode, Mode::Stopping as u8);
    let (x, y) = (f64::from(s.nav.x_m), f64::from(s.nav.y_m));
    assert!(
        x.hypot(y) > 3.0 && x.hypot(y) < 3.2,
        "stopped at ({x}, {y})"
    );
    // Outside, a path is refused.
    run_until(&mut rig, &mut fixes, 30.0, |r| {
        r.state().mode == Mode::Ready as u8
    });
    rig.ok(Command::Waypoint(anguilla_ipc::Waypoint {
        index: 0,
        x: 0.0,
        y: 0.0,
        depth: None,
    }));
    let r = rig.command(Command::Follow(anguilla_ipc::Follow {
        swim: anguilla_ipc::SwimParams {
            amplitude: 1.0,
            frequency: 1.0,
            turn: 0.0,
            pitch: 0.0,
        },
        count: 1,
        looped: false,
        from_here: true,
        resume: false,
    }));
    assert_eq!(r.accepted, 0);
    assert!(
        r.reason().contains("outside the geofence"),
        "{}",
        r.reason()
    );
}

#[test]
fn a_lost_fix_stops_the_path_holding_the_last_heading() {
    let mut cfg = config();
    // A USBL configured (its socket unused: the rig hands the fixes in).
    cfg.sensor.usbl = Some(anguilla_daemon::sensors::usbl::UsblConfig {
        source: "udp:127.0.0.1:0".into(),
        latency: 0.1,
        ..Default::default()
    });
    cfg.autopilot.fix_stale = 1.0;
    cfg.autopilot.fix_lost = 3.0;
    cfg.validate().expect("valid");
    let mut rig = Rig::new(&cfg, 6, [0.0; 3]);
    let mut fixes = Fixes::truth(6);
    ready(&mut rig, &mut fixes);
    follow(&mut rig, &[(0.0, 0.0), (50.0, 5.0)], false, false);
    run_until(&mut rig, &mut fixes, 10.0, |_| false);
    assert_eq!(rig.state().guide.guide_state(), Some(GuideState::Following));
    // The fixes stop.
    let start = rig.time();
    let mut heading = rig.state().guide.heading_deg;
    while rig.state().guide.guide_state() == Some(GuideState::Following)
        && rig.time() - start < 10.0
    {
        heading = rig.state().guide.heading_deg;
        rig.period();
    }
    let s = *rig.state();
    let after = rig.time() - start;
    assert_eq!(
        s.guide.guide_state(),
        Some(GuideState::FixLost),
        "after {after} s"
    );
    assert!(
        (2.5..=4.0).contains(&after),
        "lost after {after} s, fix-lost 3 s"
    );
    assert_eq!(s.cause, Cause::FixLost.code());
    assert_eq!(s.mode, Mode::Stopping as u8);
    // The heading held on the way down is the last the path asked.
    assert_eq!(s.nav.hold & 1, 1);
    assert!(
        (s.nav.heading_target_deg - heading).abs() < 0.01,
        "{} for {heading}",
        s.nav.heading_target_deg
    );
}
