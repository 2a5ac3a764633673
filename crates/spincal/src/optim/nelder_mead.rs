//! Bounded Nelder–Mead: MATLAB fminsearch's simplex (Lagarias et al. 1998 coefficients and initial
//! simplex) run on unconstrained variables that fminsearchbnd's transform maps into the box:
//! both bounds x = lo + (hi − lo)(sin z + 1)/2, one bound x = lo + z² or hi − z², equal bounds fixed.

use crate::progress::{Observer, Progress};

/// Per-parameter box; `f64::NEG_INFINITY` / `f64::INFINITY` for a missing side.
#[derive(Debug, Clone)]
pub struct Bounds {
    pub names: Vec<String>,
    pub lower: Vec<f64>,
    pub upper: Vec<f64>,
}

/// Bounds that cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum BoundsError {
    #[error("bounds for {name} contradict each other: lower {lower} > upper {upper}")]
    Inverted { name: String, lower: f64, upper: f64 },
    #[error("bound for {name} is NaN")]
    NotANumber { name: String },
    #[error("{expected} bounds expected, {found} given")]
    Length { expected: usize, found: usize },
}

impl Bounds {
    /// Checks every pair once; the error names the parameter.
    pub fn validate(&self) -> Result<(), BoundsError> {
        let n = self.names.len();
        for found in [self.lower.len(), self.upper.len()] {
            if found != n {
                return Err(BoundsError::Length { expected: n, found });
            }
        }
        for i in 0..n {
            let (lower, upper) = (self.lower[i], self.upper[i]);
            if lower.is_nan() || upper.is_nan() {
                return Err(BoundsError::NotANumber {
                    name: self.names[i].clone(),
                });
            }
            if lower > upper {
                return Err(BoundsError::Inverted {
                    name: self.names[i].clone(),
                    lower,
                    upper,
                });
            }
        }
        Ok(())
    }

    /// Whether `x[i]` lies on (within a relative 1e-6 of the width of) a finite bound.
    pub fn at_bound(&self, i: usize, x: f64) -> bool {
        let (lo, hi) = (self.lower[i], self.upper[i]);
        let tol = if lo.is_finite() && hi.is_finite() {
            1e-6 * (hi - lo)
        } else {
            1e-9 * x.abs().max(1e-12)
        };
        (lo.is_finite() && x - lo <= tol) || (hi.is_finite() && hi - x <= tol)
    }
}

/// Settings (defaults are fminsearch's, with the iteration limits scaled by the free dimension).
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct NelderMeadOptions {
    /// Stop when the simplex spans at most this in every transformed coordinate…
    pub tol_x: f64,
    /// …and the objective values across it differ by at most this.
    pub tol_f: f64,
    /// Iteration limit per free parameter.
    pub max_iterations_per_param: usize,
}

impl Default for NelderMeadOptions {
    fn default() -> Self {
        NelderMeadOptions {
            tol_x: 1e-4,
            tol_f: 1e-4,
            max_iterations_per_param: 200,
        }
    }
}

#[derive(Debug, Clone)]
pub struct NelderMeadReport {
    pub params: Vec<f64>,
    pub cost: f64,
    pub iterations: usize,
    pub evaluations: usize,
    pub converged: bool,
}

enum Transform {
    Free,
    Lower(f64),
    Upper(f64),
    Both(f64, f64),
    Fixed(f64),
}

impl Transform {
    fn to_x(&self, z: f64) -> f64 {
        match *self {
            Transform::Free => z,
            Transform::Lower(lo) => lo + z * z,
            Transform::Upper(hi) => hi - z * z,
            Transform::Both(lo, hi) => (lo + (hi - lo) * (z.sin() + 1.0) / 2.0).clamp(lo, hi),
            Transform::Fixed(v) => v,
        }
    }

    fn to_z(&self, x: f64) -> f64 {
        match *self {
            Transform::Free => x,
            Transform::Lower(lo) => (x - lo).max(0.0).sqrt(),
            Transform::Upper(hi) => (hi - x).max(0.0).sqrt(),
            // fminsearchbnd shifts by 2π so a start on a bound does not sit on z = 0.
            Transform::Both(lo, hi) => {
                let s = (2.0 * (x - lo) / (hi - lo) - 1.0).clamp(-1.0, 1.0);
                2.0 * std::f64::consts::PI + s.asin()
            }
            Transform::Fixed(_) => 0.0,
        }
    }
}

