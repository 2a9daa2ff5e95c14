//! `anguilla calibrate`'s identification on the simulated robot: a
//! calibration swim recorded (as `anguilla run` records `session.mcap`)
//! on a body whose coefficients are not the model's, read back and
//! fitted. The figures are printed (docs/calibration.md quotes them).

use anguilla_daemon::calibration::LEGS;
use anguilla_daemon::mcap_log::swim::{self, Source};
use anguilla_ipc::vocabulary::Mode;
use anguilla_model::AxialDrag;
use anguilla_model::identify::{self, Coefficient, FitOptions};
use anguilla_testkit::lockstep::{self, Rig};

/// A body 30 % draggier sideways, 30 % less vertically, with 25 % less
/// skin friction than the model's, recorded over CAN FD (classic CAN's
/// feedback is too coarse: docs/calibration.md): the fit brings every
/// coefficient within 5 % of the body's, every coefficient it calls
/// identified is within 5 %, and the replayed speed error shrinks.
#[test]
fn a_recorded_calibration_swim_recovers_the_coefficients_within_5_percent() {
    let mut cfg = lockstep::config();
    cfg.bus.fd = true;
    cfg.validate().unwrap();
    let prior = cfg.model.body();
    let mut body = prior.clone();
    body.c2 *= 1.3;
    body.c3 *= 0.7;
    body.axial = AxialDrag::SkinFriction { scale: 0.75 };
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
            fit: vec![Coefficient::C2, Coefficient::C3, Coefficient::Friction],
            ..FitOptions::default()
        },
    )
    .unwrap();
    for e in &fit.estimates {
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
}
