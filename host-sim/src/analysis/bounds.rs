//! Discrete-time upper bound `(K_s,max)_T` of the sliding gain (Horng & Chin Sec 4).
//!
//! The linearised error dynamics around the first equilibrium, eqs (46)-(50), in the states
//! `x = (S_a, S_b, e_θ, e_ω, e_τ)` (θ, ω mechanical), are evaluated at a plant steady state
//! (step 6: `i_d = 0`, `i_q = (Bω + τ_L)/(KN)`). With the delta transform the discrete system
//! at sample period T is stable iff every eigenvalue `p` satisfies `(T/2)|p|² + Re p < 0`
//! (a circle of radius 1/T centred at −1/T). `(K_s,max)_T` is the upper end of the K_s
//! interval in which that holds. The velocity observer is the same system without `e_τ`
//! (λτ = 0, K3 = 0).

use nalgebra::{Complex, DMatrix};
use pmsm_plant::PlantParams;
use pmsm_sensorless::motor::MotorParams;
use std::f64::consts::TAU;

/// An operating point and the observer's tuning, in f64 SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OperatingPoint {
    /// Motor (N, R, L, K = ψ, H = J, B).
    pub motor: PlantParams,
    /// Rotor speed, mechanical \[rad/s], ≠ 0.
    pub omega: f64,
    /// Load torque \[N·m].
    pub load_nm: f64,
    /// Electrical angle Nθ at which the frozen-time matrix is built \[rad].
    pub theta_e: f64,
    /// λθ, λω, λτ \[rad/s] (λτ = 0: velocity observer).
    pub lambdas: [f64; 3],
    /// Boundary layer ε \[A].
    pub epsilon: f64,
}

impl OperatingPoint {
    /// The paper's tuning (λθ = 10 Hz, λω = 60 Hz, λτ = 2 Hz or 0, ε = 1 A) for `motor` at
    /// `omega` [rad/s mechanical] and `load_nm`, in the paper's model of the motor
    /// (`MotorParams::papers_model`: J, B and the load over the torque factor).
    pub fn paper(motor: &MotorParams, omega: f64, load_nm: f64, torque_observer: bool) -> Self {
        let l_tau = if torque_observer { 2.0 } else { 0.0 };
        Self {
            motor: PlantParams::from(&motor.papers_model()),
            omega,
            load_nm: load_nm / f64::from(motor.torque.factor()),
            theta_e: 0.3,
            lambdas: [10.0 * TAU, 60.0 * TAU, l_tau * TAU],
            epsilon: 1.0,
        }
    }

    /// True when the torque state `e_τ` is part of the system (λτ > 0).
    pub fn has_torque(&self) -> bool {
        self.lambdas[2] > 0.0
    }

    /// `(K1, K2, K3)` of Sec 4 step 3.
    fn k123(&self) -> (f64, f64, f64) {
        let [a, b, c] = self.lambdas;
        (a + b + c, a * b + b * c + c * a, a * b * c)
    }

    /// Plant phase currents `(i_a, i_b)` of step 6 at this point \[A].
    pub fn currents(&self) -> (f64, f64) {
        let m = &self.motor;
        let i_q = (m.b * self.omega + self.load_nm) / (m.flux * m.n);
        let (s, c) = self.theta_e.sin_cos();
        (-i_q * s, i_q * c)
    }

