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
    pub simulations: usize,
    pub iterations: usize,
}

/// Forward-difference step in scaled units.
const FD_STEP: f64 = 1e-3;

fn scale(c: Coefficient, prior: &Body) -> f64 {
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
        let mut improved = false;
        for _ in 0..12 {
            let mut damped = a.clone();
            for i in 0..m {
                damped[(i, i)] += lambda * a[(i, i)].max(1e-12);
            }
            let Some(delta) = damped.lu().solve(&(-&g)) else {
                lambda *= 10.0;
                continue;
            };
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
                let step: f64 = delta.iter().map(|d| d.abs()).fold(0.0, f64::max);
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
        simulations,
        iterations,
    })
}

/// Lag-1 autocorrelation of a series.
fn lag1(v: &[f64]) -> f64 {
    if v.len() < 3 {
        return 0.0;
    }
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    let (mut num, mut den) = (0.0, 0.0);
    for (i, x) in v.iter().enumerate() {
        den += (x - mean) * (x - mean);
        if i > 0 {
            num += (x - mean) * (v[i - 1] - mean);
        }
    }
    if den > 0.0 { num / den } else { 0.0 }
}

/// Standard errors (coefficient units) and strongest correlations, by the
/// sandwich estimator: each group's residual variance, inflated by its
/// lag-1 autocorrelation `(1 + ρ) / (1 − ρ)` (neighbouring samples of a
/// swim are not independent measurements).
fn uncertainty(
    p: &Problem,
    free: &[Coefficient],
    r: &[f64],
    jac: &DMatrix<f64>,
) -> (Vec<f64>, Vec<Option<(Coefficient, f64)>>) {
    let m = free.len();
    let none = (vec![f64::INFINITY; m], vec![None; m]);
    let a = jac.transpose() * jac;
    let Some(ainv) = a.clone().try_inverse() else {
        return none;
    };
    let mut meat = DMatrix::zeros(m, m);
    let mut start = 0;
    for &count in &p.measured.counts {
        let end = (start + count).min(r.len());
        let g = &r[start..end];
        if !g.is_empty() {
            let n = g.len() as f64;
            let rho = lag1(g).clamp(0.0, 0.999);
            let var = g.iter().map(|x| x * x).sum::<f64>() / n * (1.0 + rho) / (1.0 - rho);
            let jg = jac.rows(start, end - start);
            meat += jg.transpose() * jg * var;
        }
        start = end;
    }
    let dof = (r.len() as f64 / (r.len() as f64 - m as f64).max(1.0)).max(1.0);
    let cov = &ainv * meat * &ainv * dof;
    let se: Vec<f64> = (0..m)
        .map(|i| cov[(i, i)].max(0.0).sqrt() * scale(free[i], p.prior))
        .collect();
    let corr = (0..m)
        .map(|i| {
            (0..m)
                .filter(|&j| j != i)
                .map(|j| {
                    let c = cov[(i, j)] / (cov[(i, i)] * cov[(j, j)]).sqrt();
                    (free[j], c)
                })
                .filter(|(_, c)| c.is_finite())
                .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
        })
        .collect();
    (se, corr)
}
