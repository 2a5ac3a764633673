//! Where the chip sits in the device: placements of one device turned about its centre, the
//! centre at one stated radius R, put the chip at different radii.
//!
//! With the chip at d from the centre (the device's axes), a placement whose `out` is o and whose
//! tangential axis is t = up × o puts it at r² = (R + d·o)² + (d·t)² = R² + |d|² + 2R d·o. A turn
//! of 180° (o → −o) gives d·o = (r₊² − r₋²)/(4R) with R the statement; a further turn of 90°
//! gives the other component, and then R² + |d|² and R·d determine R from the radii too. The
//! radii come with the joint fit's robust covariance across placements (they share the in-plane
//! scale, so their trade with it is in there); a turn made by hand is off by [`TURN_SD_DEG`],
//! which moves d·o by about ψ·(d·t), added per placement. The estimate is the weighted least
//! squares of the radii on (R, d) with the statement as R's prior (Gauss–Newton), its covariance
//! the inverse of the normal matrix.

use faer::Mat;
use serde::{Deserialize, Serialize};

use super::covariance::inverse_on;
use super::input::RunInput;
use super::placement::placement_leaders;
use super::result::JointFit;
use crate::campaign::file::SignedAxis;
use crate::turntable::fit::RadiusPrior;

/// How far a device turned by hand between placements is off the turn its `out` states
/// (standard deviation), deg: about a ruler's edge or a mark on the platter.
pub const TURN_SD_DEG: f64 = 2.0;

/// One placement the offset comes from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TurnedPlacement {
    pub label: String,
    /// Its `out` (the device's axis pointing away from the spindle).
    pub out: String,
    /// The chip's fitted radius in it, m.
    pub chip_radius_m: f64,
}

/// One component of the chip's offset from the device's centre.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OffsetComponent {
    /// The device's (sensor's) axis it is along, "+x", "+y" or "+z".
    pub axis: String,
    pub offset_m: f64,
    /// Its standard error (the radii's robust covariance, the centre's statement and the turns'
    /// precision propagated), m.
    pub se_m: f64,
}

/// The chip's place in the device (results.json `chip_offset`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChipOffset {
    /// The placements whose runs state the device's centre, turned about it.
    pub placements: Vec<TurnedPlacement>,
    /// The centre's radius as stated (the tightest statement).
    pub centre_stated: RadiusPrior,
    /// The centre's radius with what the radii add to the statement, m.
    pub centre_radius_m: Option<f64>,
    pub centre_radius_se_m: Option<f64>,
    /// The offset along the device's axes in the platter's plane, those the turns determine.
    pub components: Vec<OffsetComponent>,
    /// The correlation of the two components, when both are determined.
    pub correlation: Option<f64>,
    /// What the turns leave undetermined, and what would determine it.
    pub undetermined: Option<String>,
}

impl ChipOffset {
    /// One sentence for people.
    pub fn sentence(&self) -> String {
        let labels: Vec<&str> = self.placements.iter().map(|p| p.label.as_str()).collect();
        let mut text = if self.components.is_empty() {
            "The chip's place in the device is not determined".to_string()
        } else {
            let parts: Vec<String> = self
                .components
                .iter()
                .map(|c| {
                    format!(
                        "{:+.1} ± {:.1} mm along {}",
                        1e3 * c.offset_m,
                        1e3 * c.se_m,
                        c.axis
                    )
                })
                .collect();
            let centre = match (self.centre_radius_m, self.centre_radius_se_m) {
                (Some(r), Some(se)) => format!(" at {:.1} ± {:.1} mm", 1e3 * r, 1e3 * se),
                _ => String::new(),
            };
            format!(
                "The chip sits {} from the device's centre (placements {} turned about it{centre})",
                parts.join(" and "),
                labels.join(", ")
            )
        };
        if let Some(why) = &self.undetermined {
            text.push_str(&format!("; {why}"));
        }
        text.push('.');
        text
    }
}

