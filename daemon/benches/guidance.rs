//! Path following on the simulated robot, measured (issue 48's
//! benchmark). Prints one JSON line per case; `scripts/check-guidance`
//! checks the figures against the targets. Nothing here is a
//! time: the figures are the simulated robot's, in simulated seconds.
//!
//! `cargo bench -p anguilla-daemon --bench guidance`
//!
//! The rig is `anguilla_testkit::lockstep` (the controller and the
//! simulated robot in lockstep, default configuration plus `[sensor] node
//! = 20`, gait at full amplitude and 1 Hz); the current is the simulated
//! water's, unknown to the daemon. Cross-track errors are the truth's: the
//! body's centroid (half its length behind the nose along its heading)
//! averaged over each gait period (the tail beat's sway removed), as the
//! issue asks; the nose's beside them on the line.
//!
//! 1. `line`: the robot 2.0 m off a straight line, at −90° to it, the
//!    current 0.1 m/s at 90° and at 45° to the line; with positions from
//!    a tank's motion capture (10 Hz, σ 1 cm: "truth") and from a USBL
//!    (1 Hz, σ 0.1 m, 0.3 s late, 5 % lost) with a DVL (5 Hz, σ 0.01 m/s);
//!    ILOS (the default κ) and plain LOS (κ = 0): the last time the error
//!    was 0.10 m or more, its RMS and mean over the last 60 s of 180 s,
//!    the along-track speed, the estimated current's error after 60 s
//!    and at the end, the estimate's factor of the model's speed,
//!    and LOS's predicted offset Δ V⊥ / √(U² − V⊥²).
//! 2. `lawnmower`: four legs (30, 25, 30, 25 m) in a current of 0.1 m/s
//!    across the first leg: the RMS per leg from 20 s after its switch.

use anguilla_ipc::vocabulary::GuideState;
use anguilla_testkit::guided::{Fixes, Track, cross_track, follow, line_run, ready};
use anguilla_testkit::lockstep::{Rig, config};

fn main() {
    let cfg = config();
    let delta = cfg.guidance.look_ahead;
    // `cargo bench ... -- lawnmower`: that case alone.
    let only = std::env::args().skip(1).find(|a| !a.starts_with('-'));
    let run = |case: &str| only.as_deref().is_none_or(|o| o == case);
    for (fixes_name, usbl) in [("truth", false), ("usbl_dvl", true)] {
        if !run("line") {
            break;
        }
        for (angle, current) in [(90, [-0.1, 0.0]), (45, [-0.0707, 0.0707])] {
            for (law, kappa) in [("ilos", cfg.guidance.integral), ("los", 0.0)] {
                if usbl && law == "los" {
                    continue;
                }
                let mut c = cfg.clone();
                c.guidance.integral = kappa;
                let fixes = if usbl {
                    Fixes::usbl_dvl(11)
                } else {
                    Fixes::truth(11)
                };
                let f = line_run(&c, 11, current, fixes, 180.0, 60.0);
                // The line runs along +y: the current's component across it.
                let across = current[0].abs();
                let predicted = delta * across / (f.speed * f.speed - across * across).sqrt();
                println!(
                    "{{\"bench\":\"guidance_line\",\"fixes\":\"{fixes_name}\",\"current_angle_deg\":{angle},\"law\":\"{law}\",\"kappa\":{kappa},\"look_ahead\":{delta},\"last_beyond_0_1_m_s\":{:.1},\"rms_m\":{:.4},\"mean_m\":{:.4},\"along_speed_mps\":{:.3},\"current_error_60s_mps\":{:.4},\"current_error_across_60s_mps\":{:.4},\"current_error_along_60s_mps\":{:.4},\"speed_through_water_mps\":{:.3},\"nose_rms_m\":{:.4},\"nose_mean_m\":{:.4},\"current_error_end_mps\":{:.4},\"speed_scale_end\":{:.4},\"los_predicted_offset_m\":{predicted:.4}}}",
                    f.last_far,
                    f.rms,
                    f.mean,
                    f.along_speed,
                    f.current_error_60,
                    f.current_across_60,
                    f.current_along_60,
                    f.speed,
                    f.nose_rms,
                    f.nose_mean,
                    f.current_error_end,
                    f.speed_scale
                );
            }
        }
    }
    for (fixes_name, usbl) in [("truth", false), ("usbl_dvl", true)] {
        if !run("lawnmower") {
            break;
        }
        lawnmower(
            &cfg,
            fixes_name,
            if usbl {
                Fixes::usbl_dvl(12)
            } else {
                Fixes::truth(12)
            },
        );
    }
}

/// Four legs from the origin, the current across the first.
fn lawnmower(cfg: &anguilla_daemon::config::Config, name: &str, mut fixes: Fixes) {
    let mut rig = Rig::new(cfg, 12, [0.0, 0.1, 0.0]);
    ready(&mut rig, &mut fixes);
    let points = [
        (0.0, 0.0),
        (30.0, 0.0),
        (30.0, 25.0),
        (0.0, 25.0),
        (0.0, 50.0),
    ];
    follow(&mut rig, &points, false, false);
    let per = (1e9 / rig.ctl.period_ns().as_nanos() as f64).round() as usize;
    let mut track = Track::new(per, cfg.model.body().length / 2.0);
    let mut legs = [(0.0f64, 0usize, f64::NAN); 4];
    let (mut leg, mut switched) = (1u16, rig.time());
    let start = rig.time();
    rig.period();
    while rig.state().guide.guide_state() == Some(GuideState::Following)
        && rig.time() - start < 400.0
    {
        rig.period();
        fixes.poll(&mut rig);
        let g = rig.state().guide;
        if g.leg != leg {
            leg = g.leg;
            switched = rig.time();
        }
        let i = usize::from(leg).saturating_sub(1).min(3);
        if let Some(avg) = track.push(&rig)
            && rig.time() - switched >= 20.0
        {
            let (e, _) = cross_track(avg.centroid, points[i], points[i + 1]);
            legs[i].0 += e * e;
            legs[i].1 += 1;
            legs[i].2 = rig.time() - switched;
        }
    }
    let rms: Vec<String> = legs
        .iter()
        .map(|&(sq, n, _)| format!("{:.4}", (sq / n.max(1) as f64).sqrt()))
        .collect();
    let measured: Vec<String> = legs.iter().map(|l| format!("{:.1}", l.2 - 20.0)).collect();
    println!(
        "{{\"bench\":\"guidance_lawnmower\",\"fixes\":\"{name}\",\"state\":\"{}\",\"seconds\":{:.1},\"rms_per_leg_m\":[{}],\"measured_s_per_leg\":[{}]}}",
        rig.state()
            .guide
            .guide_state()
            .map_or("unknown", GuideState::name),
        rig.time() - start,
        rms.join(","),
        measured.join(",")
    );
}
