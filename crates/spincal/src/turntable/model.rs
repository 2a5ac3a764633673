//! The turntable model (SPEC §2), evaluated over a time grid, with its analytic Jacobian.
//!
//! Frame and signs: sensor axes x, y, z; z along the platter's axis (up). The platter angle is
//! θ(t) = ω t + φ with t counted from the first sample, φ the angle between the platter's downhill
//! direction and the sensor at t = 0. The sensor's x axis is turned by β from the radial direction.
//!
//! ```text
//! a_x = ω² r cos β +     g sin α · sin(θ − β) + b_x + d_x (t − t_mid)
//! a_y = ω² r sin β + s · g sin α · cos(θ − β) + b_y + d_y (t − t_mid)
//! a_z = g cos α                               + b_z + d_z (t − t_mid)
//! ```
//! s = +1 for one sense of rotation and −1 for the other ([`Direction`]); drift is measured from the
//! middle of the recording so that offsets are the mean bias and do not correlate with drift.

use serde::{Deserialize, Serialize};

impl Direction {
    /// The sense of rotation seen from above, in words.
    pub fn describe(self) -> &'static str {
        match self {
            Direction::Ccw => "counter-clockwise",
            Direction::Cw => "clockwise",
        }
    }
}

/// Sense of rotation, which flips the sign of the gravity term on y.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Direction {
    /// s = +1 (y leads x by a quarter turn): counter-clockwise seen from above with x outward.
    Ccw,
    /// s = −1: clockwise seen from above, as record players turn.
    Cw,
}

impl Direction {
    pub fn sign(self) -> f64 {
        match self {
            Direction::Ccw => 1.0,
            Direction::Cw => -1.0,
        }
    }
    pub fn from_sign(s: f64) -> Direction {
        if s >= 0.0 {
            Direction::Ccw
        } else {
            Direction::Cw
        }
    }
}

/// What one recording's turntable run looked like.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Session {
    /// Distance of the sensor from the axis, m.
    pub radius_m: f64,
    /// Rotation rate, rad/s (positive; the sense is `direction`).
    pub omega_radps: f64,
    /// Platter tilt from horizontal, rad.
    pub tilt_rad: f64,
    /// Platter angle at the first sample, rad.
    pub phase_rad: f64,
    pub direction: Direction,
    /// Linear drift per axis, m/s² per s, about the recording's middle.
    pub drift_mps2_per_s: [f64; 3],
}

/// How the sensor sits on the platter and its constant offsets (shared by all recordings).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Mounting {
    /// Angle of the sensor's x axis from the radial direction, rad.
    pub beta_rad: f64,
    /// Per-axis offsets, m/s².
    pub offset_mps2: [f64; 3],
}

/// Partial derivatives of (a_x, a_y, a_z) at one sample with respect to each model quantity.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct SampleDerivatives {
    /// The model itself, a_x, a_y, a_z (m/s²), equal to [`for_each_sample`]'s.
    pub value: [f64; 3],
    pub radius: [f64; 3],
    pub omega: [f64; 3],
    pub tilt: [f64; 3],
    pub phase: [f64; 3],
    pub beta: [f64; 3],
    /// ∂a_k/∂d_k (the drift of axis k only moves axis k); offsets have derivative 1.
    pub drift: f64,
}

/// Evaluates the model: `out[k][i]` is axis k at `time_s[i]`, m/s².
///
/// On a uniform time grid the rotation is advanced by complex multiplication in blocks that are
/// re-anchored exactly, which is ~20× cheaper than a sine and cosine per sample and accurate to
/// ~1e-14; any other grid uses exact sin/cos per sample.
pub fn evaluate(
    session: &Session,
    mounting: &Mounting,
    gravity: f64,
    time_s: &[f64],
    out: &mut [Vec<f64>; 3],
) {
    for axis in out.iter_mut() {
        axis.resize(time_s.len(), 0.0);
    }
    for_each_sample(session, mounting, gravity, time_s, |i, a| {
        out[0][i] = a[0];
        out[1][i] = a[1];
        out[2][i] = a[2];
    });
}

/// The model's constant level per axis (centripetal term, tilt's share of g and offsets, m/s²) and
/// the amplitude g sin α of the oscillating gravity term.
pub fn levels(session: &Session, mounting: &Mounting, gravity: f64) -> ([f64; 3], f64) {
    let w = session.omega_radps;
    let centripetal = w * w * session.radius_m;
    let (sin_b, cos_b) = mounting.beta_rad.sin_cos();
    let mean = [
        centripetal * cos_b + mounting.offset_mps2[0],
        centripetal * sin_b + mounting.offset_mps2[1],
        gravity * session.tilt_rad.cos() + mounting.offset_mps2[2],
    ];
    (mean, gravity * session.tilt_rad.sin())
}

/// Calls `f(i, [a_x, a_y, a_z])` with the model at every sample, in order, without allocating.
pub(crate) fn for_each_sample(
    session: &Session,
    mounting: &Mounting,
    gravity: f64,
    time_s: &[f64],
    f: impl FnMut(usize, [f64; 3]),
) {
    for_each_sample_about(session, mounting, gravity, time_s, None, f)
}