    /// The matrix of eqs (46)-(50) at sliding gain `ks` \[A/s]: 5×5 for the torque observer,
    /// 4×4 `(S_a, S_b, e_θ, e_ω)` for the velocity observer.
    pub fn error_matrix(&self, ks: f64) -> DMatrix<f64> {
        let PlantParams {
            n,
            r,
            l_d,
            flux: k,
            j: h,
            b,
            ..
        } = self.motor;
        // The papers' machine is non-salient (built from `MotorParams`): L = L_d = L_q.
        let l = l_d.l0_h;
        let (w, eps) = (self.omega, self.epsilon);
        let (k1, k2, k3) = self.k123();
        let (s, c) = self.theta_e.sin_cos();
        let (i_a, i_b) = self.currents();
        let i_d = i_a * c + i_b * s;
        let kn = k * n;
        let fast = -(r / l + ks / eps);
        let dim = if self.has_torque() { 5 } else { 4 };
        let mut m = DMatrix::zeros(dim, dim);
        // (46), (47)
        m[(0, 0)] = fast;
        m[(0, 2)] = kn / l * n * w * c;
        m[(0, 3)] = kn / l * s;
        m[(1, 1)] = fast;
        m[(1, 2)] = kn / l * n * w * s;
        m[(1, 3)] = -kn / l * c;
        // (48)
        m[(2, 3)] = 1.0;
        // (49)
        let p = ks * l / (kn * eps) * (b / h - k1);
        let q = ks * l / (h * eps * w) * i_d;
        let u = ks * l / (kn * n * eps * w) * (-k2 + k3 / (n * w));
        m[(3, 0)] = -kn / h * s + p * s + q * c + u * c;
        m[(3, 1)] = kn / h * c - p * c + q * s + u * s;
        m[(3, 2)] = -kn * n / h * i_d;
        m[(3, 3)] = -b / h;
        if dim == 5 {
            m[(3, 4)] = -1.0 / h;
            // (50)
            let g = k3 * ks * h * l / (kn * n * eps * w);
            m[(4, 0)] = g * (c + s);
            m[(4, 1)] = g * (s - c);
        }
        m
    }

    /// The matrix of eqs (51)-(55) around the second equilibrium (44)-(45) (M = 0), as
    /// printed, states `(S_a, S_b, e_θ, e_ω, e_τ)`; torque observer only. Eq (55) ends with
    /// the term `−2HLK3K_s/(Rε + LK_s)` and no state: it has the units of `ė_τ` per radian,
    /// so it is read as the coefficient of `e_θ` (the typesetting lost the state).
    pub fn second_equilibrium_matrix(&self, ks: f64) -> DMatrix<f64> {
        let PlantParams {
            n,
            r,
            l_d,
            flux: k,
            j: h,
            b,
            ..
        } = self.motor;
        // The papers' machine is non-salient (built from `MotorParams`): L = L_d = L_q.
        let l = l_d.l0_h;
        let (w, eps) = (self.omega, self.epsilon);
        let (k1, k2, k3) = self.k123();
        let (s, c) = self.theta_e.sin_cos();
        let (s2, c2) = (2.0 * self.theta_e).sin_cos();
        let (i_a, i_b) = self.currents();
        let kn = k * n;
        let fast = -(r / l + ks / eps);
        let d = r * eps + l * ks;
        let mut m = DMatrix::zeros(5, 5);
        // (51), (52): cos(Nθ − π/2) = sin Nθ, sin(Nθ − π/2) = −cos Nθ.
        m[(0, 0)] = fast;
        m[(0, 2)] = kn * n / l * w * s;
        m[(0, 3)] = -kn / l * c;
        m[(1, 1)] = fast;
        m[(1, 2)] = -kn * n / l * w * c;
        m[(1, 3)] = -kn / l * s;
        // (53)
        m[(2, 3)] = 1.0;
        // (54)
        let a1 = kn / h - b * r / (h * kn) + r * k1 / kn;
        let a2 = 2.0 * kn / h + r * k2 / (kn * n * w) - r * k3 / (kn * n * n * w * w);
        let cur = r + ks * l / eps;
        let kk = -b / h + k1;
        let k23 = -k2 + k3 / (n * w);
        m[(3, 0)] = (kn * r * eps / h * c + ks * l * c * a1 - ks * l * s * a2
            + ks * l / (h * w) * (i_a * s * s - i_b * s2 / 2.0) * cur
            + ks * ks * l * l * c / (kn * eps) * kk
            + ks * ks * l * l * s / (kn * n * eps * w) * k23)
            / d;
        m[(3, 1)] = (kn * r * eps / h * s
            + ks * l * s * a1
            + ks * l * c * a2
            + ks * l / (2.0 * h * w) * (-i_a * s2 + i_b + i_b * c2) * cur
            + ks * ks * l * l * s / (kn * eps) * kk
            - ks * ks * l * l * c / (kn * n * eps * w) * k23)
            / d;
        let inner =
            (kn * i_a * s - kn * i_b * c) / (h * w) - k2 / (n * w) + 2.0 * k3 / (n * n * w * w);
        m[(3, 3)] = (-b * r * r * eps * eps
            - k * k * l * n * n * eps * ks
            - 2.0 * b * l * r * eps * ks
            - b * l * l * ks * ks
            + l * r * eps * ks * inner
            + l * l * ks * ks * inner)
            / (d * d);
        m[(3, 4)] = -1.0 / h;
        // (55)
        let g = k3 * ks * h * l / (kn * n * eps * w);
        m[(4, 0)] = g * (s - c);
        m[(4, 1)] = g * (-c - s);
        m[(4, 2)] = -2.0 * h * l * k3 * ks / d;
        m
    }

