//! Identification of the body's hydrodynamic coefficients from recorded
//! swims (`anguilla calibrate`, docs/calibration.md).
//!
//! **The recorded joint motion, smoothed** ([`smooth`]): each axis's
//! quantised angles and rates are fused by a Kalman filter and a
//! Rauch–Tung–Striebel smoother before anything is replayed, so that the
//! accelerations the model's reactive forces need are not the encoder's
//! quantisation divided by the sample interval squared. [`steps`] tells
//! how coarse a recording is; rates in steps above [`COARSE_RATE`] (classic
//! CAN's 8-bit feedback) are too coarse to fit.
//!
//! **Output error.** A recorded [`Swim`] holds the joints' measured
//! motion and torques, and the head's horizontal track, heading and depth.
//! The model is driven by the recorded joint motion (the angles, rates and
//! accelerations of a cubic Hermite curve through the samples, at every
//! stage of every step), from rest, with candidate coefficients; its head swims where the
//! coefficients take it, and its internal torques follow. The residuals
//! ([`replay`]) compare, on a 10 Hz grid, the forward speed, the turn rate
//! and the depth rate (each over a one-second window, so that no frame,
//! origin or heading offset matters) and the head's sway (its yaw's RMS
//! about a line over the window), and at every joint sample the
//! measured torque with the model's, delayed by the drive's torque lag,
//! plus the drive's own inertia and friction (`J θ̈ + b θ̇`; the three
//! solved linearly at every evaluation: nuisances the drive adds, not the
//! water). Each group is divided by its
//! measured RMS (with a floor) and by the square root of its count, so
//! that torques, speed, turning, diving and sway weigh alike.
//!
//! **Levenberg–Marquardt** (`lm.rs`) minimises their sum of squares over
//! the chosen coefficients, each scaled by its prior (or a floor for a
//! zero prior), with a finite-difference Jacobian whose simulations run on
//! every core. At the optimum, the Jacobian gives each coefficient's
//! standard error (inflated for the residuals' autocorrelation) and their
//! correlations. A coefficient the swims know less well than the prior
//! does (its standard error beyond [`PRIOR_SPREAD`] of it) is left at the
//! prior, the worst first, and so is one of two the swims cannot tell
//! apart (correlated beyond [`MAX_CORRELATION`]: the nose's drag and the
//! skin friction), and the others are fitted again; one of those
//! is *identified* when its 95 % interval (its standard error with the
//! replay's own bias, [`REPLAY_BIAS`], added), widened by what the ones left
//! at the prior may be off by (Schmidt's consider covariance), is within
//! 5 % of its value (or of the floor). One fitted but not identified
//! stands in for what the prior's lack (the skin friction for the nose's
//! drag). The report says what the swims lacked
//! ([`Coefficient::needs`]).
//!
//! Nothing here reads a file: the daemon's `mcap_log::swim` turns a
//! recorded session into a [`Swim`].

pub mod check;
mod lm;
pub mod replay;
mod smooth;
mod swim;

pub use smooth::{COARSE_RATE, smooth, steps};
pub use swim::{JointSample, Swim};

use crate::body::{AxialDrag, Body};
use crate::error::ModelError;

/// Why a fit could not run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FitError {
    /// A swim is not usable; the text says which and why.
    #[error("{0}")]
    Swim(String),
    /// The prior body is invalid, or the model failed replaying a swim.
    #[error(transparent)]
    Model(#[from] ModelError),
}
pub use replay::{
    Channels, Evaluation, Measured, SwimError, TorqueBias, Trace, evaluate, simulate,
};

/// A coefficient the fit can adjust.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Coefficient {
    /// Nose pressure drag `c_p` (22).
    CP,
    /// Nose added mass `k` (23).
    K,
    /// Roll drag `c_1` (24).
    C1,
    /// Lateral drag `c_2` (24).
    C2,
    /// Vertical drag `c_3` (24).
    C3,
    /// The factor on the skin friction (41).
    Friction,
}

impl Coefficient {
    /// Every coefficient, in `[model]`'s order.
    pub const ALL: [Coefficient; 6] = [
        Coefficient::CP,
        Coefficient::K,
        Coefficient::C1,
        Coefficient::C2,
        Coefficient::C3,
        Coefficient::Friction,
    ];

