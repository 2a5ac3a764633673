//! A campaign file calibrated: what `spincal calibrate --campaign`, each unit of `spincal fleet`
//! and Python's `calibrate_campaign` run, so that all three give the same numbers (the files
//! they write: `report::campaign::campaign_files`).

use std::path::PathBuf;

use crate::campaign::file::Campaign;
use crate::campaign::load::{load_campaign, LoadError};
use crate::campaign::params::Params;
use crate::campaign::select::{calibrate_campaign, CampaignCalError, CampaignOutput};
use crate::progress::Observer;

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CampaignRunError {
    #[error(transparent)]
    Load(#[from] LoadError),
    #[error("{campaign}: {source}")]
    Calibration {
        campaign: String,
        #[source]
        source: CampaignCalError,
    },
}

impl Campaign {
    /// Every file the campaign reads: the campaign file, its recordings and their truth and
    /// random-error files.
    pub fn inputs(&self) -> Vec<PathBuf> {
        let mut inputs = vec![self.path.clone()];
        for entry in &self.recordings {
            inputs.push(entry.file.clone());
            inputs.extend(
                entry
                    .gyro_file
                    .iter()
                    .chain(&entry.truth)
                    .chain(&entry.random_error)
                    .cloned(),
            );
        }
        inputs
    }

    /// The settings the campaign is calibrated with: `base` with the file's own gravity and, when
    /// it gives the datasheet's figures, the priors they bound.
    pub fn params(&self, base: &Params) -> Params {
        let mut settings = base.clone();
        settings.joint.gravity_mps2 = self.gravity_mps2;
        settings.joint.set_datasheet_priors(&self.datasheet);
        settings
    }
}

/// Loads a read campaign's recordings and calibrates the unit with [`Campaign::params`]. Runs on
/// the caller's rayon pool.
pub fn calibrate_campaign_file(
    campaign: &Campaign,
    base: &Params,
    observer: &Observer,
) -> Result<CampaignOutput, CampaignRunError> {
    let clock = std::time::Instant::now();
    let recordings = load_campaign(campaign)?;
    let read_seconds = clock.elapsed().as_secs_f64();
    let mut output = calibrate_campaign(&campaign.unit, &recordings, &campaign.params(base), observer)
        .map_err(|source| CampaignRunError::Calibration {
            campaign: campaign.path.display().to_string(),
            source,
        })?;
    output.result.add_read_seconds(read_seconds);
    Ok(output)
}
