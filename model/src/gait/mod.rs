//! Curvature laws: the paper's gaits (42)–(46), a parametric gait for the
//! daemon, and a curvature source driven by measured joint motion.
//!
//! Here the [`Curvature`] and the [`CurvatureSource`] trait every law
//! implements; the laws in `law.rs` (the paper's, [`LawSource`]),
//! `parametric.rs` ([`ParametricGait`]) and `joints.rs` ([`JointCurvature`],
//! [`JointSegment`]).

use nalgebra::Vector3;

mod joints;
mod law;
mod parametric;

pub(crate) use joints::spread_joints;
pub use joints::{JointCurvature, JointMotion, JointSegment, hermite};
pub use law::{GAITS, GaitLaw, LawSource, NamedGait, TurnKind, Wave, gait_names, named_gait, ramp};
pub use parametric::{GaitParams, ParametricGait};

/// Material curvature `K_d = K2 E2 + K3 E3` (1/m) at one abscissa and its
/// first two time derivatives. The `x` (twist) components are always 0.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Curvature {
    /// `K_d`.
    pub k: Vector3<f64>,
    /// `dK_d/dt`.
    pub k_dot: Vector3<f64>,
    /// `d²K_d/dt²`.
    pub k_ddot: Vector3<f64>,
}

/// Where the imposed curvature comes from. The dynamics are generic over it.
pub trait CurvatureSource {
    /// Writes the curvature at normalized abscissae `x[i]` (X1 / length, in
    /// `[0, 1]`) at time `self.time() + tau` into `out[i]`. Must not allocate.
    fn curvature(&self, tau: f64, x: &[f64], out: &mut [Curvature]);
    /// Advances the source's own time (and internal state) by `dt`.
    fn advance(&mut self, dt: f64);
    /// Current time of the source (s).
    fn time(&self) -> f64;
    /// Whether the curvature is a law of the source's time alone:
    /// `curvature(tau)` before `advance(dt)` equals `curvature(tau - dt)`
    /// after it, and nothing else changes it. The model then keeps a
    /// step's last shape (at `tau = dt`) as the next step's first instead
    /// of integrating it again. `false` by default (always integrated):
    /// sources whose parameters a caller changes between steps, or that
    /// follow measurements, must keep it.
    fn is_law_of_time(&self) -> bool {
        false
    }
}

