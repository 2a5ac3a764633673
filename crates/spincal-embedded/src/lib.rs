//! spincal's correctors on the vehicle: `#![no_std]`, no allocation, no panics on any model.
//!
//! `spincal export --model model.json --out DIR` writes `spincal_model.rs`, a source file of
//! `static` [`Model`]s (one in `f32`, one in `f64`) built from the saved corrector's
//! coefficients; include it in firmware (embassy, RTIC, bare metal) and correct one sample at a
//! time:
//!
//! ```
//! use spincal_embedded::{Accel, Model, Physical, State};
//! // What `spincal export` writes for a physical corrector, shortened by hand.
//! static MODEL: Model<'static, f32> = Model {
//!     accel: Accel::Physical(Physical {
//!         bias: [0.04, -0.06, 0.08],
//!         one_plus_scale: [1.004, 0.994, 1.003],
//!         misalignment: [0.005, -0.003, 0.004],
//!         quadratic: [0.0; 3],
//!         lower: [-60.0; 3],
//!         upper: [60.0; 3],
//!     }),
//!     gyro: None,
//!     covariance: None,
//! };
//! let mut state = State::<f32, 0>::new();
//! let out = MODEL.correct(&mut state, [0.1, -0.2, 9.9], None);
//! assert!(out.valid && !out.outside_training_range);
//! assert!((out.accel[2] - (9.9 - 0.08) / 1.003).abs() < 0.01);
//! ```
//!
//! Every kind applies the library's stream (`spincal::correctors::corrector::Corrector::stream`) operation
//! for operation: in `f64` the corrections equal `spincal correct`'s (tested to 1e-9 relative;
//! in practice bit for bit), in `f32` they are the same operations in single precision. A
//! network carries its training envelope and, inside `physical_ann`, falls back to the physical
//! correction outside it, exactly as `correct` does. A model that does not fit its own shape
//! (a hand-edited one, a state too small) gives `valid: false` and the reading back, never a
//! panic.

#![no_std]
// Per-axis arrays are indexed together; iterators would obscure that.
#![allow(clippy::needless_range_loop)]

mod real;

pub use real::{tanh_f32, tanh_f64, Real};
/// The tanh's constants, which the C export writes out so that its tanh does the same operations.
pub use real::{LN2_HI, LN2_HI_F, LN2_LO, LN2_LO_F, ROUNDER, ROUNDER_F, TANH_C, TANH_C_F};

/// Widest layer (hidden or output) a [`Network`] may have: two buffers of this many values sit
/// on the stack during a correction. `spincal export` refuses wider networks.
pub const MAX_UNITS: usize = 32;

/// Most weight layers of a [`Network`] (three hidden layers and the output layer).
pub const MAX_LAYERS: usize = 4;

/// The inverse of spincal's physical sensor model (bias, scale, lower-triangular misalignment,
/// per-axis quadratic; `spincal::correctors::physical`). Sensor frame, m/s².
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Physical<T> {
    /// b, m/s².
    pub bias: [T; 3],
    /// 1 + s per axis.
    pub one_plus_scale: [T; 3],
    /// [m_yx, m_zx, m_zy], rad.
    pub misalignment: [T; 3],
    /// q per axis, 1/(m/s²); zero for physical-linear.
    pub quadratic: [T; 3],
    /// Readings below `lower` or above `upper` lie beyond the campaign's range by more than 10 %
    /// of it: the correction is marked outside the training range.
    pub lower: [T; 3],
    pub upper: [T; 3],
}

impl<T: Real> Physical<T> {
    /// The true specific force for reading `m`, `None` beyond the quadratic's turning point.
    pub fn correct(&self, m: [T; 3]) -> Option<[T; 3]> {
        let mut v = [T::ZERO; 3];
        for k in 0..3 {
            // The root of q u² + u − m = 0 nearest u = m, in the form without cancellation.
            let disc = T::ONE + T::FOUR * self.quadratic[k] * m[k];
            if disc <= T::ZERO {
                return None;
            }
            let u = T::TWO * m[k] / (T::ONE + disc.sqrt());
            v[k] = (u - self.bias[k]) / self.one_plus_scale[k];
        }
        let [m_yx, m_zx, m_zy] = self.misalignment;
        let fx = v[0];
        let fy = v[1] - m_yx * fx;
        let fz = v[2] - m_zx * fx - m_zy * fy;
        let f = [fx, fy, fz];
        (fx.is_finite() && fy.is_finite() && fz.is_finite()).then_some(f)
    }

