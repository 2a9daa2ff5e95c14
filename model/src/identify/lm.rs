//! Levenberg–Marquardt over scaled coefficients, its simulations spread
//! over threads, and the standard errors at the optimum.

use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

use nalgebra::{DMatrix, DVector};

use super::Coefficient;
use super::replay::{self, Measured, Trace};
use super::swim::Swim;
use crate::body::Body;
use crate::error::{ModelError, Result};

/// What every evaluation shares.
pub(super) struct Problem<'a> {
    pub prior: &'a Body,
    pub swims: &'a [Swim],
    pub measured: &'a Measured,
    pub nodes: usize,
    pub dt: f64,
    pub threads: usize,
}

/// One Levenberg–Marquardt run's result.
pub(super) struct Run {
    pub body: Body,
    /// One standard error per free coefficient (its unit).
    pub std_errors: Vec<f64>,
    /// Per free coefficient: the other free one it is most correlated
    /// with.
    pub correlated: Vec<Option<(Coefficient, f64)>>,
    /// The weighted residuals at the optimum.
    pub residuals: Vec<f64>,
    /// Their Jacobian there (a column per free coefficient, scaled units).
    pub jacobian: DMatrix<f64>,
    pub simulations: usize,
    pub iterations: usize,
}

/// Forward-difference step in scaled units.
const FD_STEP: f64 = 1e-3;

/// The longest Levenberg–Marquardt step, in scaled units (a fraction of
/// each coefficient's prior): the bodies of issue 30 are within ±40 % of
/// it.
const MAX_STEP: f64 = 0.25;

/// A coefficient's unit in the fit: its prior, or its floor for a zero prior.
pub(super) fn scale(c: Coefficient, prior: &Body) -> f64 {
    c.get(prior).abs().max(c.floor())
}

fn body_at(p: &Problem, base: &Body, free: &[Coefficient], theta: &[f64]) -> Body {
    let mut b = base.clone();
    for (c, th) in free.iter().zip(theta) {
        c.set(&mut b, (th * scale(*c, p.prior)).max(0.0));
    }
    b
}

/// Replays every swim on every body, spread over the threads.
fn replay_all(p: &Problem, bodies: &[Body]) -> Vec<Result<Vec<Trace>>> {
    let s = p.swims.len();
    let jobs = bodies.len() * s;
    let results: Mutex<Vec<Option<Result<Trace>>>> = Mutex::new((0..jobs).map(|_| None).collect());
    let next = AtomicUsize::new(0);
    let threads = match p.threads {
        0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
        n => n,
    }
    .min(jobs)
    .max(1);
    std::thread::scope(|scope| {
        for _ in 0..threads {
            scope.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    if i >= jobs {
                        break;
                    }
                    let r = replay::simulate(&bodies[i / s], &p.swims[i % s], p.nodes, p.dt);
                    if let Ok(mut v) = results.lock() {
                        v[i] = Some(r);
                    }
                }
            });
        }
    });
    let mut flat = results.into_inner().unwrap_or_default().into_iter();
    (0..bodies.len())
        .map(|_| {
            (0..s)
                .map(|_| {
                    flat.next()
                        .flatten()
                        .unwrap_or(Err(ModelError::InvalidParameter {
                            name: "replay",
                            value: f64::NAN,
                            range: "a thread that finished",
                        }))
                })
                .collect()
        })
        .collect()
}

fn residuals(p: &Problem, traces: &[Trace]) -> Vec<f64> {
    let mut out = Vec::new();
    replay::residuals(traces, p.swims, p.measured, &mut out);
    out
}

/// The residuals at `theta` and the Jacobian there (columns in scaled
/// units), `1 + free` replays of every swim.
fn linearize(
    p: &Problem,
    base: &Body,
    free: &[Coefficient],
    theta: &[f64],
) -> Result<(Vec<f64>, DMatrix<f64>)> {
    let mut bodies = vec![body_at(p, base, free, theta)];
    for i in 0..free.len() {
        let mut th = theta.to_vec();
        th[i] += FD_STEP;
        bodies.push(body_at(p, base, free, &th));
    }
    let mut all = replay_all(p, &bodies).into_iter();
    let r0 = residuals(p, &all.next().unwrap_or(Ok(Vec::new()))?);
    let mut jac = DMatrix::zeros(r0.len(), free.len());
    for (i, traces) in all.enumerate() {
        let r = residuals(p, &traces?);
        for (k, (a, b)) in r.iter().zip(&r0).enumerate() {
            jac[(k, i)] = (a - b) / FD_STEP;
        }
    }
    Ok((r0, jac))
}

