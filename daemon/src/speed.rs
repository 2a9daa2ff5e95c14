//! The model's steady forward speed against the gait's amplitude, for a
//! tool that asks for a speed (a ROS 2 `cmd_vel`'s `linear.x`) and must
//! command an amplitude (issue 46): [`steady_speeds`] swims the daemon's
//! own model (the same body, control period and gait law as
//! [`crate::control`]) straight ahead at one frequency through a ladder of
//! amplitudes, once at start; [`anguilla_model::SpeedTable`] inverts it
//! (`anguilla link`'s ROS 2 `cmd_vel`, `anguilla ctl follow --speed`).
//!
//! The speed of an undulating swimmer is far from linear in its amplitude
//! (the built-in robot at 1 Hz: 0.03 m/s at amplitude 0.1, 0.33 at 0.4,
//! 0.67 at 1), so a linear `speed / max_speed` asks for the wrong one.
//!
//! ```no_run
//! let cfg = anguilla_daemon::config::Config::default();
//! let speeds = anguilla_daemon::speed::steady_speeds(&cfg, 1.0)?;
//! assert!(speeds[20] > speeds[10]);
//! # Ok::<(), anguilla_model::ModelError>(())
//! ```

use anguilla_model::{
    GaitParams, HeadState, Integrator, Model, ModelConfig, ModelError, ParametricGait, Workspace,
    step_dyn as step,
};

use crate::config::Config;

/// Amplitudes in the table: `0, 1/(N-1), ..., 1`.
pub const N: usize = anguilla_model::SPEED_RUNGS;

/// Gait periods the model swims at each amplitude before it is measured
/// (from the previous amplitude's steady swim, one rung lower): on the
/// default body at 1 Hz, 16 is within 1.6 % of full speed of 20 at every
/// rung and 0.002 m/s at 0.3 m/s (6 was up to 7.8 % short at the low
/// amplitudes, where the body takes longest to reach its speed).
pub const SETTLE_PERIODS: usize = 16;
/// Gait periods averaged at each amplitude (whole periods: the speed
/// oscillates twice a period).
pub const MEASURE_PERIODS: usize = 2;

/// The model's steady forward speed (m/s) at amplitudes `i / (N - 1)`
/// (index `i`), straight ahead at `frequency` (Hz, limited to `[gait]
/// max-frequency`): `cfg`'s model swims through the amplitudes from 0 to
/// 1, each after the last, [`SETTLE_PERIODS`] gait periods to settle and
/// [`MEASURE_PERIODS`] measured. Some seconds of simulated swimming per
/// amplitude (about 1 s of CPU in all in a debug build); call it once, at
/// start.
pub fn steady_speeds(cfg: &Config, frequency: f64) -> Result<[f64; N], ModelError> {
    let frequency = frequency.min(cfg.gait.max_frequency);
    let dt = crate::control::period_ns(cfg).as_nanos() as f64 * 1e-9;
    let model = Model::new(ModelConfig {
        body: cfg.model.body(),
        nodes: cfg.model.nodes,
        dt,
        joints: cfg.robot.joints,
        integrator: Integrator::Midpoint,
    })?;
    let poly = cfg.gait.amplitude_polynomial;
    let period = 1.0 / frequency;
    let params = |a: f64| GaitParams {
        wavelength: cfg.gait.wavelength,
        period,
        amplitude: [poly[0] * a, poly[1] * a, poly[2] * a],
        phase: 0.0,
        kc3: 0.0,
        kc2: 0.0,
    };
    let mut gait = ParametricGait::new(params(0.0), 0.05)?;
    let mut ws = Workspace::new(&model);
    let mut head = HeadState::launch(0.0);
    let per = (period / dt).round().max(1.0) as usize;
    let mut speeds = [0.0; N];
    for (i, s) in speeds.iter_mut().enumerate().skip(1) {
        gait.set_target(&params(i as f64 / (N - 1) as f64))?;
        for _ in 0..SETTLE_PERIODS * per {
            step(&model, &mut ws, &mut gait, &mut head)?;
        }
        let mut sum = 0.0;
        for _ in 0..MEASURE_PERIODS * per {
            sum += step(&model, &mut ws, &mut gait, &mut head)?.forward_speed;
        }
        *s = sum / (MEASURE_PERIODS * per) as f64;
    }
    Ok(speeds)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The default body swims faster with amplitude, and far from
    /// linearly.
    #[test]
    fn the_default_body_swims_faster_with_amplitude() {
        let cfg = Config::default();
        let s = steady_speeds(&cfg, 1.0).unwrap();
        eprintln!("steady speeds at 1 Hz (m/s): {s:.3?}");
        assert_eq!(s[0], 0.0);
        assert!(s.windows(2).all(|w| w[1] > w[0]), "{s:?}");
        // far from linear: a tenth of the amplitude swims far less than a
        // tenth of the speed
        assert!(s[2] < 0.2 * s[N - 1] && s[N - 1] > 0.5, "{s:?}");
    }
}