    /// The corrected force (as [`Physical::correct`]) and its Jacobian ∂f/∂θ with respect to
    /// the [`PARAMS`] parameters, by spincal's `SensorModel::correct_with_jacobian` operation for
    /// operation (implicit differentiation of m = h(b + D (I + M) f)); `None` where the model has
    /// no inverse or the quadratic's slope vanishes.
    pub fn correct_with_jacobian(&self, m: [T; 3]) -> Option<([T; 3], Jacobian<T>)> {
        let f = self.correct(m)?;
        let [m_yx, m_zx, m_zy] = self.misalignment;
        // v = (I + M) f: the force as the three skewed axes see it.
        let v = [f[0], f[1] + m_yx * f[0], f[2] + m_zx * f[0] + m_zy * f[1]];
        // ∂v/∂θ for v = (u − b)/(1 + s), u = h⁻¹(m): bias, scale and q act on their own axis.
        let mut jac = [[T::ZERO; PARAMS]; 3];
        for k in 0..3 {
            let d = self.one_plus_scale[k];
            let u = self.bias[k] + d * v[k];
            // q u² + u = m  ⇒  ∂u/∂q = −u² / (1 + 2 q u).
            let slope = T::ONE + T::TWO * self.quadratic[k] * u;
            if slope.abs() < T::EPSILON {
                return None;
            }
            jac[k][k] = -T::ONE / d;
            jac[k][3 + k] = -v[k] / d;
            jac[k][9 + k] = -u * u / slope / d;
        }
        // f = (I + M)⁻¹ v: forward substitution carries v's derivatives, M's own enter directly.
        for j in 0..PARAMS {
            jac[1][j] = jac[1][j] - m_yx * jac[0][j];
            jac[2][j] = jac[2][j] - m_zx * jac[0][j] - m_zy * jac[1][j];
        }
        jac[1][6] = jac[1][6] - f[0];
        jac[2][6] = jac[2][6] + m_zy * f[0];
        jac[2][7] = jac[2][7] - f[0];
        jac[2][8] = jac[2][8] - f[1];
        Some((f, jac))
    }

    /// The correction's standard deviation per axis that the parameters' `covariance` predicts,
    /// √diag(J Σ Jᵀ), and whether on every axis the correction is predicted to beat no
    /// correction: what `spincal correct` writes as `<column>_corrected_sd` and
    /// `predicted_better`. `None` where the model has no inverse (`correct` leaves them empty).
    pub fn predicted_error(&self, covariance: &Covariance<T>, m: [T; 3]) -> Option<PredictedError<T>> {
        let (f, jac) = self.correct_with_jacobian(m)?;
        Some(error_of(&jac, covariance, f, m))
    }

    /// Whether reading `m` lies beyond the covered range by more than 10 % of its width.
    pub fn outside(&self, m: [T; 3]) -> bool {
        (0..3).any(|k| m[k] < self.lower[k] || m[k] > self.upper[k])
    }

    fn sample(&self, m: [T; 3]) -> Corrected<T> {
        match self.correct(m) {
            Some(f) => Corrected {
                accel: f,
                gyro: None,
                valid: true,
                outside_training_range: self.outside(m),
            },
            None => Corrected {
                accel: m,
                gyro: None,
                valid: false,
                outside_training_range: true,
            },
        }
    }
}