/// Levenberg–Marquardt on `free` from `start` (the others as in `start`).
pub(super) fn solve(
    p: &Problem,
    start: &Body,
    free: &[Coefficient],
    max_iterations: usize,
) -> Result<Run> {
    let m = free.len();
    let mut theta: Vec<f64> = free
        .iter()
        .map(|c| c.get(start) / scale(*c, p.prior))
        .collect();
    let mut simulations = 0;
    let mut lambda = 1e-3;
    let mut iterations = 0;
    let (mut r, mut jac) = linearize(p, start, free, &theta)?;
    simulations += (m + 1) * p.swims.len();
    let mut cost: f64 = r.iter().map(|x| x * x).sum();
    'outer: for _ in 0..max_iterations {
        iterations += 1;
        let jt = jac.transpose();
        let a = &jt * &jac;
        let g = &jt * DVector::from_column_slice(&r);
        // the damping is the same for every coefficient (each is in units
        // of its prior already): it shortens the step most along what the
        // swims tell least, where the linearisation is least to be trusted
        let mean_curvature = (a.trace() / m as f64).max(1e-12);
        // a coefficient held at zero that the gradient pushes below it is
        // left out of the step (an active bound): otherwise every step
        // asks for it, is clipped, and the fit crawls (c1 at zero on the
        // paper's body took 50 iterations instead of 13)
        let held: Vec<bool> = (0..m).map(|i| theta[i] <= 0.0 && g[i] > 0.0).collect();
        let mut improved = false;
        for _ in 0..12 {
            // a trust region: the damping grows until the step is within
            // MAX_STEP of every coefficient's unit (the linearisation does
            // not hold further: an undamped first step from the prior
            // jumped to six times the nose's drag and no skin friction, a
            // valley the fit never left)
            let mut delta = None;
            for _ in 0..40 {
                let mut damped = a.clone();
                let mut rhs = -&g;
                for i in 0..m {
                    damped[(i, i)] += lambda * mean_curvature;
                    if held[i] {
                        damped.row_mut(i).fill(0.0);
                        damped.column_mut(i).fill(0.0);
                        damped[(i, i)] = 1.0;
                        rhs[i] = 0.0;
                    }
                }
                match damped.lu().solve(&rhs) {
                    Some(d) if d.amax() <= MAX_STEP => {
                        delta = Some(d);
                        break;
                    }
                    _ => lambda *= 10.0,
                }
            }
            let Some(delta) = delta else { break };
            if delta.amax() == 0.0 {
                // every coefficient held at its bound: nothing to move
                break 'outer;
            }
            let trial: Vec<f64> = theta
                .iter()
                .zip(delta.iter())
                .map(|(t, d)| (t + d).max(0.0))
                .collect();
            let body = body_at(p, start, free, &trial);
            simulations += p.swims.len();
            let traces = replay_all(p, std::slice::from_ref(&body)).pop();
            let Some(Ok(traces)) = traces else {
                lambda *= 10.0;
                continue;
            };
            let rt = residuals(p, &traces);
            let ct: f64 = rt.iter().map(|x| x * x).sum();
            if ct < cost {
                // the step taken, bounds included
                let step: f64 = trial
                    .iter()
                    .zip(&theta)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max);
                let gain = (cost - ct) / cost.max(1e-300);
                theta = trial;
                cost = ct;
                lambda = (lambda / 10.0).max(1e-9);
                improved = true;
                let (r2, j2) = linearize(p, start, free, &theta)?;
                simulations += (m + 1) * p.swims.len();
                r = r2;
                jac = j2;
                if gain < 1e-6 || step < 1e-5 {
                    break 'outer;
                }
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    let (std_errors, correlated) = uncertainty(p, free, &r, &jac);
    Ok(Run {
        body: body_at(p, start, free, &theta),
        std_errors,
        correlated,
        residuals: r,
        jacobian: jac,
        simulations,
        iterations,
    })
}

/// The autocorrelation of a series at lag `lag`.
fn autocorrelation(v: &[f64], lag: usize) -> f64 {
    if v.len() < lag + 2 {
        return 0.0;
    }
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    let (mut num, mut den) = (0.0, 0.0);
    for (i, x) in v.iter().enumerate() {
        den += (x - mean) * (x - mean);
        if i >= lag {
            num += (x - mean) * (v[i - lag] - mean);
        }
    }
    if den > 0.0 { num / den } else { 0.0 }
}

/// The covariance of the coefficients of `jac`'s columns (scaled units)
/// by the sandwich estimator: each group's residual variance, inflated by
/// its autocorrelation one sample apart in time, `(1 + ρ) / (1 − ρ)`
/// (neighbouring samples of a swim are not independent measurements; a
/// torque's neighbour in time is the same axis's next sample, one joint
/// count of pairs further on). `None` where `jac`'s columns
/// are dependent.
fn covariance(p: &Problem, r: &[f64], jac: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let m = jac.ncols();
    let ainv = (jac.transpose() * jac).try_inverse()?;
    let mut meat = DMatrix::zeros(m, m);
    let mut start = 0;
    for (group, &count) in p.measured.counts.iter().enumerate() {
        let end = (start + count).min(r.len());
        let g = &r[start..end];
        if !g.is_empty() {
            let n = g.len() as f64;
            // one step of time: the next grid point, or the same axis's
            // next torque sample
            let lag = if group == replay::TORQUE {
                p.measured.torque_stride.max(1)
            } else {
                1
            };
            let rho = autocorrelation(g, lag).clamp(0.0, 0.999);
            let var = g.iter().map(|x| x * x).sum::<f64>() / n * (1.0 + rho) / (1.0 - rho);
            let jg = jac.rows(start, end - start);
            meat += jg.transpose() * jg * var;
        }
        start = end;
    }
    let dof = (r.len() as f64 / (r.len() as f64 - m as f64).max(1.0)).max(1.0);
    Some(&ainv * meat * &ainv * dof)
}

/// The correlations of the coefficients `kept` (indices into `jac`'s
/// columns) with the others free, by [`covariance`]; `None` where their
/// columns are dependent.
pub(super) fn correlations(
    p: &Problem,
    r: &[f64],
    jac: &DMatrix<f64>,
    kept: &[usize],
) -> Option<DMatrix<f64>> {
    let cov = covariance(p, r, &jac.select_columns(kept))?;
    let n = kept.len();
    Some(DMatrix::from_fn(n, n, |i, j| correlation(&cov, i, j)))
}

/// The correlation of `cov`'s `i`th and `j`th coefficients (not finite
/// where either has no variance).
fn correlation(cov: &DMatrix<f64>, i: usize, j: usize) -> f64 {
    cov[(i, j)] / (cov[(i, i)] * cov[(j, j)]).sqrt()
}

/// Standard errors (coefficient units) and strongest correlations, by
/// [`covariance`].
fn uncertainty(
    p: &Problem,
    free: &[Coefficient],
    r: &[f64],
    jac: &DMatrix<f64>,
) -> (Vec<f64>, Vec<Option<(Coefficient, f64)>>) {
    let m = free.len();
    let Some(cov) = covariance(p, r, jac) else {
        return (vec![f64::INFINITY; m], vec![None; m]);
    };
    let se: Vec<f64> = (0..m)
        .map(|i| cov[(i, i)].max(0.0).sqrt() * scale(free[i], p.prior))
        .collect();
    let corr = (0..m)
        .map(|i| {
            (0..m)
                .filter(|&j| j != i)
                .map(|j| (free[j], correlation(&cov, i, j)))
                .filter(|(_, c)| c.is_finite())
                .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
        })
        .collect();
    (se, corr)
}

/// How far a coefficient left at its prior may be from the body's, one
/// standard deviation in scaled units: a fifth of the prior (the bodies
/// of issue 30 differ from the paper's by up to ±40 %, two of these), or
/// the floor itself for a zero prior.
pub(super) fn prior_spread(c: Coefficient, prior: &Body) -> f64 {
    if c.get(prior) == 0.0 {
        1.0
    } else {
        super::PRIOR_SPREAD
    }
}

/// Standard errors (coefficient units) of the coefficients `kept` (indices
/// into `free`, the columns of `jac`) when the ones `dropped` stay at their
/// prior: the sandwich covariance of `kept` alone plus what the dropped
/// ones' own spread ([`prior_spread`]) moves them by, `S Σ Sᵀ` with `S =
/// (J_kᵀ J_k)⁻¹ J_kᵀ J_d` (Schmidt's *consider* covariance). A coefficient
/// that only the dropped ones' prior holds in place is not identified,
/// however narrow its own interval.
pub(super) fn consider(
    p: &Problem,
    free: &[Coefficient],
    r: &[f64],
    jac: &DMatrix<f64>,
    kept: &[usize],
    dropped: &[usize],
) -> Vec<f64> {
    let jk = jac.select_columns(kept);
    let Some(mut cov) = covariance(p, r, &jk) else {
        return vec![f64::INFINITY; kept.len()];
    };
    if !dropped.is_empty() {
        let jd = jac.select_columns(dropped);
        let Some(ainv) = (jk.transpose() * &jk).try_inverse() else {
            return vec![f64::INFINITY; kept.len()];
        };
        let s = ainv * jk.transpose() * jd;
        let sigma = DMatrix::from_diagonal(&nalgebra::DVector::from_iterator(
            dropped.len(),
            dropped
                .iter()
                .map(|&d| prior_spread(free[d], p.prior).powi(2)),
        ));
        cov += &s * sigma * s.transpose();
    }
    kept.iter()
        .enumerate()
        .map(|(i, &k)| cov[(i, i)].max(0.0).sqrt() * scale(free[k], p.prior))
        .collect()
}

/// The residuals and the Jacobian of `free` at `body` (`1 + free`
/// replays of every swim).
pub(super) fn jacobian_at(
    p: &Problem,
    body: &Body,
    free: &[Coefficient],
) -> Result<(Vec<f64>, DMatrix<f64>)> {
    let theta: Vec<f64> = free
        .iter()
        .map(|c| c.get(body) / scale(*c, p.prior))
        .collect();
    linearize(p, body, free, &theta)
}
