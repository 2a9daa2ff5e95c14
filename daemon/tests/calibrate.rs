//! `anguilla calibrate`'s identification on the simulated robot: a
//! calibration swim recorded (as `anguilla run` records `session.mcap`)
//! on a body whose coefficients are not the model's, read back and
//! fitted. The figures are printed (docs/calibration.md quotes them).

use anguilla_daemon::calibration::{CLIMB, LEGS, Leg};
use anguilla_daemon::config::Config;
use anguilla_daemon::mcap_log::swim::{self, Source};
use anguilla_ipc::vocabulary::{Command, Mode, SwimParams};
use anguilla_model::identify::{self, Coefficient, FitOptions};
use anguilla_model::{AxialDrag, Body};
use anguilla_testkit::lockstep::{self, Rig};

/// The lockstep configuration over CAN FD, its model's body (the prior)
/// and a body 30 % draggier sideways, 30 % less vertically, with 25 % less
/// skin friction.
fn draggier() -> (Config, Body, Body) {
    let mut cfg = lockstep::config();
    cfg.bus.fd = true;
    cfg.validate().unwrap();
    let prior = cfg.model.body();
    let mut body = prior.clone();
    body.c2 *= 1.3;
    body.c3 *= 0.7;
    body.axial = AxialDrag::SkinFriction { scale: 0.75 };
    (cfg, prior, body)
}