    /// Its name on the command line (`--fit c_p,k,c1,c2,c3,friction`).
    pub fn name(self) -> &'static str {
        match self {
            Coefficient::CP => "c_p",
            Coefficient::K => "k",
            Coefficient::C1 => "c1",
            Coefficient::C2 => "c2",
            Coefficient::C3 => "c3",
            Coefficient::Friction => "friction",
        }
    }

    /// Its key in `[model]`.
    pub fn key(self) -> &'static str {
        match self {
            Coefficient::CP => "c-p",
            other => other.name(),
        }
    }

    /// The coefficient named `name` (its command-line name or its key).
    pub fn parse(name: &str) -> Option<Coefficient> {
        Self::ALL
            .into_iter()
            .find(|c| c.name() == name || c.key() == name)
    }

    /// Its value in `body` (the friction factor is 1 for another law).
    pub fn get(self, body: &Body) -> f64 {
        match self {
            Coefficient::CP => body.c_p,
            Coefficient::K => body.k_nose,
            Coefficient::C1 => body.c1,
            Coefficient::C2 => body.c2,
            Coefficient::C3 => body.c3,
            Coefficient::Friction => match body.axial {
                AxialDrag::SkinFriction { scale } => scale,
                AxialDrag::Quadratic { .. } => 1.0,
            },
        }
    }

    /// Sets it in `body` (the friction factor makes the law (41)).
    pub fn set(self, body: &mut Body, v: f64) {
        match self {
            Coefficient::CP => body.c_p = v,
            Coefficient::K => body.k_nose = v,
            Coefficient::C1 => body.c1 = v,
            Coefficient::C2 => body.c2 = v,
            Coefficient::C3 => body.c3 = v,
            Coefficient::Friction => body.axial = AxialDrag::SkinFriction { scale: v },
        }
    }

    /// The scale its uncertainty is judged against when its value is
    /// smaller: the paper's `c_1` is 0.
    pub fn floor(self) -> f64 {
        match self {
            Coefficient::C1 => 0.1,
            Coefficient::K => 0.05,
            Coefficient::CP => 0.005,
            _ => 0.05,
        }
    }

    /// What a swim must contain to identify it.
    pub fn needs(self) -> &'static str {
        match self {
            Coefficient::CP => {
                "the nose's drag grows as v² and the skin's as v^1.5..1.8: telling them apart \
                 needs forward swims over a wide range of speeds"
            }
            Coefficient::K => {
                "the nose's added mass acts only on the head's axial acceleration: it needs \
                 hard starts, stops and surges"
            }
            Coefficient::C1 => "roll drag needs roll motion (rolling the body about its axis)",
            Coefficient::C2 => "lateral drag needs undulation",
            Coefficient::C3 => "vertical drag needs pitching: dives and climbs",
            Coefficient::Friction => "skin friction needs forward swimming",
        }
    }
}

/// Parses a `--fit` list, e.g. `c_p,k,c2`; the error names the unknown one.
pub fn parse_coefficients(list: &str) -> std::result::Result<Vec<Coefficient>, String> {
    let mut out = Vec::new();
    for name in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let c = Coefficient::parse(name).ok_or_else(|| {
            format!(
                "unknown coefficient '{name}' (expected some of {})",
                Coefficient::ALL.map(Coefficient::name).join(",")
            )
        })?;
        if !out.contains(&c) {
            out.push(c);
        }
    }
    if out.is_empty() {
        return Err("no coefficient to fit".into());
    }
    Ok(out)
}

