//! The robust (block-HAC sandwich) covariance and its parts the results expose.

use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::prelude::Solve;
use faer::{Mat, Par, Side};

use super::layout::run_offset;
use super::result::JointFit;
use crate::correctors::physical::SensorCovariance;
use crate::correctors::physical::SENSOR_PARAMS;

impl JointFit {
    /// The robust covariance of the sensor parameters (`SensorModel::params` order), zero for
    /// those held fixed; `None` when the fit had no covariance.
    pub fn sensor_covariance(&self) -> Option<SensorCovariance> {
        let cov = self.state.covariance.as_ref()?;
        let pos: Vec<Option<usize>> = (0..SENSOR_PARAMS)
            .map(|k| self.state.free_index.iter().position(|&i| i == k))
            .collect();
        Some(std::array::from_fn(|a| {
            std::array::from_fn(|b| match (pos[a], pos[b]) {
                (Some(a), Some(b)) => cov[(a, b)],
                _ => 0.0,
            })
        }))
    }

    /// The robust covariance of run `i`'s parameters `params` (indices into the run's own), zero
    /// for parameters held fixed; `None` when the fit had no covariance.
    pub fn run_covariance(&self, i: usize, params: &[usize]) -> Option<Vec<Vec<f64>>> {
        let cov = self.state.covariance.as_ref()?;
        let o = run_offset(i);
        let pos: Vec<Option<usize>> = params
            .iter()
            .map(|&p| self.state.free_index.iter().position(|&k| k == o + p))
            .collect();
        Some(
            pos.iter()
                .map(|a| {
                    pos.iter()
                        .map(|b| match (a, b) {
                            (Some(a), Some(b)) => cov[(*a, *b)],
                            _ => 0.0,
                        })
                        .collect()
                })
                .collect(),
        )
    }
}

impl JointFit {
    /// The robust covariance of the chip radii (each run's first parameter) of `runs`, across
    /// runs: radii that share a sensor's in-plane scale carry its trade in their covariance.
    /// `None` when the fit had no covariance or a radius was not free.
    pub(crate) fn radii_covariance(&self, runs: &[usize]) -> Option<Vec<Vec<f64>>> {
        let cov = self.state.covariance.as_ref()?;
        let pos: Vec<usize> = runs
            .iter()
            .map(|&i| self.state.free_index.iter().position(|&k| k == run_offset(i)))
            .collect::<Option<_>>()?;
        Some(
            pos.iter()
                .map(|&a| pos.iter().map(|&b| cov[(a, b)]).collect())
                .collect(),
        )
    }
}

/// How a parameter's robust variance is held at least at the model's own (see [`sandwich`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Floor {
    /// Kept as the sandwich gives it.
    None,
    /// Its variance raised by scaling its row and column.
    Variance,
    /// Every direction of the block of parameters so marked.
    EveryDirection,
}

/// H⁻¹ S H⁻¹ over the given parameters (`inverse`: H⁻¹ from [`free_inverse`]), held at least at
/// the model's own covariance `model` (the residuals weighted by their measured noise, priors at
/// their stated spreads; H⁻¹ where each prior's spread is its penalty's width) as `floor` says of
/// each: a run's parameters each on its variance (row and column scaled), the sensor's in every
/// direction (in the frame where their block of `model` is the identity, each eigenvalue of the
/// sandwich's block below one set to one). `None` where `model` is not positive definite there.
///
/// The sandwich guards against what the weights miss (coloured residuals, scatter between
/// poses), but it is an estimate from the blocks' scores: a run of six blocks gives about five
/// degrees of freedom, and a campaign of a few more one-file poses than the sensor's terms
/// hardly more. On a phone's 30 s runs it put a rate's standard error at half the white-noise
/// (Cramér–Rao) bound; at 16 one-file poses the q terms' standard errors scattered from a
/// quarter to twice the true one between noise draws of one design. White noise is the least a
/// recording carries; with few clusters the larger of the robust and the conventional variance
/// is the usual remedy. For the sensor a floor on the diagonal alone is not enough: it keeps the
/// sandwich's near-singular directions, along which held-out predictions then lie. A run's
/// parameters keep the diagonal floor: the gyro's terms come from its rates alone, and the full
/// floor there moved a scale across the terms rule's threshold. The poses' angles and the
/// sessions' offsets, which no correction carries, keep the sandwich (a full floor over them cost
/// an eigendecomposition of hundreds of parameters per fit on one-file campaigns).
pub(super) fn sandwich(
    inverse: &Mat<f64>,
    s: &Mat<f64>,
    model: &Mat<f64>,
    index: &[usize],
    floor: impl Fn(usize) -> Floor,
) -> Option<Mat<f64>> {
    let n = index.len();
    let ss = Mat::from_fn(n, n, |a, b| s[(index[a], index[b])]);
    let h_inv = Mat::from_fn(n, n, |a, b| inverse[(index[a], index[b])]);
    let robust = &h_inv * &ss * &h_inv;
    let model = Mat::from_fn(n, n, |a, b| model[(index[a], index[b])]);
    let raise: Vec<f64> = (0..n)
        .map(|a| {
            let ratio = model[(a, a)] / robust[(a, a)];
            if floor(index[a]) == Floor::Variance && ratio > 1.0 && ratio.is_finite() {
                ratio.sqrt()
            } else {
                1.0
            }
        })
        .collect();
    let mut covariance = Mat::from_fn(n, n, |a, b| raise[a] * robust[(a, b)] * raise[b]);
    let block: Vec<usize> = (0..n)
        .filter(|&a| floor(index[a]) == Floor::EveryDirection)
        .collect();
    let sub = |m: &Mat<f64>| Mat::from_fn(block.len(), block.len(), |a, b| m[(block[a], block[b])]);
    let shortfall = loewner_shortfall(&sub(&robust), &sub(&model))?;
    for (a, &i) in block.iter().enumerate() {
        for (b, &j) in block.iter().enumerate() {
            covariance[(i, j)] += shortfall[(a, b)];
        }
    }
    Some(covariance)
}