/// Which parameters the turns determine.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Turns {
    /// Both in-plane components and R: θ = (R, d₀, d₁).
    Both,
    /// The component along plane axis k (turned 180°), R from the statement: θ = (R, d_k, w) with
    /// w the other component's square (a nuisance).
    Along(usize),
}

/// The chip's offset from the placements whose runs state the device's centre; `None` when no
/// run states it.
pub fn chip_offset(runs: &[RunInput], joint: &JointFit) -> Option<ChipOffset> {
    let leaders = placement_leaders(runs);
    let stating: Vec<usize> = (0..runs.len())
        .filter(|&i| runs[i].entry.centre.is_some())
        .collect();
    let statements: Vec<RadiusPrior> = stating.iter().filter_map(|&i| runs[i].entry.centre).collect();
    // One point's radius written on several runs is one measurement, not several.
    let stated = *statements
        .iter()
        .min_by(|a, b| a.tolerance_m.total_cmp(&b.tolerance_m))?;
    let mut members: Vec<usize> = Vec::new();
    for &i in &stating {
        if !members.contains(&leaders[i]) {
            members.push(leaders[i]);
        }
    }
    let label = |m: usize| {
        runs[m]
            .entry
            .placement
            .clone()
            .unwrap_or_else(|| runs[m].name.clone())
    };
    let mut found = ChipOffset {
        placements: members
            .iter()
            .map(|&m| TurnedPlacement {
                label: label(m),
                out: runs[m].entry.out.name(),
                chip_radius_m: joint.runs[m].params[0].value,
            })
            .collect(),
        centre_stated: stated,
        centre_radius_m: None,
        centre_radius_se_m: None,
        components: Vec::new(),
        correlation: None,
        undetermined: None,
    };
    let refuse = |found: ChipOffset, why: String| {
        Some(ChipOffset {
            undetermined: Some(why),
            ..found
        })
    };
    if let Some((a, b)) = statements.iter().enumerate().find_map(|(k, a)| {
        statements[k + 1..]
            .iter()
            .find(|b| (a.value_m - b.value_m).abs() > a.tolerance_m + b.tolerance_m)
            .map(|b| (a, b))
    }) {
        return refuse(found, format!(
            "the runs state the centre at {:.1} ± {:.1} and at {:.1} ± {:.1} mm, but a device turned about its centre keeps it at one radius",
            1e3 * a.value_m,
            1e3 * a.tolerance_m,
            1e3 * b.value_m,
            1e3 * b.tolerance_m
        ));
    }
    let up = runs[members[0]].entry.up;
    if let Some(&m) = members.iter().find(|&&m| runs[m].entry.up != up) {
        return refuse(
            found,
            format!(
                "placement {} has up = {} against {}'s {}: turns about the spindle keep one face up",
                label(m),
                runs[m].entry.up.name(),
                label(members[0]),
                up.name()
            ),
        );
    }
    let plane: [usize; 2] = match up.axis {
        0 => [1, 2],
        1 => [0, 2],
        _ => [0, 1],
    };
    let in_plane = |v: [f64; 3]| [v[plane[0]], v[plane[1]]];
    let outs: Vec<[f64; 2]> = members
        .iter()
        .map(|&m| in_plane(runs[m].entry.out.vector()))
        .collect();
    let tangents: Vec<[f64; 2]> = members
        .iter()
        .map(|&m| in_plane(cross(up.vector(), runs[m].entry.out.vector())))
        .collect();
    let faces = |k: usize, sign: f64| outs.iter().any(|o| o[k] == sign);
    let turned = |k: usize| faces(k, 1.0) && faces(k, -1.0);
    let along = |k: usize| faces(k, 1.0) || faces(k, -1.0);
    let axis_name = |k: usize| {
        SignedAxis {
            axis: plane[k],
            sign: 1,
        }
        .name()
    };
    let turns = if (turned(0) && along(1)) || (turned(1) && along(0)) {
        Turns::Both
    } else if let Some(k) = (0..2).find(|&k| turned(k)) {
        Turns::Along(k)
    } else {
        return refuse(
            found,
            format!(
                "it needs placements turned 180° from each other (`out` = +{0} and -{0}, or +{1} and -{1})",
                &axis_name(0)[1..],
                &axis_name(1)[1..]
            ),
        );
    };
    let radii: Vec<f64> = found.placements.iter().map(|p| p.chip_radius_m).collect();
    let Some(cov) = joint.radii_covariance(&members) else {
        return refuse(found, "the joint fit has no covariance of the chip radii".into());
    };
    let Some((theta, normal_inverse)) = solve(turns, &radii, &cov, &outs, &tangents, stated) else {
        return refuse(found, "the radii's weighted least squares is singular".into());
    };
    let se = |k: usize| normal_inverse[(k, k)].max(0.0).sqrt();
    found.centre_radius_m = Some(theta[0]);
    found.centre_radius_se_m = Some(se(0));
    let component = |k: usize, index: usize| OffsetComponent {
        axis: axis_name(k),
        offset_m: theta[index],
        se_m: se(index),
    };
    match turns {
        Turns::Both => {
            found.components = vec![component(0, 1), component(1, 2)];
            found.correlation = Some(normal_inverse[(1, 2)] / (se(1) * se(2)));
        }
        Turns::Along(k) => {
            found.components = vec![component(k, 1)];
            let other = &axis_name(1 - k)[1..];
            found.undetermined = Some(format!(
                "the offset along {other} needs a placement turned 90° from these (`out` = ±{other})"
            ));
        }
    }
    Some(found)
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// The squared radius of a placement with in-plane `out` o under θ, and its gradient.
fn squared_radius(turns: Turns, theta: [f64; 3], o: [f64; 2]) -> (f64, [f64; 3]) {
    let r = theta[0];
    match turns {
        Turns::Both => {
            let [d0, d1] = [theta[1], theta[2]];
            let along = d0 * o[0] + d1 * o[1];
            (
                r * r + d0 * d0 + d1 * d1 + 2.0 * r * along,
                [2.0 * (r + along), 2.0 * (d0 + r * o[0]), 2.0 * (d1 + r * o[1])],
            )
        }
        Turns::Along(k) => {
            let (d, w) = (theta[1], theta[2]);
            (
                r * r + d * d + w + 2.0 * r * d * o[k],
                [2.0 * (r + d * o[k]), 2.0 * (d + r * o[k]), 1.0],
            )
        }
    }
}

/// Gauss–Newton on the radii, weighted by their covariance plus the turns' spread (taken at the
/// previous pass's offset), with the centre's statement as a prior on R. θ and the inverse of
/// the normal matrix (θ's covariance); `None` when singular or not finite.
fn solve(
    turns: Turns,
    radii: &[f64],
    cov: &[Vec<f64>],
    outs: &[[f64; 2]],
    tangents: &[[f64; 2]],
    stated: RadiusPrior,
) -> Option<([f64; 3], Mat<f64>)> {
    let n = radii.len();
    let turn_sd = TURN_SD_DEG.to_radians();
    let prior = stated.tolerance_m.powi(-2);
    let mut theta = [stated.value_m, 0.0, 0.0];
    let mut result = None;
    // Pass 0 without the turns' spread, pass 1 with it at pass 0's offset.
    for pass in 0..2 {
        let spread: Vec<f64> = (0..n)
            .map(|p| {
                if pass == 0 {
                    return 0.0;
                }
                let across = match turns {
                    Turns::Both => theta[1] * tangents[p][0] + theta[2] * tangents[p][1],
                    Turns::Along(_) => theta[2].max(0.0).sqrt(),
                };
                (theta[0] * turn_sd * across / radii[p]).powi(2)
            })
            .collect();
        let s = Mat::from_fn(n, n, |a, b| cov[a][b] + if a == b { spread[a] } else { 0.0 });
        let index: Vec<usize> = (0..n).collect();
        let weight = inverse_on(&s, &index)?;
        for _ in 0..50 {
            let mut jacobian = Mat::<f64>::zeros(n, 3);
            let mut residual = vec![0.0; n];
            for p in 0..n {
                let (q, grad) = squared_radius(turns, theta, outs[p]);
                let f = q.max(0.0).sqrt();
                residual[p] = radii[p] - f;
                for k in 0..3 {
                    jacobian[(p, k)] = grad[k] / (2.0 * f);
                }
            }
            let wj = &weight * &jacobian;
            let mut normal = jacobian.transpose() * &wj;
            normal[(0, 0)] += prior;
            let mut gradient = [0.0; 3];
            for k in 0..3 {
                gradient[k] = (0..n).map(|p| wj[(p, k)] * residual[p]).sum();
            }
            gradient[0] += prior * (stated.value_m - theta[0]);
            let inverse = inverse_on(&normal, &[0, 1, 2])?;
            let step: [f64; 3] = std::array::from_fn(|a| (0..3).map(|b| inverse[(a, b)] * gradient[b]).sum());
            for k in 0..3 {
                theta[k] += step[k];
            }
            if !theta.iter().all(|t| t.is_finite()) {
                return None;
            }
            result = Some(inverse);
            // Steps below a nanometre (and, for w, a square nanometre-metre) are converged.
            if step.iter().all(|s| s.abs() < 1e-9) {
                break;
            }
        }
    }
    result.map(|inverse| (theta, inverse))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Exact radii of a chip at d from a centre at R, under `outs`, recovered to rounding.
    #[test]
    fn exact_radii_give_the_offset_back() {
        let (r, d) = (0.1, [0.02, -0.015]);
        let outs = [[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0]];
        // up = +z: t = z × o.
        let tangents: Vec<[f64; 2]> = outs.iter().map(|o| [-o[1], o[0]]).collect();
        let radii: Vec<f64> = outs
            .iter()
            .map(|o| {
                let along = d[0] * o[0] + d[1] * o[1];
                let across = d[0] * -o[1] + d[1] * o[0];
                (r + along).hypot(across)
            })
            .collect();
        let cov: Vec<Vec<f64>> = (0..3)
            .map(|a| (0..3).map(|b| if a == b { 1e-8 } else { 0.0 }).collect())
            .collect();
        let stated = RadiusPrior {
            value_m: 0.11,
            tolerance_m: 0.01,
        };
        let (theta, _) = solve(Turns::Both, &radii, &cov, &outs, &tangents, stated).unwrap();
        // Exact radii and a statement 10 mm off: the data pull R back to within the prior's pull.
        assert!((theta[1] - d[0]).abs() < 1e-4, "{theta:?}");
        assert!((theta[2] - d[1]).abs() < 1e-4, "{theta:?}");
        assert!((theta[0] - r).abs() < 1e-4, "{theta:?}");
        // 180° only, the statement exact: the component along the turn is (r₊² − r₋²)/(4R).
        let stated = RadiusPrior {
            value_m: r,
            tolerance_m: 1e-6,
        };
        let (theta, _) = solve(
            Turns::Along(0),
            &radii[..2],
            &[cov[0][..2].to_vec(), cov[1][..2].to_vec()],
            &outs[..2],
            &tangents[..2],
            stated,
        )
        .unwrap();
        let formula = (radii[0].powi(2) - radii[1].powi(2)) / (4.0 * r);
        assert!(
            (theta[1] - formula).abs() < 1e-9 && (formula - d[0]).abs() < 1e-12,
            "{theta:?}"
        );
        assert!((theta[2] - d[1] * d[1]).abs() < 1e-9, "{theta:?}");
    }
}