/// [`for_each_sample`] with the drift measured from `drift_origin_s` (a segment of a recording
/// cut at a gap keeps the recording's), else from the middle of `time_s`.
pub(crate) fn for_each_sample_about(
    session: &Session,
    mounting: &Mounting,
    gravity: f64,
    time_s: &[f64],
    drift_origin_s: Option<f64>,
    mut f: impl FnMut(usize, [f64; 3]),
) {
    let (t0, t_mid) = time_origin(time_s);
    let t_mid = drift_origin_s.unwrap_or(t_mid);
    let s = session.direction.sign();
    let w = session.omega_radps;
    let (mean, amplitude) = levels(session, mounting, gravity);
    let d = session.drift_mps2_per_s;
    let offset = session.phase_rad - mounting.beta_rad;
    for_each_rotation(time_s, t0, w, offset, |i, sin_u, cos_u| {
        let dt = time_s[i] - t_mid;
        f(
            i,
            [
                mean[0] + amplitude * sin_u + d[0] * dt,
                mean[1] + s * amplitude * cos_u + d[1] * dt,
                mean[2] + d[2] * dt,
            ],
        );
    });
}

/// Calls `f(i, sin u_i, cos u_i)` for u_i = ω (t_i − t0) + offset, for every sample in order.
pub(crate) fn for_each_rotation(
    time_s: &[f64],
    t0: f64,
    omega: f64,
    offset: f64,
    mut f: impl FnMut(usize, f64, f64),
) {
    const BLOCK: usize = 64;
    let n = time_s.len();
    let uniform_step = uniform_step(time_s);
    match uniform_step {
        Some(step) => {
            let (sin_d, cos_d) = (omega * step).sin_cos();
            let mut start = 0;
            while start < n {
                let end = (start + BLOCK).min(n);
                let (mut s, mut c) = (omega * (time_s[start] - t0) + offset).sin_cos();
                for i in start..end {
                    f(i, s, c);
                    let next_s = s * cos_d + c * sin_d;
                    c = c * cos_d - s * sin_d;
                    s = next_s;
                }
                start = end;
            }
        }
        None => {
            for (i, t) in time_s.iter().enumerate() {
                let (s, c) = (omega * (t - t0) + offset).sin_cos();
                f(i, s, c);
            }
        }
    }
}

/// The step of a uniform grid (every sample within 1e-9 of the step of t0 + i·step), else `None`.
fn uniform_step(time_s: &[f64]) -> Option<f64> {
    let n = time_s.len();
    if n < 2 {
        return None;
    }
    let step = (time_s[n - 1] - time_s[0]) / (n - 1) as f64;
    let tolerance = 1e-9 * step.abs().max(1e-300) * 1e3;
    time_s
        .iter()
        .enumerate()
        .all(|(i, t)| (t - (time_s[0] + i as f64 * step)).abs() <= tolerance)
        .then_some(step)
}

/// First sample time and the middle of the recording (the drift's origin).
pub(crate) fn time_origin(time_s: &[f64]) -> (f64, f64) {
    match (time_s.first(), time_s.last()) {
        (Some(&a), Some(&b)) => (a, 0.5 * (a + b)),
        _ => (0.0, 0.0),
    }
}