/// Minimises `cost` over the box from `x0` (clipped into the box first).
pub fn nelder_mead_bounded(
    cost: &mut dyn FnMut(&[f64]) -> f64,
    x0: &[f64],
    bounds: &Bounds,
    options: &NelderMeadOptions,
    observer: &Observer,
) -> Result<NelderMeadReport, BoundsError> {
    bounds.validate()?;
    if x0.len() != bounds.names.len() {
        return Err(BoundsError::Length {
            expected: bounds.names.len(),
            found: x0.len(),
        });
    }
    let transforms: Vec<Transform> = (0..x0.len())
        .map(|i| {
            let (lo, hi) = (bounds.lower[i], bounds.upper[i]);
            match (lo.is_finite(), hi.is_finite()) {
                (true, true) if lo == hi => Transform::Fixed(lo),
                (true, true) => Transform::Both(lo, hi),
                (true, false) => Transform::Lower(lo),
                (false, true) => Transform::Upper(hi),
                (false, false) => Transform::Free,
            }
        })
        .collect();
    let free: Vec<usize> = (0..x0.len())
        .filter(|&i| !matches!(transforms[i], Transform::Fixed(_)))
        .collect();
    let to_x = |z: &[f64]| -> Vec<f64> {
        let mut x: Vec<f64> = transforms.iter().map(|t| t.to_x(0.0)).collect();
        for (k, &i) in free.iter().enumerate() {
            x[i] = transforms[i].to_x(z[k]);
        }
        x
    };
    let z0: Vec<f64> = free
        .iter()
        .map(|&i| transforms[i].to_z(x0[i].clamp(bounds.lower[i], bounds.upper[i])))
        .collect();
    let mut evaluations = 0;
    let mut f = |z: &[f64]| {
        evaluations += 1;
        let v = cost(&to_x(z));
        if v.is_nan() {
            f64::INFINITY
        } else {
            v
        }
    };
    let (z, value, iterations, converged) = simplex(&mut f, &z0, options, observer);
    Ok(NelderMeadReport {
        params: to_x(&z),
        cost: value,
        iterations,
        evaluations,
        converged,
    })
}

/// fminsearch's unconstrained simplex on `f`.
fn simplex(
    f: &mut dyn FnMut(&[f64]) -> f64,
    z0: &[f64],
    options: &NelderMeadOptions,
    observer: &Observer,
) -> (Vec<f64>, f64, usize, bool) {
    let n = z0.len();
    if n == 0 {
        return (Vec::new(), f(z0), 0, true);
    }
    let mut simplex = Simplex::around(f, z0);
    let max_iterations = options.max_iterations_per_param * n;
    let mut iterations = 0;
    let mut converged = false;
    loop {
        if simplex.sort_and_check(options) {
            converged = true;
            break;
        }
        if iterations >= max_iterations {
            break;
        }
        iterations += 1;
        simplex.iterate(f);
        observer(Progress {
            stage: "Nelder–Mead",
            done: iterations,
            total: Some(max_iterations),
            cost: Some(simplex.values.iter().copied().fold(f64::INFINITY, f64::min)),
        });
    }
    let Simplex {
        points,
        values,
        mut order,
    } = simplex;
    order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
    (points[order[0]].clone(), values[order[0]], iterations, converged)
}

/// The simplex's n + 1 points, their costs, and their order from best to worst (as of the last
/// sort).
struct Simplex {
    points: Vec<Vec<f64>>,
    values: Vec<f64>,
    order: Vec<usize>,
}

impl Simplex {
    /// `z0` and, per coordinate, `z0` with that coordinate moved by 5 % (0.00025 from zero).
    fn around(f: &mut dyn FnMut(&[f64]) -> f64, z0: &[f64]) -> Simplex {
        let n = z0.len();
        let mut points: Vec<Vec<f64>> = vec![z0.to_vec()];
        for k in 0..n {
            let mut p = z0.to_vec();
            p[k] = if p[k] != 0.0 { 1.05 * p[k] } else { 0.00025 };
            points.push(p);
        }
        let values: Vec<f64> = points.iter().map(|p| f(p)).collect();
        Simplex {
            points,
            values,
            order: (0..=n).collect(),
        }
    }

    /// Sorts the points by cost; whether every other point lies within the tolerances of the
    /// best, in cost and in each coordinate.
    fn sort_and_check(&mut self, options: &NelderMeadOptions) -> bool {
        let (points, values, order) = (&self.points, &self.values, &mut self.order);
        order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
        let best = order[0];
        let spread_f = order[1..]
            .iter()
            .map(|&i| (values[i] - values[best]).abs())
            .fold(0.0, f64::max);
        let spread_x = order[1..]
            .iter()
            .flat_map(|&i| points[i].iter().zip(&points[best]).map(|(a, b)| (a - b).abs()))
            .fold(0.0, f64::max);
        spread_f <= options.tol_f && spread_x <= options.tol_x
    }

