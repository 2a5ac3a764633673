//! The model's geometry: mounting and mount-tilt rotations, a run's specific force and its
//! derivatives per sample, and a still pose's gravity direction.

// Per-axis and per-parameter arrays are indexed together; iterators would obscure that.
#![allow(clippy::needless_range_loop)]

use super::layout::GEOMETRY;
use crate::campaign::file::SignedAxis;
use crate::geometry::{apply, cross, dot, mul, unit, M3};

/// Body ← mounting-frame rotation: columns are `out`, `up × out` and `up` in sensor axes.
pub fn mounting_matrix(out: SignedAxis, up: SignedAxis) -> M3 {
    let o = out.vector();
    let u = up.vector();
    let y = cross(&u, &o);
    std::array::from_fn(|r| [o[r], y[r], u[r]])
}

fn rot_x(e: f64) -> (M3, M3) {
    let (s, c) = e.sin_cos();
    (
        [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]],
        [[0.0, 0.0, 0.0], [0.0, -s, -c], [0.0, c, -s]],
    )
}

fn rot_y(e: f64) -> (M3, M3) {
    let (s, c) = e.sin_cos();
    (
        [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]],
        [[-s, 0.0, c], [0.0, 0.0, 0.0], [-c, 0.0, -s]],
    )
}

fn rot_z(e: f64) -> (M3, M3) {
    let (s, c) = e.sin_cos();
    (
        [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]],
        [[-s, -c, 0.0], [c, -s, 0.0], [0.0, 0.0, 0.0]],
    )
}

/// The once-per-revolution terms at one instant (see [`RunGeometry::kinematics`]).
pub(super) struct Kinematics {
    /// sin and cos of ωτ.
    s1: f64,
    c1: f64,
    /// Relative speed change and its quadrature part.
    m: f64,
    m_quad: f64,
    pub(super) rate: f64,
    rate_dot: f64,
    /// sin and cos of ϑ.
    s: f64,
    c: f64,
    platter: [f64; 3],
}

/// A run's geometry at given parameters: f_B and its derivatives per sample.
///
/// Wow (a once-per-revolution speed change) is modelled because it shares the rotation's
/// frequency with the tilt's gravity term: ω(τ) = ω (1 + w_c cos ωτ + w_s sin ωτ). It moves the
/// platter angle, the centripetal level and adds the tangential acceleration r ω̇.
pub(crate) struct RunGeometry {
    qr: M3,
    d_beta: M3,
    d_eps1: M3,
    d_eps2: M3,
    radius: f64,
    pub(super) omega: f64,
    sin_tilt: f64,
    cos_tilt: f64,
    /// sin and cos of the phase ϑ₀.
    sin_phase: f64,
    cos_phase: f64,
    wow: [f64; 2],
    direction: f64,
    gravity: f64,
}

impl RunGeometry {
    pub(crate) fn new(q: &M3, run: &[f64], direction: f64, gravity: f64) -> RunGeometry {
        let (rx, drx) = rot_x(run[5]);
        let (ry, dry) = rot_y(run[6]);
        let (rz, drz) = rot_z(run[4]);
        let qrx = mul(q, &rx);
        let qdrx = mul(q, &drx);
        RunGeometry {
            qr: mul(&mul(&qrx, &ry), &rz),
            d_beta: mul(&mul(&qrx, &ry), &drz),
            d_eps1: mul(&mul(&qdrx, &ry), &rz),
            d_eps2: mul(&mul(&qrx, &dry), &rz),
            radius: run[0],
            omega: run[1],
            sin_tilt: run[2].sin(),
            cos_tilt: run[2].cos(),
            sin_phase: run[3].sin(),
            cos_phase: run[3].cos(),
            wow: [run[7], run[8]],
            direction,
            gravity,
        }
    }

    /// The platter turns at σ ω(τ) about the spindle, the mounting frame's third axis (β turns
    /// about it and so leaves it alone): this is σ times that axis in the body frame.
    pub(super) fn angular_rate_direction(&self) -> [f64; 3] {
        std::array::from_fn(|r| self.direction * self.qr[r][2])
    }

    /// True specific force in the body frame at τ (seconds from the run's middle).
    pub(crate) fn force(&self, tau: f64) -> [f64; 3] {
        apply(&self.qr, &self.kinematics(tau).platter)
    }

