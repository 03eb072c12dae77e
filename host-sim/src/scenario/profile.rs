//! Piecewise-linear time profiles for commands and loads: steps, ramps, windows.

use serde::Serialize;

/// A piecewise-linear function of time given by breakpoints `(t \[s], value)`, sorted by time.
/// Two breakpoints at the same time make a step. Before the first and after the last
/// breakpoint the value is held.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Pwl {
    points: Vec<(f64, f64)>,
}

impl Pwl {
    /// A profile from breakpoints; panics only on programmer error (unsorted or empty input),
    /// which scenario definitions rule out and unit tests check.
    pub fn new(points: Vec<(f64, f64)>) -> Self {
        assert!(
            !points.is_empty(),
            "a profile needs at least one breakpoint"
        );
        assert!(
            points.windows(2).all(|w| w[0].0 <= w[1].0),
            "profile breakpoints must be sorted by time"
        );
        Self { points }
    }

    /// A constant value.
    pub fn constant(v: f64) -> Self {
        Self::new(vec![(0.0, v)])
    }

    /// A ramp from `v0` at `t0` to `v1` at `t1`, held before and after.
    pub fn ramp(t0: f64, v0: f64, t1: f64, v1: f64) -> Self {
        Self::new(vec![(t0, v0), (t1, v1)])
    }

    /// `level` between `t0` and `t1`, zero outside (a load window).
    pub fn window(t0: f64, t1: f64, level: f64) -> Self {
        Self::new(vec![(t0, 0.0), (t0, level), (t1, level), (t1, 0.0)])
    }

    /// A step from 0 to `level` at `t0`.
    pub fn step(t0: f64, level: f64) -> Self {
        Self::new(vec![(t0, 0.0), (t0, level)])
    }

    /// The value at time `t`; at a step the later breakpoint wins (right-continuous).
    pub fn at(&self, t: f64) -> f64 {
        let p = &self.points;
        let k = p.partition_point(|&(tk, _)| tk <= t);
        if k == 0 {
            return p[0].1;
        }
        if k == p.len() {
            return p[k - 1].1;
        }
        let (t0, v0) = p[k - 1];
        let (t1, v1) = p[k];
        v0 + (v1 - v0) * (t - t0) / (t1 - t0)
    }

    /// The same profile with every value multiplied by `k`.
    pub fn scaled(&self, k: f64) -> Self {
        Self::new(self.points.iter().map(|&(t, v)| (t, v * k)).collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ramp_then_hold() {
        let p = Pwl::ramp(0.0, 0.0, 1.5, 1000.0);
        assert_eq!(p.at(-1.0), 0.0);
        assert!((p.at(0.75) - 500.0).abs() < 1e-9);
        assert_eq!(p.at(1.5), 1000.0);
        assert_eq!(p.at(6.0), 1000.0);
    }

    #[test]
    fn window_is_right_continuous() {
        let p = Pwl::window(3.0, 5.0, 0.2);
        assert_eq!(p.at(2.999), 0.0);
        assert_eq!(p.at(3.0), 0.2);
        assert_eq!(p.at(4.0), 0.2);
        assert_eq!(p.at(5.0), 0.0);
        assert_eq!(p.scaled(2.0).at(4.0), 0.4);
    }
}