/// √diag(J Σ Jᵀ) of a correction `f` of reading `m` with Jacobian `jac`, in spincal's
/// `propagated_variance` operations, and `predicted_better`: on every axis the correction's
/// square exceeds twice its variance (`predicted_to_help`). One rule for every kind.
fn error_of<T: Real>(
    jac: &Jacobian<T>,
    covariance: &Covariance<T>,
    f: [T; 3],
    m: [T; 3],
) -> PredictedError<T> {
    let mut sd = [T::ZERO; 3];
    let mut better = true;
    for k in 0..3 {
        let row = &jac[k];
        let mut sum = T::ZERO;
        for a in 0..PARAMS {
            // spincal skips a parameter the correction does not depend on: the same sum.
            if row[a] == T::ZERO {
                continue;
            }
            let mut inner = T::ZERO;
            for b in 0..PARAMS {
                inner = inner + covariance[a][b] * row[b];
            }
            sum = sum + row[a] * inner;
        }
        let variance = if sum > T::ZERO { sum } else { T::ZERO };
        sd[k] = variance.sqrt();
        // Predicted to help when ĉ² > 2σ²: ĉ² − σ² estimates the true correction's square,
        // and applying ĉ leaves σ².
        let correction = f[k] - m[k];
        better &= correction * correction > T::TWO * sd[k] * sd[k];
    }
    PredictedError { sd, better }
}

/// Parameters of the physical model, in spincal's order: bias x, y, z (m/s²), scale error x,
/// y, z, misalignment m_yx, m_zx, m_zy (rad), quadratic x, y, z (1/(m/s²)).
pub const PARAMS: usize = 12;

/// ∂f_k/∂θ_j of a correction: three rows of the [`PARAMS`] parameters.
pub type Jacobian<T> = [[T; PARAMS]; 3];

/// The covariance of a model's [`PARAMS`] parameters (their units' products), as a campaign saved
/// it in model.json's `uncertainty`: a physical model's in [`PARAMS`] order, a linear map's in
/// [`Linear::predicted_error`]'s (the offsets, then the matrix row by row).
pub type Covariance<T> = [[T; PARAMS]; PARAMS];

/// A correction's error as the model's covariance predicts it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PredictedError<T> {
    /// Standard deviation of the correction per axis, m/s².
    pub sd: [T; 3],
    /// On every axis the correction's square exceeds twice its variance (`predicted_better`).
    pub better: bool,
}

/// Offset plus matrix on the chosen axes (`linear`); the other axes pass through.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Linear<T> {
    /// Axis indices (0 = x) read and corrected, the first `n_axes` used.
    pub axes: [usize; 3],
    pub n_axes: usize,
    pub offset: [T; 3],
    /// Row i: the weights of the chosen axes in corrected axis `axes[i]`.
    pub matrix: [[T; 3]; 3],
}

/// The still-pose calibration (`static`): a = T (u + q u²), u = s (raw − b).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Static<T> {
    /// b, input units.
    pub bias: [T; 3],
    /// s, m/s² per input unit.
    pub scale: [T; 3],
    /// q, 1/(m/s²).
    pub nonlinearity: [T; 3],
    /// T, the misalignment matrix.
    pub matrix: [[T; 3]; 3],
}

/// A feed-forward network (tanh hidden layers, linear output) with its scalings and training
/// envelope (`ann`, and the network of `physical_ann`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Network<'a, T> {
    /// Axis indices read (each with its delays) and corrected, the first `n_axes` used.
    pub axes: [usize; 3],
    pub n_axes: usize,
    /// Previous samples of each axis read besides the current one.
    pub delays: usize,
    /// Layer sizes: inputs, hidden layers, outputs.
    pub sizes: &'a [usize],
    /// Layer after layer: the weight matrix row-major (unit × input), then the biases.
    pub weights: &'a [T],
    /// scaled = gain · x + offset, per axis.
    pub input_gain: [T; 3],
    pub input_offset: [T; 3],
    /// x = min + (scaled + 1) · span / 2, per output (min alone when span is 0).
    pub output_min: [T; 3],
    pub output_span: [T; 3],
    /// The output scaling's forward map (the envelope check of `physical_ann`).
    pub output_gain: [T; 3],
    pub output_offset: [T; 3],
    /// |scaled| beyond this (1 + 2 · 10 %) lies outside the training range.
    pub limit: T,
}

/// The cells of a box that training reached (`physical_ann`'s coverage).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coverage<'a, T> {
    pub lower: [T; 3],
    /// upper − lower per axis.
    pub width: [T; 3],
    /// Cells per axis.
    pub cells: usize,
    /// Bit c (byte c / 8, bit c % 8) set when cell c = x + cells·(y + cells·z) is covered.
    pub covered: &'a [u8],
}