    /// [`RunGeometry::force`] given sin ωτ and cos ωτ.
    #[inline(always)]
    pub(super) fn force_at(&self, s1: f64, c1: f64) -> [f64; 3] {
        apply(&self.qr, &self.kinematics_at(s1, c1).platter)
    }

    /// The platter's motion at τ and the specific force in the platter frame.
    pub(super) fn kinematics(&self, tau: f64) -> Kinematics {
        let (s1, c1) = (self.omega * tau).sin_cos();
        self.kinematics_at(s1, c1)
    }

    /// [`RunGeometry::kinematics`] given sin ωτ and cos ωτ (from a recurrence over the samples).
    #[inline(always)]
    fn kinematics_at(&self, s1: f64, c1: f64) -> Kinematics {
        let (g, w, r, sigma) = (self.gravity, self.omega, self.radius, self.direction);
        let [wc, ws] = self.wow;
        let m = wc * c1 + ws * s1;
        let m_quad = -wc * s1 + ws * c1;
        let rate = w * (1.0 + m);
        let rate_dot = w * w * m_quad;
        // The platter angle ϑ₀ − σ(ωτ + w_c sin ωτ − w_s cos ωτ), from sin ωτ and cos ωτ and a
        // rotation by the wow term, which is small: no second sine and cosine of a large angle
        // per sample (they were a fifth of the joint fit's time).
        let (s0, c0) = (
            self.sin_phase * c1 - sigma * self.cos_phase * s1,
            self.cos_phase * c1 + sigma * self.sin_phase * s1,
        );
        let (sd, cd) = small_sin_cos(-sigma * (wc * s1 - ws * c1));
        let (s, c) = (s0 * cd + c0 * sd, c0 * cd - s0 * sd);
        let amplitude = g * self.sin_tilt;
        Kinematics {
            s1,
            c1,
            m,
            m_quad,
            rate,
            rate_dot,
            s,
            c,
            platter: [
                -rate * rate * r + amplitude * c,
                amplitude * s + sigma * r * rate_dot,
                g * self.cos_tilt,
            ],
        }
    }

    /// f_B and ∂f_B/∂(r, ω, α, ϑ₀, β, ε₁, ε₂, w_c, w_s).
    #[cfg(test)]
    fn force_and_derivatives(&self, tau: f64) -> ([f64; 3], [[f64; 3]; GEOMETRY]) {
        let (s1, c1) = (self.omega * tau).sin_cos();
        self.force_and_derivatives_at(tau, s1, c1)
    }

    /// [`RunGeometry::force_and_derivatives`] given sin ωτ and cos ωτ.
    #[inline(always)]
    pub(super) fn force_and_derivatives_at(
        &self,
        tau: f64,
        s1: f64,
        c1: f64,
    ) -> ([f64; 3], [[f64; 3]; GEOMETRY]) {
        let (g, w, r, sigma) = (self.gravity, self.omega, self.radius, self.direction);
        let Kinematics {
            s1,
            c1,
            m,
            m_quad,
            rate,
            rate_dot,
            s,
            c,
            platter: fp,
        } = self.kinematics_at(s1, c1);
        let amplitude = g * self.sin_tilt;
        // ∂/∂ω through the rate, the angle and ω̇.
        let d_rate = (1.0 + m) + w * tau * m_quad;
        let d_angle = tau * (1.0 + m);
        let d_rate_dot = 2.0 * w * m_quad - w * w * tau * m;
        let dp = [
            [-rate * rate, sigma * rate_dot, 0.0],
            [
                -2.0 * rate * r * d_rate + amplitude * s * sigma * d_angle,
                -amplitude * c * sigma * d_angle + sigma * r * d_rate_dot,
                0.0,
            ],
            [g * self.cos_tilt * c, g * self.cos_tilt * s, -g * self.sin_tilt],
            [-amplitude * s, amplitude * c, 0.0],
            [
                -2.0 * rate * r * w * c1 + amplitude * s * sigma * s1,
                -amplitude * c * sigma * s1 - sigma * r * w * w * s1,
                0.0,
            ],
            [
                -2.0 * rate * r * w * s1 - amplitude * s * sigma * c1,
                amplitude * c * sigma * c1 + sigma * r * w * w * c1,
                0.0,
            ],
        ];
        let mut d = [[0.0; 3]; GEOMETRY];
        for k in 0..4 {
            d[k] = apply(&self.qr, &dp[k]);
        }
        d[4] = apply(&self.d_beta, &fp);
        d[5] = apply(&self.d_eps1, &fp);
        d[6] = apply(&self.d_eps2, &fp);
        d[7] = apply(&self.qr, &dp[4]);
        d[8] = apply(&self.qr, &dp[5]);
        (apply(&self.qr, &fp), d)
    }
}

