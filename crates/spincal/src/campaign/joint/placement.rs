//! Where the chip sat on the platter: runs made without moving the device (one `placement`)
//! share one radius, fitted from the runs; a stated radius is a prior, and one the runs
//! contradict is named.
//!
//! Two speeds of one placement separate the chip's radius from the bias across the spindle (the
//! centripetal term grows with ω², the bias does not), and the still poses give the in-plane
//! scale that multiplies it; the radius's standard error is the joint fit's marginal one, so it
//! carries its trade with that scale and with the bias.

use serde::{Deserialize, Serialize};

use super::input::RunInput;
use super::result::JointFit;
use crate::turntable::fit::RadiusPrior;

/// The radii of one placement's runs are tied within this, m: one radius, up to rounding.
pub(super) const PLACEMENT_TIE_M: f64 = 1e-5;

/// Two speeds differ by at least this share of the faster to separate radius and bias.
const DISTINCT_SPEEDS: f64 = 0.1;

/// Two-sided false-alarm probability of "the runs contradict the stated radius".
pub const RADIUS_FALSE_ALARM: f64 = 1e-3;

/// Each run's placement leader: the first run with the same `placement` label (a run without one
/// is its own).
pub(crate) fn placement_leaders(runs: &[RunInput]) -> Vec<usize> {
    runs.iter()
        .enumerate()
        .map(|(i, run)| match &run.entry.placement {
            Some(label) => runs
                .iter()
                .position(|r| r.entry.placement.as_ref() == Some(label))
                .unwrap_or(i),
            None => i,
        })
        .collect()
}

/// Why a placement cannot be fitted as the campaign describes it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PlacementError {
    #[error("{first} and {second} share placement \"{label}\" but not their mounting ({first_mounting} against {second_mounting}): runs made without moving the device have one `out` and `up`; give the moved one its own placement")]
    Mounting {
        label: String,
        first: String,
        second: String,
        first_mounting: String,
        second_mounting: String,
    },
    #[error("{runs}: no `radius_m`, and {why}: the chip's radius cannot be told from the bias across the spindle. Measure the radius to the chip (`radius_m` with `radius_tol_m`; a phone's centre with a tolerance that covers where its chip may be), or record a second speed without moving the device (the same `placement`)")]
    Radius { runs: String, why: String },
}

/// Checks each placement: one mounting, and a radius the runs can determine when none is stated
/// (two speeds, or every run in a power-on session with still poses, which pin its offset).
/// `pose_sessions`: the sessions that hold still poses.
pub fn check_placements(runs: &[RunInput], pose_sessions: &[usize]) -> Result<(), PlacementError> {
    let leaders = placement_leaders(runs);
    for (leader, first) in runs.iter().enumerate() {
        if leaders[leader] != leader {
            continue;
        }
        let members: Vec<&RunInput> = (0..runs.len())
            .filter(|&i| leaders[i] == leader)
            .map(|i| &runs[i])
            .collect();
        let mounting = |r: &RunInput| format!("out {}, up {}", r.entry.out.name(), r.entry.up.name());
        if let Some(moved) = members.iter().find(|r| mounting(r) != mounting(first)) {
            return Err(PlacementError::Mounting {
                label: first.entry.placement.clone().unwrap_or_default(),
                first: first.name.clone(),
                second: moved.name.clone(),
                first_mounting: mounting(first),
                second_mounting: mounting(moved),
            });
        }
        if members.iter().any(|r| r.entry.radius.is_some()) {
            continue;
        }
        let (slow, fast) = members.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), r| {
            (lo.min(r.entry.rpm), hi.max(r.entry.rpm))
        });
        let two_speeds = fast - slow >= DISTINCT_SPEEDS * fast;
        let pinned = members
            .iter()
            .all(|r| r.session.is_some_and(|s| pose_sessions.contains(&s)));
        if !(two_speeds || pinned) {
            let names: Vec<&str> = members.iter().map(|r| r.name.as_str()).collect();
            let why = match (&first.entry.placement, members.len()) {
                (None, _) => "no `placement` shares it with a run at another speed".to_string(),
                (Some(label), 1) => format!("placement \"{label}\" has this one run"),
                (Some(label), _) => format!(
                    "placement \"{label}\" has one speed ({slow:.1} rpm; speeds must differ by {:.0} %)",
                    100.0 * DISTINCT_SPEEDS
                ),
            };
            return Err(PlacementError::Radius {
                runs: names.join(", "),
                why,
            });
        }
    }
    Ok(())
}

/// One placement's radius: what was stated, what the fit found, and whether the runs contradict
/// the statement (results.json).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlacementFit {
    /// The campaign's label, or the run's name for a run without one.
    pub label: String,
    pub runs: Vec<String>,
    /// The stated radius, the runs' statements combined (inverse-variance), when any.
    pub stated: Option<RadiusPrior>,
    /// The fitted radius of the chip, m.
    pub radius_m: f64,
    /// Its robust standard error (with the statement's prior), m.
    pub radius_se_m: Option<f64>,
    /// What the runs alone say, m: the fit with the statement's prior taken out again (Gaussian
    /// algebra on the standard error); `None` when no radius was stated (then it is `radius_m`),
    /// or the runs add nothing to the statement.
    pub from_runs: Option<RadiusPrior>,
    /// The runs' radius minus the stated one over their combined standard deviation.
    pub contradiction_z: Option<f64>,
    /// |z| beyond the two-sided [`RADIUS_FALSE_ALARM`] quantile: the stated radius is wrong.
    pub contradicted: bool,
}

