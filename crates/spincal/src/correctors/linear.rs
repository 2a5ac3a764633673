//! The linear corrector (SPEC §3): per-axis offset plus a square matrix (scale and
//! misalignment), fitted by least squares (QR) on the training part of the same 60/20/20
//! division the network uses. The baseline every other corrector must beat.

use faer::prelude::SolveLstsq;
use faer::Mat;
use serde::{Deserialize, Serialize};

use crate::correctors::corrector::{
    axes_phrase, check_finite, check_len, check_model_axes, Axis, CorrectedSample, Corrector, ModelError,
    SampleCorrector,
};
use crate::correctors::division::{
    check_axes, check_pairing, Division, DivisionMode, PairingError, Part, PartFits,
};
use crate::correctors::physical::{propagated_variance, SensorJacobian, SensorUncertainty, SENSOR_PARAMS};
use crate::input::recording::Recording;
use crate::metrics::fit_percent;

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LinearError {
    /// The axes or the data do not pair up (the checks every corrector shares).
    #[error(transparent)]
    Pairing(#[from] PairingError),
    #[error("the least-squares solution is not finite: the measured axes are constant or collinear over the training part")]
    Singular,
}

/// `corrected[axes[i]] = offset[i] + Σ_j matrix[i][j] · measured[axes[j]]`, sensor frame, m/s².
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LinearModel {
    pub axes: Vec<Axis>,
    pub offset_mps2: Vec<f64>,
    /// Row i gives corrected axis i from the measured axes.
    pub matrix: Vec<Vec<f64>>,
    pub training: Option<LinearSummary>,
    /// The covariance of the 12 parameters in [`LinearModel::params`] order (the offsets, then
    /// the matrix row by row), the readings' noise and the sessions' spread, as a campaign's
    /// `linear-12` saves them (`campaign::candidate`: what the covariance includes); only on a
    /// map of all three axes in the order x, y, z. `correct` then writes each row's predicted
    /// standard deviation and `predicted_better`, by the physical kind's rule. Optional: a file
    /// without it reads (no error bar), and an older build reading one with it ignores it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub uncertainty: Option<SensorUncertainty>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LinearSummary {
    pub fits: PartFits,
    pub uncorrected: PartFits,
    pub division: Division,
}

impl LinearModel {
    /// Checks the model against its own structure, everything that applying it relies on:
    /// distinct axes, one finite offset per axis, a square finite matrix with one row and one
    /// column per axis, and a training summary (if any) with one fit per axis and a division that
    /// holds together. Fields are relative to the model (`matrix[1]`). A model that passes never
    /// panics when applied.
    pub fn validate(&self) -> Result<(), ModelError> {
        check_model_axes("axes", &self.axes)?;
        let k = self.axes.len();
        let why = axes_phrase(k);
        check_len("offset_mps2", self.offset_mps2.len(), k, &why)?;
        check_finite("offset_mps2", &self.offset_mps2)?;
        if self.matrix.len() != k {
            return Err(ModelError::new(
                "matrix",
                format!("{} rows, but {why} need a {k} × {k} matrix", self.matrix.len()),
            ));
        }
        for (i, row) in self.matrix.iter().enumerate() {
            let field = format!("matrix[{i}]");
            check_len(&field, row.len(), k, &why)?;
            check_finite(&field, row)?;
        }
        if let Some(uncertainty) = &self.uncertainty {
            if self.axes != Axis::ALL {
                return Err(ModelError::new(
                    "uncertainty",
                    format!(
                        "a covariance of the 12 parameters of a map of the axes x, y, z, but the map is of {}",
                        self.axes.iter().map(|a| a.name()).collect::<Vec<_>>().join(", ")
                    ),
                ));
            }
            uncertainty.validate().map_err(|e| e.within("uncertainty"))?;
        }
        if let Some(training) = &self.training {
            training.fits.check(k).map_err(|e| e.within("training.fits"))?;
            training
                .uncorrected
                .check(k)
                .map_err(|e| e.within("training.uncorrected"))?;
            training
                .division
                .check(0)
                .map_err(|e| e.within("training.division"))?;
        }
        Ok(())
    }

    /// Least squares of `reference` on `[1, measured]` over the training part.
    pub fn fit(
        measured: &Recording,
        reference: &Recording,
        axes: &[Axis],
        mode: DivisionMode,
    ) -> Result<LinearModel, LinearError> {
        check_axes(axes)?;
        check_pairing(measured, reference)?;
        let division = Division::new(measured.len(), 0, mode);
        let rows: Vec<usize> = division.train.iter().flat_map(|r| r.clone()).collect();
        let k = axes.len();
        let design = Mat::from_fn(rows.len(), k + 1, |r, c| {
            if c == 0 {
                1.0
            } else {
                measured.accel_mps2[axes[c - 1].index()][rows[r]]
            }
        });
        let mut solution = Mat::from_fn(rows.len(), k, |r, c| {
            reference.accel_mps2[axes[c].index()][rows[r]]
        });
        design.qr().solve_lstsq_in_place(&mut solution);
        let offset_mps2: Vec<f64> = (0..k).map(|i| solution[(0, i)]).collect();
        let matrix: Vec<Vec<f64>> = (0..k)
            .map(|i| (0..k).map(|j| solution[(j + 1, i)]).collect())
            .collect();
        if offset_mps2
            .iter()
            .chain(matrix.iter().flatten())
            .any(|v| !v.is_finite())
        {
            return Err(LinearError::Singular);
        }
        let mut model = LinearModel {
            axes: axes.to_vec(),
            offset_mps2,
            matrix,
            training: None,
            uncertainty: None,
        };
        let corrected = model.correct(measured);
        let fits_of = |signal: &[Vec<f64>; 3]| -> PartFits {
            let part = |p: Part| -> Vec<f64> {
                let idx: Vec<usize> = division.ranges(p).iter().flat_map(|r| r.clone()).collect();
                axes.iter()
                    .map(|a| {
                        let y: Vec<f64> = idx.iter().map(|&i| reference.accel_mps2[a.index()][i]).collect();
                        let e: Vec<f64> = idx.iter().map(|&i| signal[a.index()][i]).collect();
                        fit_percent(&y, &e)
                    })
                    .collect()
            };
            PartFits {
                train: part(Part::Train),
                validation: part(Part::Validation),
                test: part(Part::Test),
            }
        };
        model.training = Some(LinearSummary {
            fits: fits_of(&corrected.accel_mps2),
            uncorrected: fits_of(&measured.accel_mps2),
            division,
        });
        Ok(model)
    }
}

impl LinearModel {
    /// The corrected reading: the map on its axes, the others as read.
    pub fn apply(&self, accel_mps2: [f64; 3]) -> [f64; 3] {
        let mut out = accel_mps2;
        for (i, axis) in self.axes.iter().enumerate() {
            let mut v = self.offset_mps2[i];
            for (j, from) in self.axes.iter().enumerate() {
                v += self.matrix[i][j] * accel_mps2[from.index()];
            }
            out[axis.index()] = v;
        }
        out
    }

    /// The 12 parameters of a map of the three axes: the offsets, then the matrix row by row
    /// (`None` for a map of fewer axes).
    pub fn params(&self) -> Option<[f64; SENSOR_PARAMS]> {
        if self.axes != Axis::ALL {
            return None;
        }
        let mut p = [0.0; SENSOR_PARAMS];
        p[..3].copy_from_slice(&self.offset_mps2);
        for i in 0..3 {
            p[3 + 3 * i..6 + 3 * i].copy_from_slice(&self.matrix[i]);
        }
        Some(p)
    }

    /// The corrected reading and its Jacobian by the 12 parameters ([`LinearModel::params`]
    /// order): ∂f_i/∂c_i = 1, ∂f_i/∂A_ij = m_j. `None` for a map of fewer than three axes.
    pub fn correct_with_jacobian(&self, m: [f64; 3]) -> Option<([f64; 3], SensorJacobian)> {
        if self.axes != Axis::ALL {
            return None;
        }
        let mut jac = [[0.0; SENSOR_PARAMS]; 3];
        for i in 0..3 {
            jac[i][i] = 1.0;
            jac[i][3 + 3 * i..6 + 3 * i].copy_from_slice(&m);
        }
        Some((self.apply(m), jac))
    }

    /// The standard deviation per axis of the correction of reading `m` that the parameters'
    /// covariance predicts, √diag(J Σ Jᵀ) (`None` without an uncertainty).
    pub fn predicted_sd(&self, m: [f64; 3]) -> Option<[f64; 3]> {
        let uncertainty = self.uncertainty.as_ref()?;
        let (_, jac) = self.correct_with_jacobian(m)?;
        Some(propagated_variance(&jac, &uncertainty.covariance).map(f64::sqrt))
    }
}

struct LinearStream<'a>(&'a LinearModel);

impl SampleCorrector for LinearStream<'_> {
    fn correct_sample(&mut self, accel_mps2: [f64; 3]) -> CorrectedSample {
        CorrectedSample {
            accel_mps2: self.0.apply(accel_mps2),
            valid: true,
            outside_training_range: false,
        }
    }
}

impl Corrector for LinearModel {
    fn corrected_axes(&self) -> Vec<Axis> {
        self.axes.clone()
    }

    fn warmup_samples(&self) -> usize {
        0
    }

    fn stream(&self) -> Box<dyn SampleCorrector + '_> {
        Box::new(LinearStream(self))
    }
}