/// The physical inverse, then a static network on what it left, trusted only inside its
/// envelope.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhysicalAnn<'a, T> {
    pub physical: Physical<T>,
    pub network: Network<'a, T>,
    pub coverage: Coverage<'a, T>,
}

/// The gyroscope's inverse: ω = K⁻¹ (m − b), rad/s (m in rad/s or counts, as calibrated).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gyro<T> {
    pub bias: [T; 3],
    pub inverse: [[T; 3]; 3],
}

/// The accelerometer's corrector, one per kind of saved model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Accel<'a, T> {
    Physical(Physical<T>),
    Linear(Linear<T>),
    Static(Static<T>),
    Ann(Network<'a, T>),
    PhysicalAnn(PhysicalAnn<'a, T>),
    /// The reading unchanged (a model.json of kind `uncorrected`: its gyro part alone).
    AsRead,
}

/// A saved corrector: the accelerometer's and, if calibrated, the gyroscope's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Model<'a, T> {
    pub accel: Accel<'a, T>,
    pub gyro: Option<Gyro<T>>,
    /// The parameters' covariance of a physical model or a linear map, when model.json carries
    /// one (`spincal correct` then writes each row's error bar): see [`Model::predicted_error`].
    /// `None` for every other kind.
    pub covariance: Option<&'a Covariance<T>>,
}

/// One corrected sample. An invalid sample carries the reading unchanged.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Corrected<T> {
    /// Sensor frame, m/s² (the axes a model does not correct pass through).
    pub accel: [T; 3],
    /// The gyroscope's rate, rad/s, when the model calibrates it and a reading was given.
    pub gyro: Option<[T; 3]>,
    /// False for the first `delays` samples of a network with delays, for a reading beyond a
    /// quadratic's turning point, and for a model or state that does not fit together.
    pub valid: bool,
    /// An input beyond the training range (spincal's `outside_training_range`).
    pub outside_training_range: bool,
}

/// A stream's state: the network's scaled delay history (`H` = axes × (delays + 1), the
/// `HISTORY` constant of the exported file; 0 for kinds without a network).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct State<T, const H: usize> {
    history: [T; H],
    seen: usize,
}

impl<T: Real, const H: usize> State<T, H> {
    pub const fn new() -> Self {
        State {
            history: [T::ZERO; H],
            seen: 0,
        }
    }

    /// Back to the start of a stream.
    pub fn reset(&mut self) {
        *self = State::new();
    }
}

impl<T: Real, const H: usize> Default for State<T, H> {
    fn default() -> Self {
        State::new()
    }
}

impl<T: Real> Model<'_, T> {
    /// Corrects one sample: `accel` in the model's input unit (m/s², or the static calibration's
    /// raw unit), sensor frame; `gyro` in the gyro model's input unit (rad/s or counts). Samples
    /// of one stream must arrive in time order through the same `state`.
    #[inline]
    pub fn correct<const H: usize>(
        &self,
        state: &mut State<T, H>,
        accel: [T; 3],
        gyro: Option<[T; 3]>,
    ) -> Corrected<T> {
        let mut out = self.correct_accel(state, accel);
        out.gyro = match (&self.gyro, gyro) {
            (Some(model), Some(m)) => Some(model.correct(m)),
            _ => None,
        };
        out
    }

    /// The error of the correction of `accel` that the model's covariance predicts (as
    /// [`Physical::predicted_error`] and [`Linear::predicted_error`]): for a physical model with
    /// a covariance, where it has an inverse, and a linear map of the three axes with one;
    /// `None` otherwise, as `spincal correct` writes no error bar then.
    #[inline]
    pub fn predicted_error(&self, accel: [T; 3]) -> Option<PredictedError<T>> {
        match (&self.accel, self.covariance) {
            (Accel::Physical(p), Some(covariance)) => p.predicted_error(covariance, accel),
            (Accel::Linear(l), Some(covariance)) => l.predicted_error(covariance, accel),
            _ => None,
        }
    }

    /// The accelerometer alone (`gyro` of the result is `None`).
    #[inline]
    pub fn correct_accel<const H: usize>(&self, state: &mut State<T, H>, m: [T; 3]) -> Corrected<T> {
        match &self.accel {
            Accel::Physical(p) => p.sample(m),
            Accel::Linear(l) => l.sample(m),
            Accel::Static(s) => s.sample(m),
            Accel::Ann(n) => n.stream_sample(&mut state.history, &mut state.seen, m),
            Accel::PhysicalAnn(pa) => pa.sample(&mut state.history, m),
            Accel::AsRead => Corrected {
                accel: m,
                gyro: None,
                valid: true,
                outside_training_range: false,
            },
        }
    }
}

