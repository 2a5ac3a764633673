//! The one evaluation step: every candidate trained through the one trait ([`Candidate::train`]
//! on a [`TrainingSet`](crate::campaign::candidate::TrainingSet)), its output
//! ([`Trained::correct`](crate::campaign::candidate::Trained::correct)) scored on what it did not
//! train on. Two modes ([`Evaluation`]):
//! - [`HeldOutEvaluation`]: each condition of a campaign held out in turn, scored by physics (and
//!   against truth where a simulation carries it); what decides what is saved;
//! - [`SplitEvaluation`]: the paper's 60/20/20 split of one recording against its reference, and
//!   the other recordings (cross-condition); reported for the paper's figures.

mod held_out;
mod split;

use serde::{Deserialize, Serialize};

use crate::campaign::candidate::Candidate;
use crate::campaign::joint::RunInput;
use crate::campaign::prepare::Prepared;
use crate::progress::Observer;

pub use held_out::HeldOutEvaluation;
pub use split::{SplitError, SplitEvaluation, SplitScores};

/// A way of judging candidates on data they did not train on.
pub trait Evaluation {
    type Scores;
    /// Every candidate trained and scored, in the candidates' order.
    fn score(&self, candidates: &[Box<dyn Candidate + Sync>], observer: &Observer) -> Self::Scores;
}

/// A group of recordings that share one condition, held out together.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Condition {
    /// e.g. "speed 45 rpm", "radius 0.120 m", "mounting out +y, up +z", "poses 2 and 5".
    pub label: String,
    /// Indices into the prepared runs and poses.
    pub runs: Vec<usize>,
    pub poses: Vec<usize>,
}

/// The held-out groups: each speed, radius and mounting among the runs (when the campaign has more
/// than one), and the still poses in three groups.
pub fn conditions(prepared: &Prepared) -> Vec<Condition> {
    let mut out = Vec::new();
    let runs = &prepared.runs;
    let mut group = |label_of: &dyn Fn(&RunInput) -> String| {
        let mut labels: Vec<String> = runs.iter().map(label_of).collect();
        labels.sort();
        labels.dedup();
        if labels.len() < 2 {
            return;
        }
        for label in labels {
            let members: Vec<usize> = (0..runs.len()).filter(|&i| label_of(&runs[i]) == label).collect();
            if out
                .iter()
                .any(|c: &Condition| c.runs == members && c.poses.is_empty())
            {
                continue;
            }
            out.push(Condition {
                label,
                runs: members,
                poses: Vec::new(),
            });
        }
    };
    group(&|r| format!("speed {:.1} rpm", r.entry.rpm));
    group(&|r| match (&r.entry.placement, r.entry.radius) {
        (Some(label), _) => format!("placement {label}"),
        (None, Some(stated)) => format!("radius {:.3} m", stated.value_m),
        (None, None) => format!("placement of {}", r.name),
    });
    group(&|r| format!("mounting out {}, up {}", r.entry.out.name(), r.entry.up.name()));
    let n_poses = prepared.poses.len();
    if n_poses >= 3 {
        let groups = 3.min(n_poses / 2).max(1);
        for g in 0..groups {
            let members: Vec<usize> = (g..n_poses).step_by(groups).collect();
            let names: Vec<String> = members.iter().map(|p| (p + 1).to_string()).collect();
            out.push(Condition {
                label: format!("poses {}", names.join(", ")),
                runs: Vec::new(),
                poses: members,
            });
        }
    }
    out
}