/// What `robust` lacks of `model` in every direction: F U max(1 − Λ, 0) Uᵀ Fᵀ, with F Fᵀ = model
/// and U Λ Uᵀ = F⁻¹ robust F⁻ᵀ (positive semi-definite; added to `robust`, a covariance at least
/// both). `None` where `model` is not positive definite.
fn loewner_shortfall(robust: &Mat<f64>, model: &Mat<f64>) -> Option<Mat<f64>> {
    let n = model.nrows();
    // F = D L with D the diagonal's square root, for a well-conditioned factor.
    let d: Vec<f64> = (0..n)
        .map(|a| model[(a, a)].max(f64::MIN_POSITIVE).sqrt())
        .collect();
    let scaled = Mat::from_fn(n, n, |a, b| model[(a, b)] / (d[a] * d[b]));
    let llt = scaled.llt(Side::Lower).ok()?;
    let factor = Mat::from_fn(n, n, |a, b| d[a] * llt.L()[(a, b)]);
    let solve = |mut m: Mat<f64>| {
        solve_lower_triangular_in_place(factor.as_ref(), m.as_mut(), Par::Seq);
        m
    };
    let whitened = solve(solve(robust.clone()).transpose().to_owned());
    let whitened = Mat::from_fn(n, n, |a, b| 0.5 * (whitened[(a, b)] + whitened[(b, a)]));
    let eigen = whitened.self_adjoint_eigen(Side::Lower).ok()?;
    let (u, lambda) = (eigen.U(), eigen.S());
    let lacking = Mat::from_fn(n, n, |a, b| {
        (0..n)
            .map(|k| u[(a, k)] * (1.0 - lambda[k]).max(0.0) * u[(b, k)])
            .sum::<f64>()
    });
    Some(&factor * lacking * factor.transpose())
}

/// The inverse of the symmetric positive definite `h` restricted to `index` (rows and columns);
/// `None` when it is singular.
pub(super) fn inverse_on(h: &Mat<f64>, index: &[usize]) -> Option<Mat<f64>> {
    let n = index.len();
    let hs = Mat::from_fn(n, n, |a, b| h[(index[a], index[b])]);
    // Scale to unit diagonal for a well-conditioned factorisation.
    let d: Vec<f64> = (0..n).map(|a| hs[(a, a)].max(f64::MIN_POSITIVE).sqrt()).collect();
    let scaled = Mat::from_fn(n, n, |a, b| hs[(a, b)] / (d[a] * d[b]));
    let llt = scaled.llt(Side::Lower).ok()?;
    let inv = llt.solve(Mat::<f64>::identity(n, n));
    Some(Mat::from_fn(n, n, |a, b| inv[(a, b)] / (d[a] * d[b])))
}

/// A block's score s made the block jackknife's (CR3): (I − A P)⁻¹ s, with A the block's JᵀJ
/// and P the inverse normal matrix, both over the parameters the block touches. P times it is
/// exactly what leaving the block out moves the (linearised) fit by: a score the fit partly
/// absorbed, because the block's own parameters were fitted to it, is restored. `None` where
/// the block alone determines a direction.
pub(super) fn jackknife_score(a: &Mat<f64>, p: &Mat<f64>, score: &[f64]) -> Option<Vec<f64>> {
    let k = score.len();
    let kept = Mat::<f64>::identity(k, k) - a * p;
    let s = Mat::from_fn(k, 1, |r, _| score[r]);
    let corrected = kept.partial_piv_lu().solve(&s);
    let corrected: Vec<f64> = (0..k).map(|r| corrected[(r, 0)]).collect();
    corrected.iter().all(|v| v.is_finite()).then_some(corrected)
}