/// `sin, cos` of `a0 + slope * x[i]` for every `x[i]`, by the angle-addition
/// recurrence when `x` is uniformly spaced (the model's grid), else directly.
/// Calls `f(i, sin, cos)`.
#[inline]
fn for_each_sin_cos(x: &[f64], a0: f64, slope: f64, mut f: impl FnMut(usize, f64, f64)) {
    let n = x.len();
    if n == 0 {
        return;
    }
    let dx = if n > 1 { x[1] - x[0] } else { 0.0 };
    let uniform = n > 2 && ((x[n - 1] - x[0]) - dx * (n - 1) as f64).abs() < 1e-12;
    if !uniform {
        for (i, &xi) in x.iter().enumerate() {
            let (s, c) = (a0 + slope * xi).sin_cos();
            f(i, s, c);
        }
        return;
    }
    let (sd, cd) = (slope * dx).sin_cos();
    let (mut s, mut c) = (a0 + slope * x[0]).sin_cos();
    for i in 0..n {
        f(i, s, c);
        // re-anchor every 64 points to bound round-off growth
        if (i + 1) % 64 == 0 && i + 1 < n {
            (s, c) = (a0 + slope * x[i + 1]).sin_cos();
        } else {
            (s, c) = (s * cd + c * sd, c * cd - s * sd);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fd_check(src: &mut impl CurvatureSource, x: f64, tol: f64) {
        let h = 1e-4;
        let mut o = [Curvature::default(); 3];
        src.curvature(-h, &[x], &mut o[0..1]);
        src.curvature(0.0, &[x], &mut o[1..2]);
        src.curvature(h, &[x], &mut o[2..3]);
        let d1 = (o[2].k - o[0].k) / (2.0 * h);
        let d2 = (o[2].k_dot - o[0].k_dot) / (2.0 * h);
        let t1 = tol * (1.0 + o[1].k_dot.norm());
        let t2 = tol * (1.0 + o[1].k_ddot.norm());
        assert!((d1 - o[1].k_dot).norm() < t1, "{d1} vs {}", o[1].k_dot);
        assert!((d2 - o[1].k_ddot).norm() < t2, "{d2} vs {}", o[1].k_ddot);
    }

    #[test]
    fn analytic_derivatives_match_finite_differences() {
        // central differences with h = 1e-4: truncation ~ h² |K'''| ≈ 1e-8
        // times (2 pi)^3 amplitudes ~ 1e3 -> 1e-5; tolerance 1e-4.
        for g in GAITS {
            for &t in &[0.3, 0.77, 1.2, 1.6, 2.2, 3.7, 4.6, 5.0] {
                for &x in &[0.0, 0.3, 0.9] {
                    let mut s = LawSource::new(g.law);
                    s.t = t;
                    fd_check(&mut s, x, 1e-4);
                }
            }
        }
    }

    #[test]
    fn ramp_is_c2() {
        let h = 1e-6;
        for &(t, a, b) in &[(0.0, 0.0, 1.0), (1.0, 0.0, 1.0), (2.0, 1.5, 2.0)] {
            let l = ramp(t - h, a, b);
            let r = ramp(t + h, a, b);
            for k in 0..3 {
                // jump over 2h bounded by 2h max|f'''| = 2e-6 (2 pi)^2/d^3 < 3e-3
                assert!((l[k] - r[k]).abs() < 3e-3, "{t} {k}");
            }
        }
    }

    #[test]
    fn parametric_gait_is_c2_across_parameter_jumps() {
        let mut g = ParametricGait::from_rest(GaitParams::default(), 0.2).unwrap();
        let dt = 1e-3;
        let x = [0.7];
        let mut prev = [Curvature::default()];
        g.curvature(0.0, &x, &mut prev);
        let mut max_jump = [0.0f64; 3];
        for i in 0..3000 {
            if i == 1000 {
                g.set_target(&GaitParams {
                    period: 0.6,
                    wavelength: 0.8,
                    kc3: 1.5,
                    kc2: -0.5,
                    ..GaitParams::default()
                })
                .unwrap();
            }
            // derivative consistency inside the step
            if i % 250 == 7 {
                fd_check(&mut g, 0.7, 5e-3);
            }
            g.advance(dt);
            let mut c = [Curvature::default()];
            g.curvature(0.0, &x, &mut c);
            max_jump[0] = max_jump[0].max((c[0].k - prev[0].k).norm());
            max_jump[1] = max_jump[1].max((c[0].k_dot - prev[0].k_dot).norm());
            max_jump[2] = max_jump[2].max((c[0].k_ddot - prev[0].k_ddot).norm());
            prev = c;
        }
        // continuity: per-ms changes bounded by (rate × dt); K'' changes by
        // at most K''' dt ~ (2 pi)^3 · 3.4 · 1e-3 / 0.6^3 ~ 4 with faster period.
        assert!(max_jump[0] < 0.05, "{max_jump:?}");
        assert!(max_jump[1] < 0.5, "{max_jump:?}");
        assert!(max_jump[2] < 5.0, "{max_jump:?}");
        let p = g.params();
        // triple pole after 10 time constants: error e^-10 (1 + 10 + 50) ≈ 3e-3 of the jump
        assert!(
            (p.period - 0.6).abs() < 1e-2 && (p.kc3 - 1.5).abs() < 1e-2,
            "{p:?}"
        );
    }

    #[test]
    fn bad_gait_parameters_are_rejected_and_the_target_kept() {
        let mut g = ParametricGait::new(GaitParams::default(), 0.2).unwrap();
        let e = g
            .set_target(&GaitParams {
                period: 0.0,
                ..GaitParams::default()
            })
            .unwrap_err();
        assert!(e.to_string().contains("period"), "{e}");
        let e = g
            .set_target(&GaitParams {
                wavelength: f64::NAN,
                ..GaitParams::default()
            })
            .unwrap_err();
        assert!(e.to_string().contains("wavelength"), "{e}");
        assert!(ParametricGait::new(GaitParams::default(), 0.0).is_err());
        g.advance(0.01);
        assert!((g.params().period - 1.0).abs() < 1e-12);
    }

    #[test]
    fn joint_curvature_integrates_to_joint_angle() {
        let mut j = JointCurvature::new(4, 1.0);
        j.joints_mut()[1].yaw = [0.3, 0.0, 0.0];
        let n = 4000;
        let xs: Vec<f64> = (0..=n).map(|i| i as f64 / n as f64).collect();
        let mut o = vec![Curvature::default(); n + 1];
        j.curvature(0.0, &xs, &mut o);
        let s: f64 = o.iter().map(|c| c.k.z).sum::<f64>() / n as f64;
        assert!((s - 0.3).abs() < 1e-6, "{s}");
    }

    #[test]
    fn a_joint_segment_runs_from_its_start_to_its_end_along_its_rates() {
        let mut j = JointSegment::new(3, 1.0);
        let h = 0.002;
        let (a, b) = j.span_mut(h);
        a[1].pitch = [0.1, 2.0, 0.0];
        b[1].pitch = [0.1045, 2.5, 0.0];
        a[1].yaw = [-0.2, -1.0, 0.0];
        b[1].yaw = [-0.2021, -1.1, 0.0];
        // joint 2's span is centred at x = 2/4
        let x = [0.5];
        let dens = 2.0 / (0.25 * 1.0);
        let mut o = [Curvature::default(); 1];
        j.curvature(0.0, &x, &mut o);
        assert!((o[0].k.y / dens - 0.1).abs() < 1e-12 && (o[0].k_dot.y / dens - 2.0).abs() < 1e-9);
        j.curvature(h, &x, &mut o);
        assert!(
            (o[0].k.y / dens - 0.1045).abs() < 1e-12,
            "{}",
            o[0].k.y / dens
        );
        assert!((o[0].k_dot.z / dens + 1.1).abs() < 1e-9);
        // rate and acceleration are the angle's derivatives within the step
        fd_check(&mut j, 0.5, 1e-4);
        // so is the acceleration the rate's, where the pitch rate grows by
        // 0.5 rad/s over the step: 250 rad/s² on average
        let mut acc = 0.0;
        for i in 0..100 {
            j.curvature(h * (i as f64 + 0.5) / 100.0, &x, &mut o);
            acc += o[0].k_ddot.y / dens / 100.0;
        }
        assert!((acc - 250.0).abs() < 1e-6, "{acc}");
    }

    #[test]
    fn every_table_gait_is_named() {
        assert_eq!(GAITS.len(), 15);
        assert!(named_gait("f1").is_some());
        assert!(named_gait("X9").is_none());
        assert!(gait_names().contains("SPIRAL"));
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig { cases: 24, ..Default::default() })]
        /// Random target sequences (fixed seed by proptest's default config):
        /// the curvature stays finite and its per-step changes bounded by its
        /// rates (C0/C1 continuity in the discrete sense).
        #[test]
        fn parametric_gait_random_targets_stay_finite_and_continuous(
            targets in proptest::collection::vec(
                (0.3f64..2.0, 0.4f64..2.0, 0.0f64..3.0, -2.0f64..2.0, -1.0f64..1.0), 1..5)
        ) {
            let mut g = ParametricGait::from_rest(GaitParams::default(), 0.1).unwrap();
            let dt = 1e-3;
            let x = [0.0, 0.5, 1.0];
            let mut prev = [Curvature::default(); 3];
            g.curvature(0.0, &x, &mut prev);
            for (k, &(lambda, period, a2, kc3, kc2)) in targets.iter().enumerate() {
                g.set_target(&GaitParams { wavelength: lambda, period, amplitude: [1.0, 0.5, a2], phase: 0.1 * k as f64, kc3, kc2 }).unwrap();
                for _ in 0..400 {
                    g.advance(dt);
                    let mut c = [Curvature::default(); 3];
                    g.curvature(0.0, &x, &mut c);
                    for (a, b) in c.iter().zip(&prev) {
                        proptest::prop_assert!(a.k.iter().chain(a.k_dot.iter()).chain(a.k_ddot.iter()).all(|v| v.is_finite()));
                        // |dK| <= max|K'| dt with margin 2: K' bounded by the rates seen
                        let bound = 2.0 * dt * (a.k_dot.norm().max(b.k_dot.norm()) + 1e-9) + 1e-6;
                        proptest::prop_assert!((a.k - b.k).norm() <= bound, "{} > {}", (a.k - b.k).norm(), bound);
                    }
                    prev = c;
                }
            }
        }
    }
}