/// How to fit.
#[derive(Debug, Clone, PartialEq)]
pub struct FitOptions {
    /// The coefficients to adjust; the others keep the prior's values.
    pub fit: Vec<Coefficient>,
    /// Space nodes of the model replaying the swims (52, the simulated
    /// robot's: at 26, on recordings of it, `c2` and `c3` came out 2.5 %
    /// high whether the robot's body had 52 or 104; at 52, within 1 %).
    pub nodes: usize,
    /// Its time step (s): 5 ms (RK4, the joints on their Hermite curve at
    /// every stage: a 10 s fast, turning swim ends within 2 % of the
    /// distance swum from where a 1.25 ms step ends it, 2.5 ms within
    /// 0.5 %; `tests/identify.rs`).
    pub dt: f64,
    /// The torques' weight against the head's motion (1: alike).
    pub torque_weight: f64,
    /// Most Levenberg–Marquardt iterations.
    pub max_iterations: usize,
    /// Threads for the simulations (0: every core).
    pub threads: usize,
    /// The drives' own reflected inertia (kg·m²), viscous friction
    /// (N·m·s/rad) and torque lag (s), if known: a held-out session is
    /// judged with those a fit found ([`Evaluation::actuator`]), not
    /// refitted to it (which would let them absorb the coefficients'
    /// error). `None`: fitted with every body by least squares.
    pub actuator: Option<[f64; replay::DRIVE]>,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self {
            fit: Coefficient::ALL.to_vec(),
            nodes: 52,
            dt: 0.005,
            torque_weight: TORQUE_WEIGHT,
            max_iterations: 25,
            threads: 0,
            actuator: None,
        }
    }
}

/// One coefficient's result.
#[derive(Debug, Clone, PartialEq)]
pub struct Estimate {
    /// Which.
    pub coefficient: Coefficient,
    /// The prior's value.
    pub prior: f64,
    /// The value the fitted body has: the estimate when fitted, else the
    /// prior's.
    pub value: f64,
    /// The best estimate, identified or not (of one left at the prior:
    /// the first pass's, every coefficient asked for free).
    pub estimate: f64,
    /// One standard error of the estimate (same unit): of one fitted,
    /// widened by the spread of those left at the prior.
    pub std_error: f64,
    /// Whether the swims identify it (95 % interval within 5 % of its
    /// value or floor, counting the spread of those left at the prior).
    pub identified: bool,
    /// Whether the fit set it from the swims (identified or not: one that
    /// is not stands in for what the ones left at the prior lack); the
    /// others are at the prior, the swims knowing less of them than
    /// [`PRIOR_SPREAD`].
    pub fitted: bool,
    /// The coefficient it is most correlated with, and the correlation.
    pub correlated: Option<(Coefficient, f64)>,
    /// Of one left at the prior for its correlation with another fitted
    /// one (beyond [`MAX_CORRELATION`]): that one, and the correlation;
    /// `None` for one left at the prior because the swims know less of
    /// it than the prior does (and for every fitted one).
    pub confounded: Option<(Coefficient, f64)>,
}

/// What a fit found.
#[derive(Debug, Clone)]
pub struct Fit {
    /// The body with the fitted coefficients.
    pub body: Body,
    /// Every coefficient asked for, in the order asked.
    pub estimates: Vec<Estimate>,
    /// The swims' residuals with the prior's coefficients.
    pub before: Evaluation,
    /// With the fitted body (the fitted estimates, the prior's others).
    pub after: Evaluation,
    /// With every estimate, identified or not.
    pub estimated: Evaluation,
    /// Model replays of the swims run.
    pub simulations: usize,
    /// Levenberg–Marquardt iterations run (all passes).
    pub iterations: usize,
}

/// The torques' default weight: on the simulated robot they keep an
/// error of about 0.05 N·m RMS that no coefficient explains (the servos'
/// coupling to the body, the feedback's one-period lag), which at full
/// weight would pull the coefficients off the head's motion.
pub const TORQUE_WEIGHT: f64 = 0.1;

/// Per coefficient: its estimate, standard error and strongest
/// correlation.
type Found = std::collections::BTreeMap<Coefficient, (f64, f64, Option<(Coefficient, f64)>)>;

/// The relative half-width of the 95 % interval within which a
/// coefficient counts as identified.
pub const IDENTIFIED_WITHIN: f64 = 0.05;

/// The replay's own systematic error, relative to a fitted coefficient
/// (or to its floor), one standard deviation, added in quadrature to the
/// standard error from the residuals: a bias that every part of a swim
/// shares (the joint motion rebuilt from its samples, the torques'
/// floor) is not in the residuals' noise. Set on the simulated robot's
/// bodies of the calibration benchmark: seeds 1–3's identified `c1`,
/// `c2`, `c3` came back with errors of 0.8 % RMS (the largest 2.1 %,
/// while their standard errors from the residuals were 0.1–0.5 %);
/// checked on seeds 4–6, none of whose errors (1.0 % at most) is
/// outside its 95 % interval with it (docs/calibration.md). A real robot's
/// other laws add more, which the held-out sessions show.
pub const REPLAY_BIAS: f64 = 0.01;