    /// Eigenvalues of [`Self::error_matrix`].
    pub fn eigenvalues(&self, ks: f64) -> Vec<Complex<f64>> {
        self.error_matrix(ks)
            .complex_eigenvalues()
            .iter()
            .copied()
            .collect()
    }
}

/// Delta-transform stability margin of one eigenvalue at period `ts`: negative when stable.
pub fn delta_margin(p: Complex<f64>, ts: f64) -> f64 {
    0.5 * ts * p.norm_sqr() + p.re
}

/// True when every eigenvalue at `ks` satisfies `(T/2)|p|² + Re p < 0`.
pub fn stable(op: &OperatingPoint, ks: f64, ts: f64) -> bool {
    op.eigenvalues(ks)
        .iter()
        .all(|&p| delta_margin(p, ts) < 0.0)
}

/// `(K_s,max)_T` \[A/s]: the upper end of the first stable K_s interval found by scanning
/// `(0, ks_scan_max]` in steps of `ks_step`, refined by bisection to `tol`. `None` when no
/// scanned K_s is stable; `Some(ks_scan_max)` if still stable there.
pub fn ks_max_t(
    op: &OperatingPoint,
    ts: f64,
    ks_scan_max: f64,
    ks_step: f64,
    tol: f64,
) -> Option<f64> {
    let mut ks = ks_step;
    let mut seen_stable = false;
    while ks <= ks_scan_max {
        let ok = stable(op, ks, ts);
        if ok {
            seen_stable = true;
        } else if seen_stable {
            let (mut lo, mut hi) = (ks - ks_step, ks);
            while hi - lo > tol {
                let mid = 0.5 * (lo + hi);
                if stable(op, mid, ts) {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            return Some(lo);
        }
        ks += ks_step;
    }
    seen_stable.then_some(ks_scan_max)
}

/// The answer of `pmsm-sim bounds`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct BoundsReport {
    /// `(K_s,max)_E2 = (√2·K·N·ω − R·ε)/L` \[A/s] (core closed form).
    pub ks_max_e2: f64,
    /// `(K_s,max)_T` \[A/s], `null` if no K_s up to the scan limit is stable.
    pub ks_max_t: Option<f64>,
    /// Eigenvalues `[re, im]` \[1/s] at `(K_s,max)_T`.
    pub eigenvalues_at_ks_max_t: Vec<[f64; 2]>,
}

/// Scan limit and resolution of the `(K_s,max)_T` search \[A/s].
pub const KS_SCAN_MAX: f64 = 1.0e6;
const KS_SCAN_STEP: f64 = 10.0;
const KS_TOL: f64 = 1e-3;

/// `(K_s,max)_E2` from the core and `(K_s,max)_T` at `rate_hz`.
pub fn report(motor: &MotorParams, op: &OperatingPoint, rate_hz: f64) -> BoundsReport {
    let ks_max_e2 =
        pmsm_sensorless::bounds::ks_max_e2(motor, op.omega as f32, op.epsilon as f32) as f64;
    let ks_max_t = ks_max_t(op, 1.0 / rate_hz, KS_SCAN_MAX, KS_SCAN_STEP, KS_TOL);
    let eigenvalues_at_ks_max_t = ks_max_t
        .map(|ks| op.eigenvalues(ks).iter().map(|p| [p.re, p.im]).collect())
        .unwrap_or_default();
    BoundsReport {
        ks_max_e2,
        ks_max_t,
        eigenvalues_at_ks_max_t,
    }
}

/// Which linearisation a root locus is drawn for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Equilibrium {
    /// Eqs (46)-(50) (Fig 2).
    First,
    /// Eqs (51)-(55) (Fig 3).
    Second,
}