impl<T: Real> Linear<T> {
    /// The correction's standard deviation per axis that the covariance of the map's 12
    /// parameters (offset x, y, z, then the matrix row by row) predicts, and `predicted_better`,
    /// as `spincal correct` writes them (∂f_i/∂c_i = 1, ∂f_i/∂A_ij = m_j). `None` unless the map
    /// is of the three axes in the order x, y, z (the only maps saved with a covariance).
    pub fn predicted_error(&self, covariance: &Covariance<T>, m: [T; 3]) -> Option<PredictedError<T>> {
        if self.n_axes != 3 || self.axes != [0, 1, 2] {
            return None;
        }
        let mut jac = [[T::ZERO; PARAMS]; 3];
        for i in 0..3 {
            jac[i][i] = T::ONE;
            for j in 0..3 {
                jac[i][3 + 3 * i + j] = m[j];
            }
        }
        let f = self.sample(m).accel;
        Some(error_of(&jac, covariance, f, m))
    }

    fn sample(&self, m: [T; 3]) -> Corrected<T> {
        let mut out = m;
        let n = self.n_axes;
        let fits = (1..=3).contains(&n) && self.axes[..n.min(3)].iter().all(|&a| a < 3);
        if fits {
            for i in 0..n {
                let mut v = self.offset[i];
                for j in 0..n {
                    v = v + self.matrix[i][j] * m[self.axes[j]];
                }
                out[self.axes[i]] = v;
            }
        }
        Corrected {
            accel: out,
            gyro: None,
            valid: fits,
            outside_training_range: false,
        }
    }
}

impl<T: Real> Static<T> {
    fn sample(&self, raw: [T; 3]) -> Corrected<T> {
        let mut v = [T::ZERO; 3];
        for i in 0..3 {
            let u = self.scale[i] * (raw[i] - self.bias[i]);
            v[i] = u + self.nonlinearity[i] * u * u;
        }
        let t = &self.matrix;
        let mut a = [T::ZERO; 3];
        for r in 0..3 {
            a[r] = t[r][0] * v[0] + t[r][1] * v[1] + t[r][2] * v[2];
        }
        Corrected {
            accel: a,
            gyro: None,
            valid: true,
            outside_training_range: false,
        }
    }
}

impl<T: Real> Gyro<T> {
    /// ω = K⁻¹ (m − b).
    pub fn correct(&self, m: [T; 3]) -> [T; 3] {
        let d = [m[0] - self.bias[0], m[1] - self.bias[1], m[2] - self.bias[2]];
        let k = &self.inverse;
        let mut w = [T::ZERO; 3];
        for i in 0..3 {
            w[i] = k[i][0] * d[0] + k[i][1] * d[1] + k[i][2] * d[2];
        }
        w
    }
}

