//! Amplitude-invariant Clarke transforms in f64, between phase quantities `(a, b, c)` and
//! the stationary frame `(α, β)`.

use num_traits::Float;

/// Amplitude-invariant Clarke in f64.
pub fn clarke(x: [f64; 3]) -> (f64, f64) {
    (
        (2.0 * x[0] - x[1] - x[2]) / 3.0,
        (x[1] - x[2]) / Float::sqrt(3f64),
    )
}

/// Inverse amplitude-invariant Clarke in f64.
pub fn inverse_clarke(alpha: f64, beta: f64) -> [f64; 3] {
    let s3 = Float::sqrt(3f64) / 2.0;
    [alpha, -0.5 * alpha + s3 * beta, -0.5 * alpha - s3 * beta]
}