/// The inverse of `h` over the free parameters `index`, scattered into an n × n matrix with zeros
/// where a parameter is fixed; `None` when it is singular there.
pub(super) fn free_inverse(h: &Mat<f64>, index: &[usize]) -> Option<Mat<f64>> {
    let inverse = inverse_on(h, index)?;
    let mut full = Mat::<f64>::zeros(h.nrows(), h.ncols());
    for (a, &i) in index.iter().enumerate() {
        for (b, &j) in index.iter().enumerate() {
            full[(i, j)] = inverse[(a, b)];
        }
    }
    Some(full)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The floored covariance is at least the robust one and the model's in every direction (both
    /// differences positive semi-definite), equals the robust one where that already exceeds the
    /// model's, and raises a direction the robust one nearly lacks to the model's there.
    #[test]
    fn the_floor_holds_every_direction_at_the_models_variance() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let n = 5;
        let random_spd = |rng: &mut ChaCha8Rng, rank: usize| {
            let a = Mat::from_fn(n, rank, |_, _| rng.gen_range(-1.0..1.0));
            &a * a.transpose() + Mat::<f64>::identity(n, n) * 1e-9
        };
        let min_eigen = |m: &Mat<f64>| {
            let sym = Mat::from_fn(n, n, |a, b| 0.5 * (m[(a, b)] + m[(b, a)]));
            let values = sym.self_adjoint_eigenvalues(Side::Lower).unwrap();
            values.iter().copied().fold(f64::INFINITY, f64::min)
        };
        for _ in 0..20 {
            let model = random_spd(&mut rng, n);
            // A sandwich from too few blocks: rank 2 of 5.
            let robust = random_spd(&mut rng, 2);
            let floored = &robust + loewner_shortfall(&robust, &model).unwrap();
            assert!(min_eigen(&(&floored - &robust)) > -1e-9);
            assert!(min_eigen(&(&floored - &model)) > -1e-9);
            // Already above the model everywhere: unchanged.
            let above = &model * 2.0;
            let same = &above + loewner_shortfall(&above, &model).unwrap();
            for a in 0..n {
                for b in 0..n {
                    assert!((same[(a, b)] - above[(a, b)]).abs() < 1e-9 * (1.0 + above[(a, b)].abs()));
                }
            }
        }
    }

    /// On a linear least-squares fit, P times the corrected score of a block equals the change
    /// in the fit when that block is left out, computed by refitting without it.
    #[test]
    fn the_jackknife_score_is_what_leaving_the_block_out_moves() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let (n, rows, blocks) = (4, 40, 5);
        let x = Mat::from_fn(rows, n, |_, _| rng.gen_range(-1.0..1.0));
        let y: Vec<f64> = (0..rows).map(|_| rng.gen_range(-1.0..1.0)).collect();
        let fit = |keep: &dyn Fn(usize) -> bool| -> (Mat<f64>, Vec<f64>) {
            let mut h = Mat::<f64>::zeros(n, n);
            let mut g = Mat::<f64>::zeros(n, 1);
            for r in (0..rows).filter(|&r| keep(r)) {
                for a in 0..n {
                    g[(a, 0)] += x[(r, a)] * y[r];
                    for b in 0..n {
                        h[(a, b)] += x[(r, a)] * x[(r, b)];
                    }
                }
            }
            let theta = h.partial_piv_lu().solve(&g);
            (h, (0..n).map(|a| theta[(a, 0)]).collect())
        };
        let (h, theta) = fit(&|_| true);
        let p = inverse_on(&h, &[0, 1, 2, 3]).unwrap();
        let block_of = |r: usize| r * blocks / rows;
        for b in 0..blocks {
            let mut a = Mat::<f64>::zeros(n, n);
            let mut score = vec![0.0; n];
            for r in (0..rows).filter(|&r| block_of(r) == b) {
                let residual = y[r] - (0..n).map(|c| x[(r, c)] * theta[c]).sum::<f64>();
                for i in 0..n {
                    score[i] += x[(r, i)] * residual;
                    for j in 0..n {
                        a[(i, j)] += x[(r, i)] * x[(r, j)];
                    }
                }
            }
            let corrected = jackknife_score(&a, &p, &score).unwrap();
            let (_, without) = fit(&|r| block_of(r) != b);
            for i in 0..n {
                let moved: f64 = (0..n).map(|j| p[(i, j)] * corrected[j]).sum();
                let refit = theta[i] - without[i];
                assert!(
                    (moved - refit).abs() < 1e-10 * (1.0 + refit.abs()),
                    "block {b}, parameter {i}: {moved} vs {refit}"
                );
            }
        }
    }
}