impl<T: Real> Network<'_, T> {
    /// The layout holds together: sizes, axes, weights and the buffers agree.
    fn fits(&self, history: usize) -> bool {
        let s = self.sizes;
        let n = self.n_axes;
        if !(2..=MAX_LAYERS + 1).contains(&s.len()) || !(1..=3).contains(&n) {
            return false;
        }
        if self.axes[..n].iter().any(|&a| a >= 3) || s[s.len() - 1] != n {
            return false;
        }
        let Some(inputs) = self.delays.checked_add(1).and_then(|l| l.checked_mul(n)) else {
            return false;
        };
        if s[0] != inputs || inputs > history || s[1..].iter().any(|&u| u == 0 || u > MAX_UNITS) {
            return false;
        }
        let mut weights = 0usize;
        for l in 1..s.len() {
            weights += s[l] * (s[l - 1] + 1);
        }
        weights == self.weights.len()
    }

    /// The network's outputs for one input row (scaled), into `out`.
    fn forward(&self, input: &[T], out: &mut [T; 3]) {
        let s = self.sizes;
        let last = s.len() - 1;
        let mut buffers = [[T::ZERO; MAX_UNITS]; 2];
        let mut at = 0;
        for l in 1..=last {
            let (n_in, n_out) = (s[l - 1], s[l]);
            let biases = at + n_out * n_in;
            let (first, second) = buffers.split_at_mut(1);
            let (a_in, a_out): (&[T], &mut [T; MAX_UNITS]) = match (l == 1, l % 2) {
                (true, _) => (input, &mut first[0]),
                (false, 0) => (&first[0][..n_in], &mut second[0]),
                (false, _) => (&second[0][..n_in], &mut first[0]),
            };
            for i in 0..n_out {
                let row = &self.weights[at + i * n_in..at + (i + 1) * n_in];
                let mut z = self.weights[biases + i];
                for (&w, &a) in row.iter().zip(&a_in[..n_in]) {
                    z = z + w * a;
                }
                a_out[i] = z;
            }
            // The tanh in a loop of its own: independent lanes the compiler can interleave.
            if l != last {
                for v in &mut a_out[..n_out] {
                    *v = v.tanh();
                }
            }
            at = biases + n_out;
        }
        // Layer l wrote buffer (l + 1) % 2.
        let result = &buffers[(last + 1) % 2];
        out[..s[last]].copy_from_slice(&result[..s[last]]);
    }

    fn reverse(&self, c: usize, scaled: T) -> T {
        let span = self.output_span[c];
        if span > T::ZERO {
            self.output_min[c] + (scaled + T::ONE) * span / T::TWO
        } else {
            self.output_min[c]
        }
    }

    /// One sample of the `ann` stream: the history shifts, the network runs once the history
    /// is full and every input lies within the training range.
    fn stream_sample(&self, history: &mut [T], seen: &mut usize, m: [T; 3]) -> Corrected<T> {
        let invalid = Corrected {
            accel: m,
            gyro: None,
            valid: false,
            outside_training_range: false,
        };
        if !self.fits(history.len()) {
            return invalid;
        }
        let lags = self.delays + 1;
        let mut outside = false;
        for c in 0..self.n_axes {
            let row = &mut history[c * lags..(c + 1) * lags];
            if lags > 1 {
                row.copy_within(0..lags - 1, 1);
            }
            row[0] = self.input_gain[c] * m[self.axes[c]] + self.input_offset[c];
            outside |= row[0].abs() > self.limit;
        }
        *seen = seen.saturating_add(1);
        let mut out = Corrected {
            outside_training_range: outside,
            // Outside its training range the network is not applied (as spincal's `correct`).
            valid: *seen > self.delays && !outside,
            ..invalid
        };
        if out.valid {
            let mut scaled = [T::ZERO; 3];
            self.forward(&history[..self.sizes[0]], &mut scaled);
            for c in 0..self.n_axes {
                out.accel[self.axes[c]] = self.reverse(c, scaled[c]);
            }
        }
        out
    }
}

impl<T: Real> Coverage<'_, T> {
    /// Whether `v` lies in a covered cell.
    pub fn covers(&self, v: [T; 3]) -> bool {
        let n = self.cells;
        let mut index = [0usize; 3];
        for k in 0..3 {
            let u = (v[k] - self.lower[k]) / self.width[k];
            if !(u >= T::ZERO && u <= T::ONE) {
                return false;
            }
            index[k] = (u * T::from_count(n)).to_index().min(n.saturating_sub(1));
        }
        let c = index[0] + n * (index[1] + n * index[2]);
        self.covered
            .get(c / 8)
            .is_some_and(|byte| byte & (1 << (c % 8)) != 0)
    }
}