/// The correlation beyond which two fitted coefficients count as one
/// (the swims tell only a combination of them, such as the nose's drag
/// and the skin friction, both resisting forward motion): the one whose
/// prior is the better knowledge is left at it, and widens the other's
/// interval by what it may be off by.
pub const MAX_CORRELATION: f64 = 0.95;

/// How far the model's prior coefficients may be from a robot's, one
/// standard deviation as a fraction of the prior: a coefficient the fit
/// leaves at its prior widens the others' intervals by this much of its
/// own (the bodies of issue 30 differ from the paper's by up to ±40 %:
/// two of these).
pub const PRIOR_SPREAD: f64 = 0.2;

/// The errors of each of `bodies` against `swims` (held-out sessions,
/// say): the swims' joint motion smoothed as the fit smooths it
/// ([`smooth`]), the channels weighed as the fit weighs them, each body
/// replayed with `opts`' discretisation.
pub fn compare(
    bodies: &[&Body],
    swims: &[Swim],
    opts: &FitOptions,
) -> Result<Vec<Evaluation>, FitError> {
    for s in swims {
        s.validate().map_err(FitError::Swim)?;
    }
    let smoothed: Vec<Swim> = swims.iter().map(|s| smooth(s).0).collect();
    let mut m = replay::Measured::of(&smoothed, opts.torque_weight);
    m.actuator = opts.actuator;
    bodies
        .iter()
        .map(|b| Ok(replay::evaluate(b, &smoothed, &m, opts.nodes, opts.dt)?))
        .collect()
}

