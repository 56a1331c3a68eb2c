//! Small 3×3 helpers for rotations: products, the hat map, Rodrigues' formula, quaternions.
//!
//! Matrices are `[[f64; 3]; 3]` indexed `[row][column]`. A body's rotation `R` maps body
//! coordinates to space coordinates; its columns are the body axes seen in space.

/// A 3×3 matrix, `[row][column]`.
pub type Mat3 = [[f64; 3]; 3];

/// The identity.
pub const IDENTITY: Mat3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// `a b`.
#[must_use]
pub fn mul(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut out = [[0.0; 3]; 3];
    for (i, row) in out.iter_mut().enumerate() {
        for (j, x) in row.iter_mut().enumerate() {
            *x = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    out
}

/// `aᵀ`.
#[must_use]
pub fn transpose(a: &Mat3) -> Mat3 {
    let mut out = [[0.0; 3]; 3];
    for (i, row) in out.iter_mut().enumerate() {
        for (j, x) in row.iter_mut().enumerate() {
            *x = a[j][i];
        }
    }
    out
}

/// `a v`.
#[must_use]
pub fn apply(a: &Mat3, v: &[f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| (0..3).map(|k| a[i][k] * v[k]).sum())
}

/// `a · b`.
#[must_use]
pub fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `a × b`.
#[must_use]
pub fn cross(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// The hat map: `hat(w) v = w × v`.
#[must_use]
pub fn hat(w: &[f64; 3]) -> Mat3 {
    [[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]]
}

/// The inverse of the hat map on the skew part: `vee(A) = ((A₃₂ − A₂₃)/2, (A₁₃ − A₃₁)/2,
/// (A₂₁ − A₁₂)/2)`, so `vee(hat(w)) = w`.
#[must_use]
pub fn vee(a: &Mat3) -> [f64; 3] {
    [
        0.5 * (a[2][1] - a[1][2]),
        0.5 * (a[0][2] - a[2][0]),
        0.5 * (a[1][0] - a[0][1]),
    ]
}

/// `exp(hat(w))` by Rodrigues' formula: the rotation by `|w|` about `w/|w|`.
#[must_use]
pub fn exp(w: &[f64; 3]) -> Mat3 {
    let theta2 = dot(w, w);
    let theta = theta2.sqrt();
    // sin θ/θ and (1 − cos θ)/θ², by their series near 0 (relative error below 1e-16 there).
    let (a, b) = if theta < 1e-4 {
        (1.0 - theta2 / 6.0, 0.5 - theta2 / 24.0)
    } else {
        (theta.sin() / theta, (1.0 - theta.cos()) / theta2)
    };
    let k = hat(w);
    let k2 = mul(&k, &k);
    let mut out = IDENTITY;
    for i in 0..3 {
        for j in 0..3 {
            out[i][j] += a * k[i][j] + b * k2[i][j];
        }
    }
    out
}

/// The rotation of the unit quaternion `(w, x, y, z)` (normalised here).
#[must_use]
pub fn from_quaternion(q: [f64; 4]) -> Mat3 {
    let n = q.iter().map(|c| c * c).sum::<f64>().sqrt();
    let [w, x, y, z] = q.map(|c| c / n);
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ]
}

/// The rotation by `angle` about the unit vector `axis` (normalised here).
#[must_use]
pub fn from_axis_angle(axis: [f64; 3], angle: f64) -> Mat3 {
    let n = dot(&axis, &axis).sqrt();
    exp(&axis.map(|c| c * angle / n))
}

/// `‖RᵀR − I‖_max`: how far `r` is from an orthogonal matrix.
#[must_use]
pub fn orthonormality_error(r: &Mat3) -> f64 {
    let rtr = mul(&transpose(r), r);
    let mut worst: f64 = 0.0;
    for (i, row) in rtr.iter().enumerate() {
        for (j, x) in row.iter().enumerate() {
            worst = worst.max((x - IDENTITY[i][j]).abs());
        }
    }
    worst
}

/// `det(a)`.
#[must_use]
pub fn det(a: &Mat3) -> f64 {
    dot(&a[0], &cross(&a[1], &a[2]))
}

/// A unit vector perpendicular to the unit vector `n`: the coordinate axis least aligned with `n`
/// (the first of equals), with its component along `n` removed. For `n = e_z` it is `e_x`, for
/// `n = e_y` also `e_x`, for `n = e_x` it is `e_y`.
#[must_use]
pub fn perpendicular(n: &[f64; 3]) -> [f64; 3] {
    let k = (0..3)
        .min_by(|&a, &b| n[a].abs().total_cmp(&n[b].abs()))
        .unwrap_or(0);
    let mut e = [0.0; 3];
    e[k] = 1.0;
    let along = dot(&e, n);
    let c = [0, 1, 2].map(|i| e[i] - along * n[i]);
    let l = dot(&c, &c).sqrt();
    c.map(|x| x / l)
}

/// The rotation whose third column is the unit vector along `axis`: columns
/// `(p, axis × p, axis)` with `p` from [`perpendicular`] (so `frame_with_z(e_z)` is the identity).
#[must_use]
pub fn frame_with_z(axis: [f64; 3]) -> Mat3 {
    let l = dot(&axis, &axis).sqrt();
    let z = axis.map(|c| c / l);
    frame_with_zx(z, perpendicular(&z))
}

/// The rotation whose third column is along `z` and whose first column is `x` with its component
/// along `z` removed (both normalised here); `x` must not be parallel to `z`.
#[must_use]
pub fn frame_with_zx(z: [f64; 3], x: [f64; 3]) -> Mat3 {
    let lz = dot(&z, &z).sqrt();
    let z = z.map(|c| c / lz);
    let along = dot(&x, &z);
    let x = [0, 1, 2].map(|i| x[i] - along * z[i]);
    let lx = dot(&x, &x).sqrt();
    let x = x.map(|c| c / lx);
    let y = cross(&z, &x);
    [[x[0], y[0], z[0]], [x[1], y[1], z[1]], [x[2], y[2], z[2]]]
}

#[cfg(test)]
mod tests {
    //! Rodrigues' formula against the quaternion of the same rotation, the hat/vee pair, and the
    //! frames built around an axis. Exact identities, so the tolerance is a few ulps.

    use super::*;

    /// Round-off allowance for order-one entries after a few products.
    const ULPS: f64 = 1e-15;

    #[test]
    fn rodrigues_matches_the_quaternion_and_stays_orthonormal() {
        let axis = [0.3, -0.5, 0.81];
        let n = dot(&axis, &axis).sqrt();
        for angle in [1e-6, 0.3, 2.0, 3.1] {
            let r = from_axis_angle(axis, angle);
            let (s, c) = (0.5 * angle).sin_cos();
            let q = from_quaternion([c, s * axis[0] / n, s * axis[1] / n, s * axis[2] / n]);
            for i in 0..3 {
                for j in 0..3 {
                    assert!((r[i][j] - q[i][j]).abs() < 4.0 * ULPS, "{angle}: {i}{j}");
                }
            }
            assert!(orthonormality_error(&r) < 4.0 * ULPS);
            assert!((det(&r) - 1.0).abs() < 4.0 * ULPS);
        }
        let w = [0.2, -1.3, 0.7];
        assert_eq!(vee(&hat(&w)), w);
        let v = [1.0, 2.0, -0.5];
        assert_eq!(apply(&hat(&w), &v), cross(&w, &v));
    }

    #[test]
    fn frame_with_z_is_a_right_handed_rotation() {
        assert_eq!(frame_with_z([0.0, 0.0, 2.0]), IDENTITY);
        for axis in [[0.0, 0.0, 1.0], [1.0, 1.0, 0.0], [-0.2, 0.9, 0.1]] {
            let f = frame_with_z(axis);
            assert!(orthonormality_error(&f) < ULPS);
            assert!((det(&f) - 1.0).abs() < ULPS);
            let l = dot(&axis, &axis).sqrt();
            for (i, a) in axis.iter().enumerate() {
                assert!((f[i][2] - a / l).abs() < ULPS);
            }
        }
    }
}