impl<T: Real> PhysicalAnn<'_, T> {
    fn sample(&self, history: &mut [T], m: [T; 3]) -> Corrected<T> {
        let p = self.physical.sample(m);
        if !p.valid {
            return p;
        }
        let net = &self.network;
        // The network on top of physics is static and on all three axes.
        if net.delays != 0 || net.n_axes != 3 || net.axes != [0, 1, 2] {
            return Corrected { valid: false, ..p };
        }
        let mut seen = 0;
        let residual = net.stream_sample(history, &mut seen, p.accel);
        let output_in_range = (0..3)
            .all(|c| (net.output_gain[c] * residual.accel[c] + net.output_offset[c]).abs() <= net.limit);
        if residual.outside_training_range
            || !residual.valid
            || !output_in_range
            || !self.coverage.covers(p.accel)
        {
            return Corrected {
                outside_training_range: true,
                ..p
            };
        }
        Corrected {
            accel: [
                p.accel[0] + residual.accel[0],
                p.accel[1] + residual.accel[1],
                p.accel[2] + residual.accel[2],
            ],
            ..p
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;

    fn ulps32(a: f32, b: f32) -> i64 {
        (i64::from(a.to_bits() as i32) - i64::from(b.to_bits() as i32)).abs()
    }

    #[test]
    fn single_precision_tanh_is_within_three_ulps() {
        let mut worst = 0;
        for i in -20 * 4096..=20 * 4096 {
            let x = i as f32 / 4096.0;
            let exact = (f64::from(x)).tanh() as f32;
            worst = worst.max(ulps32(tanh_f32(x), exact));
        }
        for x in [1e-30f32, 1e-8, 3e-4, 0.1234567, 19.99, 25.0, f32::MAX] {
            worst = worst.max(ulps32(tanh_f32(x), (f64::from(x)).tanh() as f32));
        }
        std::println!("tanh_f32: at most {worst} ulps from the correctly rounded tanh");
        assert!(worst <= 3, "tanh_f32 is {worst} ulps off");
        assert!(tanh_f32(f32::NAN).is_nan());
        assert_eq!(tanh_f32(-0.0).to_bits(), (-0.0f32).to_bits());
    }

    #[test]
    fn double_precision_tanh_is_within_four_ulps() {
        for i in -4000..=4000 {
            let x = i as f64 / 197.0;
            let (ours, std) = (tanh_f64(x), x.tanh());
            let ulps = (ours.to_bits() as i64 - std.to_bits() as i64).abs();
            assert!(ulps <= 4, "tanh({x}) {ours} vs {std}");
        }
    }

    /// A sensor with every term of the model, well inside its invertible range.
    fn sensor() -> Physical<f64> {
        Physical::<f64> {
            bias: [0.04, -0.06, 0.08],
            one_plus_scale: [1.004, 0.994, 1.003],
            misalignment: [0.005, -0.003, 0.004],
            quadratic: [6e-4, -6e-4, 3e-4],
            lower: [-20.0; 3],
            upper: [20.0; 3],
        }
    }

    #[test]
    fn physical_inverts_the_sensor_model() {
        let p = sensor();
        let f = [1.0, -9.8, 2.0];
        // The forward model: u = b + D (I + M) f, m = u + q u².
        let [m_yx, m_zx, m_zy] = p.misalignment;
        let skewed = [f[0], f[1] + m_yx * f[0], f[2] + m_zx * f[0] + m_zy * f[1]];
        let m: [f64; 3] = core::array::from_fn(|k| {
            let u = p.bias[k] + p.one_plus_scale[k] * skewed[k];
            u + p.quadratic[k] * u * u
        });
        let back = p.correct(m).unwrap();
        for k in 0..3 {
            assert!((back[k] - f[k]).abs() < 1e-12, "{back:?}");
        }
        assert!(p.outside([25.0, 0.0, 0.0]) && !p.outside(m));
        let past_turning_point = Physical {
            quadratic: [0.1, 0.0, 0.0],
            ..p
        };
        assert!(past_turning_point.correct([-3.0, 0.0, 0.0]).is_none());
    }

    /// The Jacobian against central differences of `correct`, and the error bar of a bias known
    /// to ±σ: σ/(1 + s) on its own axis, carried into the others by the misalignment.
    #[test]
    fn the_error_bar_follows_the_jacobian() {
        let p = sensor();
        let m = [1.0, -9.7, 2.0];
        let (f, jac) = p.correct_with_jacobian(m).unwrap();
        assert_eq!(f, p.correct(m).unwrap());
        let h = 1e-6;
        for j in 0..PARAMS {
            let moved = |d: f64| {
                let mut q = p;
                match j {
                    0..=2 => q.bias[j] += d,
                    3..=5 => q.one_plus_scale[j - 3] += d,
                    6..=8 => q.misalignment[j - 6] += d,
                    _ => q.quadratic[j - 9] += d,
                }
                q.correct(m).unwrap()
            };
            let (a, b) = (moved(h), moved(-h));
            for k in 0..3 {
                let numeric = (a[k] - b[k]) / (2.0 * h);
                assert!(
                    (numeric - jac[k][j]).abs() < 1e-6 * (1.0 + numeric.abs()),
                    "f_{k} by θ_{j}: {} vs {numeric}",
                    jac[k][j]
                );
            }
        }
        let sigma = 0.01;
        let mut covariance = [[0.0; PARAMS]; PARAMS];
        covariance[0][0] = sigma * sigma;
        let e = p.predicted_error(&covariance, m).unwrap();
        let sd_x = sigma / 1.004;
        let [m_yx, m_zx, m_zy] = p.misalignment;
        let expected = [sd_x, m_yx * sd_x, (m_zx - m_zy * m_yx) * sd_x];
        for k in 0..3 {
            assert!(
                (e.sd[k] - expected[k].abs()).abs() < 1e-15,
                "{:?} vs {expected:?}",
                e.sd
            );
        }
        // Every axis's correction (about 0.05 m/s²) exceeds √2 of its sd (at most 0.01 m/s²).
        assert!(e.better);
        // A bias known only to ±1 m/s² is not: its sd swamps the x correction.
        covariance[0][0] = 1.0;
        assert!(!p.predicted_error(&covariance, m).unwrap().better);
        // No covariance on the model: no error bar, as `spincal correct`.
        let model = Model {
            accel: Accel::Physical(p),
            gyro: None,
            covariance: None,
        };
        assert_eq!(model.predicted_error(m), None);
        let model = Model {
            covariance: Some(&covariance),
            ..model
        };
        assert!(model.predicted_error(m).is_some());
        assert_eq!(
            model.predicted_error([0.0, 0.0, -1e4]),
            None,
            "past the turning point"
        );
    }

    #[test]
    fn a_network_that_does_not_fit_its_state_is_invalid_not_a_panic() {
        static WEIGHTS: [f64; 3 * 4 + 3 * 4] = [0.1; 24];
        let net = Network::<f64> {
            axes: [0, 1, 2],
            n_axes: 3,
            delays: 0,
            sizes: &[3, 3, 3],
            weights: &WEIGHTS,
            input_gain: [0.1; 3],
            input_offset: [0.0; 3],
            output_min: [-1.0; 3],
            output_span: [2.0; 3],
            output_gain: [1.0; 3],
            output_offset: [0.0; 3],
            limit: 1.2,
        };
        let model = Model {
            accel: Accel::Ann(net),
            gyro: None,
            covariance: None,
        };
        let too_small = model.correct(&mut State::<f64, 2>::new(), [1.0, 2.0, 3.0], None);
        assert!(!too_small.valid);
        assert_eq!(too_small.accel, [1.0, 2.0, 3.0]);
        let ok = model.correct(&mut State::<f64, 3>::new(), [1.0, 2.0, 3.0], None);
        assert!(ok.valid && !ok.outside_training_range);
        // Every unit sees 0.1 · (0.1 + 0.2 + 0.3) + 0.1 = 0.16, every output 0.1 + 3 · 0.1 tanh.
        let expected = 0.1 + 3.0 * 0.1 * tanh_f64(0.1 * 0.1 + 0.1 * 0.2 + 0.1 * 0.3 + 0.1);
        assert!((ok.accel[0] - expected).abs() < 1e-15, "{:?}", ok.accel);
        let far = model.correct(&mut State::<f64, 3>::new(), [20.0, 0.0, 0.0], None);
        assert!(far.outside_training_range);
    }
}