/// Fits `opts.fit` of `prior` to `swims`. Every swim is replayed from rest
/// ([`replay`]); the prior also sets everything not fitted (geometry,
/// density, ballast).
pub fn fit(prior: &Body, swims: &[Swim], opts: &FitOptions) -> Result<Fit, FitError> {
    prior.validate()?;
    if swims.is_empty() {
        return Err(FitError::Swim("no swim to fit".into()));
    }
    let joints = swims[0].joints();
    for s in swims {
        s.validate().map_err(FitError::Swim)?;
        if s.joints() != joints {
            return Err(FitError::Swim(format!(
                "{} has {} joints, {} has {joints}",
                s.name,
                s.joints(),
                swims[0].name
            )));
        }
    }
    let smoothed: Vec<Swim> = swims.iter().map(|s| smooth(s).0).collect();
    let swims = &smoothed[..];
    let mut measured = replay::Measured::of(swims, opts.torque_weight);
    measured.actuator = opts.actuator;
    let ctx = lm::Problem {
        prior,
        swims,
        measured: &measured,
        nodes: opts.nodes,
        dt: opts.dt,
        threads: opts.threads,
    };
    // Fit everything asked for. Then leave at its prior every coefficient
    // the swims know less well than the prior does (its standard error,
    // the others free, beyond PRIOR_SPREAD; the worst first, as removing
    // one narrows those it was confounded with), and fit the rest again
    // (so that what the data cannot tell does not wander off and drag the
    // others with it). A coefficient fitted is *identified* when its 95 %
    // interval, widened by what the ones left at the prior may be off by
    // (`lm::consider`), is within IDENTIFIED_WITHIN.
    let first = lm::solve(&ctx, prior, &opts.fit, opts.max_iterations)?;
    let mut simulations = first.simulations;
    let mut iterations = first.iterations;
    let width = |c: Coefficient, at: &Body, se: f64| 2.0 * se / c.get(at).abs().max(c.floor());
    let mut kept: Vec<usize> = (0..opts.fit.len()).collect();
    let mut dropped: Vec<usize> = Vec::new();
    let mut confounded: std::collections::BTreeMap<Coefficient, (Coefficient, f64)> =
        std::collections::BTreeMap::new();
    while !kept.is_empty() {
        let se = lm::consider(
            &ctx,
            &opts.fit,
            &first.residuals,
            &first.jacobian,
            &kept,
            &[],
        );
        let excess: Vec<f64> = kept
            .iter()
            .zip(&se)
            .map(|(&i, &s)| {
                let c = opts.fit[i];
                s / lm::scale(c, prior) / lm::prior_spread(c, prior)
            })
            .collect();
        let Some((worst, &e)) = excess.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)) else {
            break;
        };
        if e > 1.0 {
            dropped.push(kept.remove(worst));
            continue;
        }
        // two the swims cannot tell apart: the one its prior knows better
        // (relative to what the swims say) stays at it
        let corr = lm::correlations(&ctx, &first.residuals, &first.jacobian, &kept);
        let pair = corr.and_then(|c| {
            (0..kept.len())
                .flat_map(|a| (a + 1..kept.len()).map(move |b| (a, b)))
                .map(|(a, b)| (a, b, c[(a, b)]))
                .filter(|&(_, _, r)| r.abs() > MAX_CORRELATION)
                .max_by(|x, y| x.2.abs().total_cmp(&y.2.abs()))
        });
        let Some((a, b, r)) = pair else {
            break;
        };
        let (drop, other) = if excess[a] >= excess[b] {
            (a, b)
        } else {
            (b, a)
        };
        confounded.insert(opts.fit[kept[drop]], (opts.fit[kept[other]], r));
        dropped.push(kept.remove(drop));
    }
    let mut found: Found = opts
        .fit
        .iter()
        .enumerate()
        .map(|(i, &c)| {
            (
                c,
                (c.get(&first.body), first.std_errors[i], first.correlated[i]),
            )
        })
        .collect();
    let mut identified: Vec<Coefficient> = Vec::new();
    let free: Vec<Coefficient> = kept.iter().map(|&i| opts.fit[i]).collect();
    let body = if kept.is_empty() {
        prior.clone()
    } else {
        let second = if dropped.is_empty() {
            first
        } else {
            let second = lm::solve(&ctx, prior, &free, opts.max_iterations)?;
            simulations += second.simulations;
            iterations += second.iterations;
            second
        };
        // the consider intervals at the second optimum: the dropped
        // ones' columns there
        let all: Vec<Coefficient> = free
            .iter()
            .chain(dropped.iter().map(|&i| &opts.fit[i]))
            .copied()
            .collect();
        let (r, jac) = if dropped.is_empty() {
            (second.residuals.clone(), second.jacobian.clone())
        } else {
            simulations += (all.len() + 1) * swims.len();
            lm::jacobian_at(&ctx, &second.body, &all)?
        };
        let k: Vec<usize> = (0..free.len()).collect();
        let d: Vec<usize> = (free.len()..all.len()).collect();
        let se = lm::consider(&ctx, &all, &r, &jac, &k, &d);
        for (i, &c) in free.iter().enumerate() {
            // the residuals' noise and the replay's own bias
            let v = c.get(&second.body);
            let se = se[i].hypot(REPLAY_BIAS * v.abs().max(c.floor()));
            found.insert(c, (v, se, second.correlated[i]));
            if width(c, &second.body, se) <= IDENTIFIED_WITHIN {
                identified.push(c);
            }
        }
        second.body
    };
    let before = replay::evaluate(prior, swims, &measured, opts.nodes, opts.dt)?;
    let after = replay::evaluate(&body, swims, &measured, opts.nodes, opts.dt)?;
    let mut all = prior.clone();
    for (c, (v, _, _)) in &found {
        c.set(&mut all, *v);
    }
    let estimated = replay::evaluate(&all, swims, &measured, opts.nodes, opts.dt)?;
    simulations += 3 * swims.len();
    let estimates = opts
        .fit
        .iter()
        .map(|&c| {
            let (estimate, std_error, correlated) =
                found.get(&c).copied().unwrap_or((f64::NAN, f64::NAN, None));
            Estimate {
                coefficient: c,
                prior: c.get(prior),
                value: c.get(&body),
                estimate,
                std_error,
                identified: identified.contains(&c),
                fitted: free.contains(&c),
                correlated,
                confounded: confounded.get(&c).copied(),
            }
        })
        .collect();
    Ok(Fit {
        body,
        estimates,
        before,
        after,
        estimated,
        simulations,
        iterations,
    })
}
