//! Small 3-D algebra shared across the crate: 3×3 matrices, 3-vectors and unit quaternions.
//! Each helper keeps the operation order of the copies it replaced, so results are bit-identical.

// 3×3 algebra reads best with indices.
#![allow(clippy::needless_range_loop)]

/// A 3×3 matrix, row-major: `m[row][column]`.
pub(crate) type M3 = [[f64; 3]; 3];

/// A unit quaternion, scalar first.
pub(crate) type Quat = [f64; 4];

pub(crate) const IDENTITY: M3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// The matrix whose rows are `v[0..3]`, `v[3..6]`, `v[6..9]`.
pub(crate) fn from_row_major(v: &[f64]) -> M3 {
    std::array::from_fn(|i| std::array::from_fn(|j| v[3 * i + j]))
}

/// The product a·b.
pub(crate) fn mul(a: &M3, b: &M3) -> M3 {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

/// aᵀ.
pub(crate) fn transpose(a: &M3) -> M3 {
    std::array::from_fn(|i| std::array::from_fn(|j| a[j][i]))
}

/// a·v.
pub(crate) fn apply(a: &M3, v: &[f64; 3]) -> [f64; 3] {
    std::array::from_fn(|i| a[i][0] * v[0] + a[i][1] * v[1] + a[i][2] * v[2])
}

pub(crate) fn determinant(a: &M3) -> f64 {
    a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
        + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
}

/// The inverse of a 3×3 matrix; `None` when it is (nearly) singular.
pub(crate) fn inverse(a: &M3) -> Option<M3> {
    let det = determinant(a);
    if !(det.is_finite() && det.abs() > 1e-12) {
        return None;
    }
    let c = |i: usize, j: usize| {
        let (r0, r1) = ((i + 1) % 3, (i + 2) % 3);
        let (c0, c1) = ((j + 1) % 3, (j + 2) % 3);
        a[r0][c0] * a[r1][c1] - a[r0][c1] * a[r1][c0]
    };
    // Cyclic cofactors carry their sign; the inverse is the transposed cofactor matrix over det.
    Some(std::array::from_fn(|i| std::array::from_fn(|j| c(j, i) / det)))
}

pub(crate) fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(crate) fn cross(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// |v|.
pub(crate) fn norm(v: &[f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// v / |v|.
pub(crate) fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = norm(&v);
    v.map(|x| x / n)
}

/// Point `i` of `n` directions evenly spread over the sphere (a Fibonacci lattice), a unit vector.
pub(crate) fn lattice_direction(i: usize, n: usize) -> [f64; 3] {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let z = 1.0 - (2.0 * i as f64 + 1.0) / n.max(1) as f64;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = golden * i as f64;
    [r * phi.cos(), r * phi.sin(), z]
}

/// Hamilton product a ⊗ b (scalar first).
pub(crate) fn quat_mul(a: &Quat, b: &Quat) -> Quat {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

/// The unit quaternion of the rotation vector `phi` (rad).
pub(crate) fn quat_exp(phi: [f64; 3]) -> Quat {
    let angle = dot(&phi, &phi).sqrt();
    let half = 0.5 * angle;
    // sin(x/2)/x, its series below 1e-4 rad.
    let k = if angle < 1e-4 {
        0.5 - angle * angle / 48.0
    } else {
        half.sin() / angle
    };
    [half.cos(), k * phi[0], k * phi[1], k * phi[2]]
}

/// q v q*: `v` in the frame `q` maps from into the frame it maps to.
pub(crate) fn rotate(q: &Quat, v: [f64; 3]) -> [f64; 3] {
    let p = quat_mul(
        &quat_mul(q, &[0.0, v[0], v[1], v[2]]),
        &[q[0], -q[1], -q[2], -q[3]],
    );
    [p[1], p[2], p[3]]
}

/// q* v q, the inverse rotation.
pub(crate) fn rotate_inverse(q: &Quat, v: [f64; 3]) -> [f64; 3] {
    rotate(&[q[0], -q[1], -q[2], -q[3]], v)
}