/// A body 30 % draggier sideways, 30 % less vertically, with 25 % less
/// skin friction than the model's, recorded over CAN FD (classic CAN's
/// feedback is too coarse: docs/calibration.md): the fit brings every
/// coefficient within 5 % of the body's, every coefficient it calls
/// identified is within 5 %, and the replayed speed error shrinks.
#[test]
fn a_recorded_calibration_swim_recovers_the_coefficients_within_5_percent() {
    let (cfg, prior, body) = draggier();
    let dir = std::env::temp_dir().join(format!("anguilla-calibrate-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("session.mcap");
    let mut rig = Rig::with_body(&cfg, 5, body.clone());
    rig.record_legs(&cfg, &LEGS, &path).unwrap();
    // the glide legs (amplitude 0) are still swims
    assert_eq!(rig.state().mode, Mode::Swimming as u8);
    let read = swim::read(&dir, None).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!((read.track, read.attitude), (Source::Truth, Source::Truth));
    assert!(read.swim.duration() > 55.0, "{}", read.swim.duration());
    let fit = identify::fit(
        &prior,
        &[read.swim],
        &FitOptions {
            // the nose's drag too, which the swim tells only with the
            // skin friction: left at the prior for that
            fit: vec![
                Coefficient::CP,
                Coefficient::C2,
                Coefficient::C3,
                Coefficient::Friction,
            ],
            ..FitOptions::default()
        },
    )
    .unwrap();
    for e in &fit.estimates {
        if e.coefficient == Coefficient::CP {
            eprintln!("     c_p: {e:?}");
            assert!(!e.fitted, "{e:?}");
            let (other, r) = e.confounded.expect("left at the prior for a correlation");
            assert_eq!(other, Coefficient::Friction);
            assert!(r.abs() > identify::MAX_CORRELATION, "{r}");
            continue;
        }
        let truth = e.coefficient.get(&body);
        eprintln!(
            "{:>8}: prior {:.4}, estimate {:.4} ± {:.4} (truth {:.4}, {:+.1} %), identified: {}",
            e.coefficient.name(),
            e.prior,
            e.estimate,
            e.std_error,
            truth,
            100.0 * (e.estimate / truth - 1.0),
            e.identified
        );
        assert!(
            (e.estimate / truth - 1.0).abs() < 0.05,
            "{} is not within 5 % of the body's",
            e.coefficient.name()
        );
        if e.identified {
            assert!((e.value / truth - 1.0).abs() < 0.05, "{e:?}");
            // its interval holds the body's: the replay's own bias counted
            // (identify::REPLAY_BIAS; without it `c3`, +0.3 %, was five
            // standard errors off)
            assert!((e.estimate - truth).abs() < 2.0 * e.std_error, "{e:?}");
        }
    }
    let (b, e) = (&fit.before.swims[0], &fit.estimated.swims[0]);
    eprintln!(
        "mean speed error: prior {:+.2} %, every estimate {:+.2} %; torque RMS error {:.4} and \
         {:.4} N·m; {} replays",
        100.0 * b.speed_error(),
        100.0 * e.speed_error(),
        b.torque_rms,
        e.torque_rms,
        fit.simulations
    );
    assert!(e.speed_error().abs() < b.speed_error().abs());
    assert!(fit.estimated.cost < fit.before.cost);
    assert!(fit.after.cost <= fit.before.cost);
    // Issue 46, finding 4: what `calibrate --write` writes (the identified
    // coefficients and the drives' terms) cuts the daemon's live torque
    // error on this body.
    let mut written = cfg.clone();
    let mut body_w = prior.clone();
    for e in fit.estimates.iter().filter(|e| e.identified) {
        e.coefficient.set(&mut body_w, e.value);
    }
    written.model.c2 = body_w.c2;
    written.model.c3 = body_w.c3;
    written.model.c1 = body_w.c1;
    if let AxialDrag::SkinFriction { scale } = body_w.axial {
        written.model.friction = scale;
    }
    let [ji, bi, lag] = fit.after.actuator;
    written.model.drive_inertia = ji;
    written.model.drive_friction = bi;
    written.model.drive_lag = lag;
    written.validate().unwrap();
    let before = live_torque_error(&cfg, &body);
    let after = live_torque_error(&written, &body);
    eprintln!(
        "drive terms fitted {ji:.4} kg·m², {bi:.4} N·m·s/rad, {:.2} ms; the daemon's live torque \
         error RMS {before:.4} N·m with the prior, {after:.4} with the written fit",
        1e3 * lag
    );
    assert!(after < 0.5 * before, "{after} against {before}");
    // Issue 46, finding 4: with the written file the daemon's predicted
    // speed is no worse on gaits the calibration swim did not swim (it was
    // 2-3 % worse on forward gaits of two bodies where the replay promised
    // better).
    for (amplitude, frequency) in HELD_OUT {
        let prior_error = predicted_speed_error(&cfg, &body, amplitude, frequency);
        let written_error = predicted_speed_error(&written, &body, amplitude, frequency);
        eprintln!(
            "held out: amplitude {amplitude}, {frequency} Hz: the daemon's predicted speed \
             {:+.2} % off the body's with the prior, {:+.2} % with the written fit",
            100.0 * prior_error,
            100.0 * written_error
        );
        assert!(
            written_error.abs() <= prior_error.abs(),
            "{written_error} against {prior_error}"
        );
    }
}

/// Gaits no leg of the calibration swim ([`LEGS`]) swims: (amplitude,
/// frequency in Hz).
const HELD_OUT: [(f64, f64); 2] = [(0.7, 1.1), (0.5, 0.8)];

/// The daemon's predicted forward speed against the body's true one,
/// relative, averaged over 4 s (whole periods) after 5 s straight at
/// `amplitude` and `frequency` on `body` under `cfg`. The rig runs in
/// lockstep on simulated time with a fixed seed: the same figure every
/// run, so "no worse" needs no tolerance.
fn predicted_speed_error(cfg: &Config, body: &Body, amplitude: f64, frequency: f64) -> f64 {
    let mut rig = Rig::with_body(cfg, 8, body.clone());
    rig.swim_at(amplitude, frequency);
    rig.run(5.0, |_| {});
    let (mut predicted, mut truth, mut n) = (0.0, 0.0, 0usize);
    rig.run((4.0 * frequency).round() / frequency, |r| {
        predicted += f64::from(r.state().predicted_head_speed);
        truth += r.truth().forward_speed;
        n += 1;
    });
    assert!(
        n > 0 && truth > 0.0,
        "no swim: {truth} m/s over {n} periods"
    );
    predicted / truth - 1.0
}

/// How far the calibration swim climbs above its start and dives below
/// it, open water, on the paper's body and on the draggier one:
/// `calibration::CLIMB`, which `ctl calibrate-swim`'s shallowest start
/// (`MIN_START_DEPTH`) is made of, is above both, and less than half a
/// metre above the higher (a README recipe that started at 1 m surfaced
/// mid-swim, and its fit refused the torques).
#[test]
fn the_swim_climbs_less_than_its_documented_climb() {
    let (cfg, prior, draggier) = draggier();
    let mut most = 0.0f64;
    for (name, body) in [("the paper's", prior), ("the draggier", draggier)] {
        let mut rig = Rig::with_body(&cfg, 5, body);
        rig.ok(Command::TakeControl);
        rig.ok(Command::Enable);
        assert!(rig.run_until(5.0, |r| r.state().mode == Mode::Ready as u8));
        let start = rig.ground_truth().depth;
        let (mut lo, mut hi) = (start, start);
        for leg in &LEGS {
            rig.ok(Command::Swim(leg.gait));
            rig.run(leg.seconds, |r| {
                let d = r.ground_truth().depth;
                lo = lo.min(d);
                hi = hi.max(d);
            });
        }
        let (climb, dive) = (start - lo, hi - start);
        eprintln!("{name} body: climbs {climb:.2} m, dives {dive:.2} m from {start:.2} m");
        assert!(climb < CLIMB, "{name}: climbs {climb}");
        assert!(dive < CLIMB, "{name}: dives {dive}");
        most = most.max(climb);
    }
    assert!(most > CLIMB - 0.5, "the most either climbs: {most}");
}

/// The simulated robot's joint torques are the model's inverse dynamics of
/// its body, bent as well as straight: on a turning and climbing gait
/// (the body bent in both planes), the measured torques less the drives'
/// own inertia and friction are the model's with the body's coefficients
/// to 0.02 N·m RMS, and less than half as far as with the paper's. (With
/// the servos coupled to the straight body's inertia, held over each
/// physics tick, the body's own model was 0.074 N·m off and hardly better
/// than the paper's: docs/calibration.md.)
#[test]
fn the_robots_torques_are_the_models_on_a_bent_body() {
    let (cfg, prior, body) = draggier();
    let leg = Leg {
        what: "turning and climbing",
        seconds: 12.0,
        gait: SwimParams {
            amplitude: 0.9,
            frequency: 1.3,
            turn: 0.8,
            pitch: -0.4,
        },
    };
    let dir = std::env::temp_dir().join(format!("anguilla-bent-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut rig = Rig::with_body(&cfg, 6, body.clone());
    rig.record_legs(&cfg, &[leg], &dir.join("session.mcap"))
        .unwrap();
    let read = swim::read(&dir, None).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    // the simulated drives' reflected inertia and friction
    let actuator = anguilla_sim::actuator::ActuatorParams::default();
    let opts = FitOptions {
        actuator: Some([actuator.inertia, actuator.damping, 0.0]),
        ..FitOptions::default()
    };
    let ev = identify::compare(&[&body, &prior], &[read.swim], &opts).unwrap();
    let (own, paper) = (ev[0].rms[4], ev[1].rms[4]);
    eprintln!("torque RMS error: the body's own coefficients {own:.4} N·m, the paper's {paper:.4}");
    assert!(own < 0.02, "{own}");
    assert!(own < 0.5 * paper, "{own} against {paper}");
}

/// The daemon's live torque error on a swim: RMS over every joint's axis
/// of the measured torque less the predicted (the feed-forward), over the
/// last 8 s of 14 s forward at 1.2 Hz on `body` under `cfg`.
fn live_torque_error(cfg: &Config, body: &Body) -> f64 {
    let mut rig = Rig::with_body(cfg, 7, body.clone());
    rig.swim(1.2);
    rig.run(6.0, |_| {});
    let (mut se, mut n) = (0.0, 0usize);
    rig.run(8.0, |r| {
        for j in r.state().joints.iter().take(cfg.robot.joints) {
            for (m, p) in [
                (j.measured_pitch_torque, j.predicted_pitch_torque),
                (j.measured_yaw_torque, j.predicted_yaw_torque),
            ] {
                if m.is_finite() {
                    se += f64::from(m - p).powi(2);
                    n += 1;
                }
            }
        }
    });
    assert!(n > 0, "no measured torque");
    (se / n as f64).sqrt()
}

/// Issue 46, finding 4: the fit's drive terms did not reach the daemon, so
/// on a body that differs from the model its live torque error stayed
/// where it was with the fitted coefficients (the error being mostly the
/// drives' inertia and friction). With `[model] drive-inertia`,
/// `drive-friction` and `drive-lag` written (here the simulated drives'
/// own, which a fit recovers: docs/calibration.md) the feed-forward
/// carries them and the error falls.
#[test]
fn written_drive_terms_cut_the_daemons_live_torque_error() {
    let (cfg, _, body) = draggier();
    let before = live_torque_error(&cfg, &body);
    let mut fitted = cfg.clone();
    fitted.model.c2 = body.c2;
    fitted.model.c3 = body.c3;
    fitted.model.friction = 0.75;
    let coefficients = live_torque_error(&fitted, &body);
    let a = anguilla_sim::actuator::ActuatorParams::default();
    fitted.model.drive_inertia = a.inertia;
    fitted.model.drive_friction = a.damping;
    fitted.validate().unwrap();
    let after = live_torque_error(&fitted, &body);
    eprintln!(
        "live torque error RMS: the paper's model {before:.4} N·m, the body's coefficients \
         {coefficients:.4}, with the drives' terms {after:.4}"
    );
    assert!(after < 0.5 * coefficients, "{after} against {coefficients}");
    assert!(after < 0.5 * before, "{after} against {before}");
}
