//! Each recording cut at its logging gaps into pieces that share its parameters but their phase
//! (`turntable::segments`): across a gap the platter's angle is not known.

use std::borrow::Cow;

use super::options::FitError;
use super::start::{sinusoid_fit, wrap_angle, FirstLook};
use crate::input::recording::Recording;
use crate::turntable::model::time_origin;
use crate::turntable::segments::{phase_segments, PhaseSegments};

/// The fit's pieces: whole recordings, and the segments of those cut at a gap.
pub(super) struct Pieces<'a> {
    pub(super) recordings: Vec<Cow<'a, Recording>>,
    /// Per piece: its recording.
    pub(super) recording_of: Vec<usize>,
    /// Per piece of a cut recording, the recording's middle (the drift's origin); `None` for a
    /// whole recording (its own middle).
    pub(super) drift_origin: Vec<Option<f64>>,
    /// Per piece of a cut recording, its phase's start from its own sinusoid fit.
    pub(super) phase_start: Vec<Option<f64>>,
    /// The recordings that were cut, with where.
    pub(super) cut: Vec<PhaseSegments>,
}

/// Cuts each recording at its gaps (at its measured rate). A recording whose every stretch
/// between gaps is too short to fit is refused.
pub(super) fn cut_at_gaps<'a>(
    recordings: &[&'a Recording],
    looks: &[FirstLook],
) -> Result<Pieces<'a>, FitError> {
    let mut pieces = Pieces {
        recordings: Vec::new(),
        recording_of: Vec::new(),
        drift_origin: Vec::new(),
        phase_start: Vec::new(),
        cut: Vec::new(),
    };
    let beta0 = super::parameters::beta_start(looks);
    for (k, (rec, look)) in recordings.iter().zip(looks).enumerate() {
        let segments = phase_segments(rec, look.rate.omega_radps);
        if !segments.is_split() {
            pieces.recordings.push(Cow::Borrowed(*rec));
            pieces.recording_of.push(k);
            pieces.drift_origin.push(None);
            pieces.phase_start.push(None);
            continue;
        }
        if segments.ranges.is_empty() {
            return Err(FitError::NoSegment {
                file: rec.source.name.clone(),
                gaps: segments.gaps.len(),
            });
        }
        let middle = time_origin(&rec.time_s).1;
        for range in &segments.ranges {
            let keep: Vec<bool> = (0..rec.len()).map(|i| range.contains(&i)).collect();
            let piece = rec.select(&keep);
            let s = sinusoid_fit(&piece, look.rate.omega_radps);
            pieces
                .phase_start
                .push(Some(wrap_angle(s.cos[0].atan2(s.sin[0]) + beta0)));
            pieces.recordings.push(Cow::Owned(piece));
            pieces.recording_of.push(k);
            pieces.drift_origin.push(Some(middle));
        }
        pieces.cut.push(segments);
    }
    Ok(pieces)
}