impl PlacementFit {
    /// One line for people: the chip's radius and, when stated, how it compares.
    pub fn sentence(&self) -> String {
        let se = self
            .radius_se_m
            .map_or(String::new(), |se| format!(" ± {:.2}", 1e3 * se));
        let fitted = format!(
            "placement {} ({}): chip at radius {:.2}{se} mm",
            self.label,
            self.runs.join(", "),
            1e3 * self.radius_m
        );
        match (&self.stated, &self.from_runs) {
            (None, _) => format!("{fitted}, from the runs alone"),
            (Some(s), Some(runs)) if self.contradicted => format!(
                "{fitted}; the runs alone say {:.2} ± {:.2} mm, which contradicts the stated {:.2} ± {:.2} mm (z = {:.1}): the stated radius is wrong",
                1e3 * runs.value_m,
                1e3 * runs.tolerance_m,
                1e3 * s.value_m,
                1e3 * s.tolerance_m,
                self.contradiction_z.unwrap_or(0.0)
            ),
            (Some(s), _) => format!(
                "{fitted} (stated {:.2} ± {:.2} mm)",
                1e3 * s.value_m,
                1e3 * s.tolerance_m
            ),
        }
    }
}

/// Each placement's radius after the joint fit of `runs`.
pub fn placement_fits(runs: &[RunInput], joint: &JointFit) -> Vec<PlacementFit> {
    let leaders = placement_leaders(runs);
    let threshold = crate::metrics::student_t_quantile(1.0 - 0.5 * RADIUS_FALSE_ALARM, 1e6);
    (0..runs.len())
        .filter(|&i| leaders[i] == i)
        .map(|leader| {
            let members: Vec<usize> = (0..runs.len()).filter(|&i| leaders[i] == leader).collect();
            let stated = combined_statement(members.iter().filter_map(|&i| runs[i].entry.radius));
            let radius = &joint.runs[leader].params[0];
            let from_runs = stated.and_then(|s| runs_alone(radius.value, radius.std_error?, s));
            let contradiction_z = match (stated, from_runs) {
                (Some(s), Some(r)) => {
                    Some((r.value_m - s.value_m) / (r.tolerance_m.powi(2) + s.tolerance_m.powi(2)).sqrt())
                }
                _ => None,
            };
            PlacementFit {
                label: runs[leader]
                    .entry
                    .placement
                    .clone()
                    .unwrap_or_else(|| runs[leader].name.clone()),
                runs: members.iter().map(|&i| runs[i].name.clone()).collect(),
                stated,
                radius_m: radius.value,
                radius_se_m: radius.std_error,
                from_runs,
                contradiction_z,
                contradicted: contradiction_z.is_some_and(|z| z.abs() > threshold),
            }
        })
        .collect()
}

/// Several statements of one radius as one prior (inverse-variance weighted).
fn combined_statement(statements: impl Iterator<Item = RadiusPrior>) -> Option<RadiusPrior> {
    let (mut weight, mut sum) = (0.0, 0.0);
    for s in statements {
        let w = s.tolerance_m.powi(-2);
        weight += w;
        sum += w * s.value_m;
    }
    (weight > 0.0).then(|| RadiusPrior {
        value_m: sum / weight,
        tolerance_m: weight.powf(-0.5),
    })
}

/// The runs' own radius from a posterior (`value`, `se`) that included the prior `stated`: the
/// precisions subtract, and the posterior mean is the precision-weighted mean of the two.
/// `None` when the runs add less than 1 % to the statement's precision.
fn runs_alone(value: f64, se: f64, stated: RadiusPrior) -> Option<RadiusPrior> {
    let prior = stated.tolerance_m.powi(-2);
    let data = se.powi(-2) - prior;
    if !(data.is_finite() && data > 0.01 * prior) {
        return None;
    }
    Some(RadiusPrior {
        value_m: (value * (data + prior) - stated.value_m * prior) / data,
        tolerance_m: data.powf(-0.5),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_runs_alone_are_recovered_from_a_posterior_with_the_prior() {
        // Runs alone: 0.0900 ± 0.0004; statement 0.1100 ± 0.0020.
        let (r, sr, s, ss) = (0.09f64, 4e-4f64, 0.11f64, 2e-3f64);
        let (wr, ws) = (sr.powi(-2), ss.powi(-2));
        let post = (wr * r + ws * s) / (wr + ws);
        let post_se = (wr + ws).powf(-0.5);
        let alone = runs_alone(
            post,
            post_se,
            RadiusPrior {
                value_m: s,
                tolerance_m: ss,
            },
        )
        .unwrap();
        assert!((alone.value_m - r).abs() < 1e-12, "{alone:?}");
        assert!((alone.tolerance_m - sr).abs() < 1e-12, "{alone:?}");
        // A posterior no tighter than the statement: the runs said nothing.
        assert_eq!(
            runs_alone(
                s,
                ss,
                RadiusPrior {
                    value_m: s,
                    tolerance_m: ss
                }
            ),
            None
        );
    }

    #[test]
    fn statements_combine_by_their_precision() {
        let c = combined_statement(
            [(0.1, 0.002), (0.104, 0.002)]
                .into_iter()
                .map(|(value_m, tolerance_m)| RadiusPrior { value_m, tolerance_m }),
        )
        .unwrap();
        assert!((c.value_m - 0.102).abs() < 1e-12);
        assert!((c.tolerance_m - 0.002 / 2f64.sqrt()).abs() < 1e-12);
        assert_eq!(combined_statement(std::iter::empty()), None);
    }
}