    /// One iteration on the sorted simplex: the worst point reflected through the others'
    /// centroid, expanded or contracted; when none of those improves it, a shrink towards the
    /// best.
    fn iterate(&mut self, f: &mut dyn FnMut(&[f64]) -> f64) {
        let (rho, chi, gamma) = (1.0, 2.0, 0.5);
        let (points, values, order) = (&mut self.points, &mut self.values, &self.order);
        let n = order.len() - 1;
        let best = order[0];
        let worst = order[n];
        let second_worst = order[n - 1];
        let mut centroid = vec![0.0; n];
        for &i in &order[..n] {
            for k in 0..n {
                centroid[k] += points[i][k] / n as f64;
            }
        }
        let along = |t: f64| -> Vec<f64> {
            (0..n)
                .map(|k| centroid[k] + t * (centroid[k] - points[worst][k]))
                .collect()
        };
        let reflected = along(rho);
        let f_reflected = f(&reflected);
        let mut shrink = false;
        if f_reflected < values[best] {
            let expanded = along(rho * chi);
            let f_expanded = f(&expanded);
            if f_expanded < f_reflected {
                points[worst] = expanded;
                values[worst] = f_expanded;
            } else {
                points[worst] = reflected;
                values[worst] = f_reflected;
            }
        } else if f_reflected < values[second_worst] {
            points[worst] = reflected;
            values[worst] = f_reflected;
        } else if f_reflected < values[worst] {
            let outside = along(rho * gamma);
            let f_outside = f(&outside);
            if f_outside <= f_reflected {
                points[worst] = outside;
                values[worst] = f_outside;
            } else {
                shrink = true;
            }
        } else {
            let inside = along(-gamma);
            let f_inside = f(&inside);
            if f_inside < values[worst] {
                points[worst] = inside;
                values[worst] = f_inside;
            } else {
                shrink = true;
            }
        }
        if shrink {
            self.shrink(f);
        }
    }

    /// Every point but the best moved halfway towards it, and costed again.
    fn shrink(&mut self, f: &mut dyn FnMut(&[f64]) -> f64) {
        let sigma = 0.5;
        let n = self.order.len() - 1;
        let anchor = self.points[self.order[0]].clone();
        for &i in &self.order[1..] {
            for k in 0..n {
                self.points[i][k] = anchor[k] + sigma * (self.points[i][k] - anchor[k]);
            }
            self.values[i] = f(&self.points[i]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bounds(lower: Vec<f64>, upper: Vec<f64>) -> Bounds {
        Bounds {
            names: (0..lower.len()).map(|i| format!("p{i}")).collect(),
            lower,
            upper,
        }
    }

    #[test]
    fn finds_rosenbrock_minimum_like_fminsearch() {
        // fminsearch reaches (1, 1) from (−1.2, 1) with the default tolerances.
        let mut cost = |x: &[f64]| 100.0 * (x[1] - x[0] * x[0]).powi(2) + (1.0 - x[0]).powi(2);
        let inf = f64::INFINITY;
        let b = bounds(vec![-inf, -inf], vec![inf, inf]);
        let r = nelder_mead_bounded(
            &mut cost,
            &[-1.2, 1.0],
            &b,
            &NelderMeadOptions::default(),
            &crate::progress::silent,
        )
        .unwrap();
        assert!(
            (r.params[0] - 1.0).abs() < 1e-3 && (r.params[1] - 1.0).abs() < 1e-3,
            "{r:?}"
        );
        assert!(r.converged);
    }

    #[test]
    fn stays_in_the_box_and_finds_the_constrained_minimum() {
        let cost = |x: &[f64]| (x[0] - 3.0).powi(2) + (x[1] + 1.0).powi(2) + (x[2] - 0.5).powi(2);
        let b = bounds(vec![0.0, 0.0, 0.5], vec![2.0, f64::INFINITY, 0.5]);
        let mut inside = true;
        let mut wrapped = |x: &[f64]| {
            inside &= x[0] >= 0.0 && x[0] <= 2.0 && x[1] >= 0.0 && x[2] == 0.5;
            cost(x)
        };
        let options = NelderMeadOptions {
            tol_x: 1e-10,
            tol_f: 1e-12,
            ..Default::default()
        };
        let r = nelder_mead_bounded(
            &mut wrapped,
            &[1.0, 1.0, 0.5],
            &b,
            &options,
            &crate::progress::silent,
        )
        .unwrap();
        assert!(inside);
        assert!((r.params[0] - 2.0).abs() < 1e-6, "{r:?}");
        assert!(r.params[1].abs() < 1e-3, "{r:?}");
        assert!(b.at_bound(0, r.params[0]));
    }

    #[test]
    fn contradicting_bounds_are_refused_by_name() {
        let b = Bounds {
            names: vec!["radius_m".into()],
            lower: vec![0.2],
            upper: vec![0.1],
        };
        let e = nelder_mead_bounded(
            &mut |x| x[0],
            &[0.15],
            &b,
            &NelderMeadOptions::default(),
            &crate::progress::silent,
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "bounds for radius_m contradict each other: lower 0.2 > upper 0.1"
        );
    }
}