impl Equilibrium {
    fn matrix(self, op: &OperatingPoint, ks: f64) -> DMatrix<f64> {
        match self {
            Equilibrium::First => op.error_matrix(ks),
            Equilibrium::Second => op.second_equilibrium_matrix(ks),
        }
    }

    fn name(self) -> (&'static str, &'static str) {
        match self {
            Equilibrium::First => (
                "root_locus",
                "Eqs (46)-(50), 1st equilibrium (Horng & Chin Fig 2)",
            ),
            Equilibrium::Second => (
                "root_locus_e2",
                "Eqs (51)-(55), 2nd equilibrium (Horng & Chin Fig 3)",
            ),
        }
    }
}

/// Root locus over K_s: `<stem>.csv` (ks, index, re, im) and `<stem>.png` with the
/// delta-transform stability circles of `rates_hz`; stem `root_locus` (Fig 2) or
/// `root_locus_e2` (Fig 3).
pub fn write_root_locus(
    op: &OperatingPoint,
    which: Equilibrium,
    ks_max: f64,
    rates_hz: &[f64],
    dir: &std::path::Path,
) -> anyhow::Result<(std::path::PathBuf, std::path::PathBuf)> {
    use anyhow::Context;
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let (stem, what) = which.name();
    let steps = 400;
    let dim = which.matrix(op, 0.0).nrows();
    let mut re = vec![Vec::new(); dim];
    let mut im = vec![Vec::new(); dim];
    let csv_path = dir.join(format!("{stem}.csv"));
    let mut w = csv::Writer::from_path(&csv_path)
        .with_context(|| format!("creating {}", csv_path.display()))?;
    w.write_record(["ks_a_per_s", "index", "re_per_s", "im_per_s"])?;
    for k in 0..=steps {
        let ks = ks_max * k as f64 / steps as f64;
        let mut e: Vec<Complex<f64>> = which
            .matrix(op, ks)
            .complex_eigenvalues()
            .iter()
            .copied()
            .collect();
        e.sort_by(|a, b| a.re.total_cmp(&b.re).then(a.im.total_cmp(&b.im)));
        for (i, p) in e.iter().enumerate() {
            w.write_record([
                format!("{ks:.3}"),
                i.to_string(),
                format!("{:.6}", p.re),
                format!("{:.6}", p.im),
            ])?;
            re[i].push(p.re);
            im[i].push(p.im);
        }
    }
    w.flush()?;
    let labels: Vec<String> = (0..dim).map(|i| format!("eigenvalue {}", i + 1)).collect();
    let series: Vec<crate::plot::Series> = (0..dim)
        .map(|i| crate::plot::Series {
            label: &labels[i],
            x: &re[i],
            y: &im[i],
        })
        .collect();
    let circle_labels: Vec<String> = rates_hz
        .iter()
        .map(|f| format!("delta-transform stability circle, {:.0} Hz", f))
        .collect();
    let circles: Vec<(f64, f64, f64, &str)> = rates_hz
        .iter()
        .zip(&circle_labels)
        .map(|(f, label)| (-f, 0.0, *f, label.as_str()))
        .collect();
    let png_path = dir.join(format!("{stem}.png"));
    let title = format!(
        "{what}: K_s 0..{ks_max:.0} A/s, {:.0} rpm, {} N·m",
        op.omega * 30.0 / std::f64::consts::PI,
        op.load_nm
    );
    crate::plot::plot_xy(
        &png_path,
        &title,
        "Re p [1/s]",
        "Im p [1/s]",
        &series,
        &circles,
        true,
    )?;
    Ok((csv_path, png_path))
}