/// sin and cos of `x`: by their Taylor series to x⁶ when |x| < 1e-3 (the next terms are below
/// 1e-22, far under a double's rounding), by `sin_cos` otherwise.
#[inline(always)]
fn small_sin_cos(x: f64) -> (f64, f64) {
    if x.abs() < 1e-3 {
        let x2 = x * x;
        (
            x * (1.0 - x2 / 6.0 * (1.0 - x2 / 20.0)),
            1.0 - x2 / 2.0 * (1.0 - x2 / 12.0 * (1.0 - x2 / 30.0)),
        )
    } else {
        x.sin_cos()
    }
}

/// A pose's gravity direction: w₀ and a tangent basis.
#[derive(Debug, Clone, Copy)]
pub(crate) struct PoseFrame {
    w0: [f64; 3],
    e1: [f64; 3],
    e2: [f64; 3],
}

impl PoseFrame {
    pub(super) fn new(mean: [f64; 3]) -> PoseFrame {
        let norm = (mean[0] * mean[0] + mean[1] * mean[1] + mean[2] * mean[2]).sqrt();
        let w0 = if norm > 0.0 {
            mean.map(|v| v / norm)
        } else {
            [0.0, 0.0, 1.0]
        };
        // The axis least aligned with w₀ makes a well-conditioned tangent basis.
        let k = (0..3)
            .min_by(|&a, &b| w0[a].abs().total_cmp(&w0[b].abs()))
            .unwrap_or(0);
        let mut a = [0.0; 3];
        a[k] = 1.0;
        let along = dot(&a, &w0);
        let e1 = unit([a[0] - along * w0[0], a[1] - along * w0[1], a[2] - along * w0[2]]);
        let e2 = cross(&w0, &e1);
        PoseFrame { w0, e1, e2 }
    }

    /// g ŵ and its derivatives with respect to the two angles.
    pub(super) fn force(&self, a: f64, b: f64, g: f64) -> ([f64; 3], [[f64; 3]; 2]) {
        let w: [f64; 3] = std::array::from_fn(|k| self.w0[k] + a * self.e1[k] + b * self.e2[k]);
        let norm = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
        let hat = w.map(|v| v / norm);
        let d = |e: &[f64; 3]| -> [f64; 3] {
            let dot = hat[0] * e[0] + hat[1] * e[1] + hat[2] * e[2];
            std::array::from_fn(|k| g * (e[k] - dot * hat[k]) / norm)
        };
        (hat.map(|v| g * v), [d(&self.e1), d(&self.e2)])
    }
}