/// Derivatives of the three axes at every sample: calls `f(i, &SampleDerivatives)`; the drift
/// about `drift_origin_s` as in [`for_each_sample_about`].
pub(crate) fn for_each_derivative(
    session: &Session,
    mounting: &Mounting,
    gravity: f64,
    time_s: &[f64],
    drift_origin_s: Option<f64>,
    mut f: impl FnMut(usize, &SampleDerivatives),
) {
    let (t0, t_mid) = time_origin(time_s);
    let t_mid = drift_origin_s.unwrap_or(t_mid);
    let s = session.direction.sign();
    let w = session.omega_radps;
    let r = session.radius_m;
    let (sin_b, cos_b) = mounting.beta_rad.sin_cos();
    let (sin_a, cos_a) = session.tilt_rad.sin_cos();
    let amplitude = gravity * sin_a;
    let centripetal = w * w * r;
    let offset = session.phase_rad - mounting.beta_rad;
    let (mean, _) = levels(session, mounting, gravity);
    let drift = session.drift_mps2_per_s;
    let mut d = SampleDerivatives {
        radius: [w * w * cos_b, w * w * sin_b, 0.0],
        tilt: [0.0, 0.0, -gravity * sin_a],
        ..Default::default()
    };
    for_each_rotation(time_s, t0, w, offset, |i, sin_u, cos_u| {
        let t = time_s[i] - t0;
        d.omega = [
            2.0 * w * r * cos_b + amplitude * cos_u * t,
            2.0 * w * r * sin_b - s * amplitude * sin_u * t,
            0.0,
        ];
        d.tilt[0] = gravity * cos_a * sin_u;
        d.tilt[1] = s * gravity * cos_a * cos_u;
        d.phase = [amplitude * cos_u, -s * amplitude * sin_u, 0.0];
        d.beta = [
            -centripetal * sin_b - amplitude * cos_u,
            centripetal * cos_b + s * amplitude * sin_u,
            0.0,
        ];
        d.drift = time_s[i] - t_mid;
        d.value = [
            mean[0] + amplitude * sin_u + drift[0] * d.drift,
            mean[1] + s * amplitude * cos_u + drift[1] * d.drift,
            mean[2] + drift[2] * d.drift,
        ];
        f(i, &d);
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    fn session() -> Session {
        Session {
            radius_m: 0.1,
            omega_radps: 3.49,
            tilt_rad: 5f64.to_radians(),
            phase_rad: 0.7,
            direction: Direction::Cw,
            drift_mps2_per_s: [1e-3, -2e-3, 5e-4],
        }
    }

    fn mounting() -> Mounting {
        Mounting {
            beta_rad: 0.3,
            offset_mps2: [0.05, -0.02, 0.1],
        }
    }

    fn grid(n: usize, rate: f64) -> Vec<f64> {
        (0..n).map(|i| 2.0 + i as f64 / rate).collect()
    }

    #[test]
    fn block_recurrence_equals_exact_trigonometry() {
        let t = grid(20_000, 100.0);
        let mut fast = [vec![], vec![], vec![]];
        evaluate(&session(), &mounting(), 9.81, &t, &mut fast);
        // A jittered copy of the grid forces the exact path; compare at the shared samples.
        let mut exact = [vec![], vec![], vec![]];
        let mut jittered = t.clone();
        jittered[1] += 1e-4;
        evaluate(&session(), &mounting(), 9.81, &jittered, &mut exact);
        for k in 0..3 {
            for i in (2..t.len()).step_by(97) {
                // t_mid is unchanged; only sample 1 moved.
                assert!((fast[k][i] - exact[k][i]).abs() < 1e-11, "axis {k} sample {i}");
            }
        }
    }

    #[test]
    fn matches_the_papers_equation_without_extras() {
        let s = Session {
            drift_mps2_per_s: [0.0; 3],
            phase_rad: 0.0,
            direction: Direction::Ccw,
            ..session()
        };
        let m = Mounting {
            beta_rad: 0.3,
            offset_mps2: [0.0; 3],
        };
        let t = grid(50, 10.0);
        let mut out = [vec![], vec![], vec![]];
        evaluate(&s, &m, 9.81, &t, &mut out);
        for (i, ti) in t.iter().enumerate() {
            let u = 3.49 * (ti - 2.0) - 0.3;
            let am = 3.49f64.powi(2) * 0.1;
            let a = 9.81 * 5f64.to_radians().sin();
            assert!((out[0][i] - (am * 0.3f64.cos() + a * u.sin())).abs() < 1e-12);
            assert!((out[1][i] - (am * 0.3f64.sin() + a * u.cos())).abs() < 1e-12);
        }
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        let t = grid(300, 50.0);
        let g = 9.81;
        let mut analytic = vec![SampleDerivatives::default(); t.len()];
        for_each_derivative(&session(), &mounting(), g, &t, None, |i, d| analytic[i] = *d);
        type Perturb = fn(&mut Session, &mut Mounting, f64);
        type Pick = fn(&SampleDerivatives) -> [f64; 3];
        let cases: [(&str, Perturb, Pick); 5] = [
            ("radius", |s, _, h| s.radius_m += h, |d| d.radius),
            ("omega", |s, _, h| s.omega_radps += h, |d| d.omega),
            ("tilt", |s, _, h| s.tilt_rad += h, |d| d.tilt),
            ("phase", |s, _, h| s.phase_rad += h, |d| d.phase),
            ("beta", |_, m, h| m.beta_rad += h, |d| d.beta),
        ];
        for (name, perturb, pick) in cases {
            let h = 1e-6;
            let (mut sp, mut mp) = (session(), mounting());
            perturb(&mut sp, &mut mp, h);
            let (mut sm, mut mm) = (session(), mounting());
            perturb(&mut sm, &mut mm, -h);
            let (mut up, mut down) = ([vec![], vec![], vec![]], [vec![], vec![], vec![]]);
            evaluate(&sp, &mp, g, &t, &mut up);
            evaluate(&sm, &mm, g, &t, &mut down);
            for i in 0..t.len() {
                for k in 0..3 {
                    let numeric = (up[k][i] - down[k][i]) / (2.0 * h);
                    let exact = pick(&analytic[i])[k];
                    assert!(
                        (numeric - exact).abs() <= 1e-6 * (1.0 + exact.abs()),
                        "{name} axis {k} sample {i}: {numeric} vs {exact}"
                    );
                }
            }
        }
        // Drift: d a_k / d d_k = t − t_mid.
        let mut s2 = session();
        s2.drift_mps2_per_s[1] += 1.0;
        let (mut base, mut moved) = ([vec![], vec![], vec![]], [vec![], vec![], vec![]]);
        evaluate(&session(), &mounting(), g, &t, &mut base);
        evaluate(&s2, &mounting(), g, &t, &mut moved);
        for i in 0..t.len() {
            assert!((moved[1][i] - base[1][i] - analytic[i].drift).abs() < 1e-9);
        }
    }
}