/// The body ← platter rotation Q·Rx(ε₁)Ry(ε₂)Rz(β) of a run's parameters.
pub(crate) fn rotation_of(q: &M3, run: &[f64]) -> M3 {
    RunGeometry::new(q, run, 1.0, 1.0).qr
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mounting_matrix_is_a_right_handed_rotation() {
        for out in ["+x", "-x", "+y", "-y", "+z", "-z"] {
            for up in ["+x", "-x", "+y", "-y", "+z", "-z"] {
                let (o, u) = (SignedAxis::parse(out).unwrap(), SignedAxis::parse(up).unwrap());
                if o.axis == u.axis {
                    continue;
                }
                let q = mounting_matrix(o, u);
                let det = q[0][0] * (q[1][1] * q[2][2] - q[1][2] * q[2][1])
                    - q[0][1] * (q[1][0] * q[2][2] - q[1][2] * q[2][0])
                    + q[0][2] * (q[1][0] * q[2][1] - q[1][1] * q[2][0]);
                assert_eq!(det, 1.0, "{out} {up}");
                assert_eq!(apply(&q, &[1.0, 0.0, 0.0]), o.vector());
                assert_eq!(apply(&q, &[0.0, 0.0, 1.0]), u.vector());
            }
        }
    }

    /// The platter angle's sine and cosine, built from sin ωτ, cos ωτ and the small wow rotation,
    /// equal a direct `sin_cos` of the whole angle, for small and large wow, both senses and long
    /// recordings (large ωτ).
    #[test]
    fn platter_angle_from_the_rotation_equals_direct_trigonometry() {
        let q = mounting_matrix(SignedAxis::parse("+x").unwrap(), SignedAxis::parse("+z").unwrap());
        for (wc, ws) in [(0.0, 0.0), (2e-4, -3e-4), (7e-4, 6e-4), (0.02, -0.01), (0.3, 0.2)] {
            for sigma in [1.0, -1.0] {
                for phase in [-2.9, 0.0, 0.4, 3.1] {
                    let run = [0.1, 4.71, 0.01, phase, 0.0, 0.0, 0.0, wc, ws, 0.0, 0.0, 0.0];
                    let geo = RunGeometry::new(&q, &run, sigma, 9.81);
                    for tau in [-3600.0, -61.3, -0.01, 0.0, 0.37, 59.9, 7200.5] {
                        let k = geo.kinematics(tau);
                        let w = 4.71;
                        let (s1, c1) = (w * tau).sin_cos();
                        let angle = w * tau + wc * s1 - ws * c1;
                        let (s, c) = (phase - sigma * angle).sin_cos();
                        // The direct form rounds ωτ (up to 3e4 rad) before its sine: ~1e-12.
                        let tolerance = 1e-15 * (w * tau).abs().max(1.0) * 4.0;
                        assert!(
                            (k.s - s).abs() < tolerance && (k.c - c).abs() < tolerance,
                            "{wc} {ws} {sigma} {phase} {tau}: {} {} vs {s} {c}",
                            k.s,
                            k.c
                        );
                    }
                }
            }
        }
        for x in [-9.99e-4, -1e-5, 0.0, 3e-7, 5e-4, 9.99e-4] {
            let (s, c) = small_sin_cos(x);
            assert!(
                (s - x.sin()).abs() <= 2.3e-16 * x.abs() && (c - x.cos()).abs() <= 2.3e-16,
                "{x}"
            );
        }
    }

    #[test]
    fn run_derivatives_match_finite_differences() {
        let q = mounting_matrix(SignedAxis::parse("-y").unwrap(), SignedAxis::parse("+x").unwrap());
        let base = [
            0.09, 3.5, 0.02, 0.7, 0.3, 0.01, -0.02, 0.002, -0.001, 0.0, 0.0, 0.0,
        ];
        let tau = 3.7;
        let (_, d) = RunGeometry::new(&q, &base, -1.0, 9.81).force_and_derivatives(tau);
        for j in 0..GEOMETRY {
            let h = 1e-6;
            let mut plus = base;
            let mut minus = base;
            plus[j] += h;
            minus[j] -= h;
            let fp = RunGeometry::new(&q, &plus, -1.0, 9.81).force(tau);
            let fm = RunGeometry::new(&q, &minus, -1.0, 9.81).force(tau);
            for k in 0..3 {
                let numeric = (fp[k] - fm[k]) / (2.0 * h);
                assert!(
                    (numeric - d[j][k]).abs() < 1e-6,
                    "param {j} axis {k}: {numeric} vs {}",
                    d[j][k]
                );
            }
        }
    }

    #[test]
    fn pose_derivatives_match_finite_differences() {
        let frame = PoseFrame::new([0.3, -9.7, 1.1]);
        let (_, d) = frame.force(0.02, -0.01, 9.81);
        for j in 0..2 {
            let h = 1e-7;
            let at = |x: f64| {
                let (a, b) = if j == 0 {
                    (0.02 + x, -0.01)
                } else {
                    (0.02, -0.01 + x)
                };
                frame.force(a, b, 9.81).0
            };
            let (fp, fm) = (at(h), at(-h));
            for k in 0..3 {
                assert!(((fp[k] - fm[k]) / (2.0 * h) - d[j][k]).abs() < 1e-6);
            }
        }
    }
}
