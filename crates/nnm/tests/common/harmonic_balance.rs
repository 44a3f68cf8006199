//! Harmonic balance (HB): an independent reference for the shooting tests.
//!
//! Test-only code. It sees the system only through the public [`MechanicalSystem`] trait (mass
//! products, internal force, tangent-stiffness products) and uses none of nnm's shooting,
//! integrators, continuation or linear-mode solver, so an agreement with a shooting branch
//! checks the whole shooting path (integrator, sensitivities, Newton, continuation) against
//! a method that shares none of it.
//!
//! The motion. A synchronous NNM of a conservative, time-reversible system passes through a
//! state of rest; with `t = 0` there the motion is even in time, `x(−t) = x(t)`, so it is a
//! cosine series in `τ = ω t`:
//!
//! ```text
//!     x(τ) = Σ_h a_h cos(h τ),     h ∈ the chosen harmonics (odd ones for an odd system)
//! ```
//!
//! For an odd internal force (`f(−x) = −f(x)`, e.g. the cubic beam and the Duffing oscillator)
//! the half-wave symmetric motions `x(τ + π) = −x(τ)` contain odd harmonics only, so
//! [`Harmonics::Odd`] halves the unknowns; [`Harmonics::All`] (h = 0, 1, …) makes no such
//! assumption.
//!
//! The equations. Galerkin projection of `M x'' + f(x) = 0` onto each `cos(h τ)`:
//!
//! ```text
//!     R_h(a, λ) = −h² λ M a_h + F_h(a) = 0,      λ = ω²,
//!     F_h(a)    = w_h Σ_j f(x(τ_j)) cos(h τ_j),  τ_j = 2π j / N,  w_0 = 1/N, w_h = 2/N,
//! ```
//!
//! (alternating frequency–time: the force is sampled in time and projected), plus one
//! amplitude condition `ℓᵀ x(0) = ℓᵀ Σ_h a_h = value` that picks the point of the family
//! (the time shift is already fixed by the cosine ansatz, up to `τ → τ + π`, which the sign of
//! `value` fixes). Newton on `(a, λ)` with the exact Jacobian
//!
//! ```text
//!     ∂R_h/∂a_k = −h² λ M δ_hk + w_h Σ_j cos(h τ_j) K_t(x(τ_j)) cos(k τ_j),   ∂R_h/∂λ = −h² M a_h
//! ```
//!
//! solved densely (faer's LU with partial pivoting).
//!
//! The sampling. For a polynomial force of degree `p` and harmonics up to `h_max`, `f(x(τ))`
//! is a trigonometric polynomial of degree `p·h_max`, so `f · cos(h τ)` has degree at most
//! `(p + 1)·h_max`; the `N`-point rectangle rule is exact for trigonometric polynomials of
//! degree below `N`. With `N = (p + 1)·h_max + 1` the sums are therefore the exact Galerkin
//! integrals (no aliasing), and the same bound covers the Jacobian (`K_t` has degree
//! `(p − 1)·h_max`, times two cosines). The only approximation left is the truncation in `h`,
//! which the callers check by adding harmonics.

use std::f64::consts::PI;

use faer::Mat;
use faer::linalg::solvers::Solve;
use nnm::prelude::*;

/// Which harmonics the cosine series keeps.
#[derive(Debug, Clone, Copy)]
pub enum Harmonics {
    /// `1, 3, …, 2·count − 1`: half-wave symmetric motions of odd systems.
    Odd(usize),
    /// `0, 1, …, max`: no symmetry assumed.
    All(usize),
}

impl Harmonics {
    fn list(self) -> Vec<usize> {
        match self {
            Harmonics::Odd(count) => (0..count).map(|i| 2 * i + 1).collect(),
            Harmonics::All(max) => (0..=max).collect(),
        }
    }
}

/// One periodic motion `x(τ) = Σ_h a_h cos(h τ)`, `τ = ω t`.
#[derive(Debug, Clone)]
pub struct Motion {
    /// Angular frequency ω (rad/s).
    pub omega: f64,
    /// The harmonics `h`, in the order of `coefficients`.
    pub harmonics: Vec<usize>,
    /// `a_h` (length n each).
    pub coefficients: Vec<Vec<f64>>,
    /// Newton iterations of the last solve.
    pub iterations: usize,
    /// `max_h ‖R_h‖∞ / max_h max(‖h² ω² M a_h‖∞, ‖F_h‖∞)` at convergence.
    pub relative_residual: f64,
}

impl Motion {
    /// `x(τ)`.
    pub fn displacement(&self, tau: f64) -> Vec<f64> {
        let n = self.coefficients[0].len();
        let mut x = vec![0.0; n];
        for (&h, a) in self.harmonics.iter().zip(&self.coefficients) {
            let c = (h as f64 * tau).cos();
            for (xi, ai) in x.iter_mut().zip(a) {
                *xi += c * ai;
            }
        }
        x
    }

    /// `x(0) = Σ_h a_h`: the state of rest the motion starts from.
    pub fn initial_displacement(&self) -> Vec<f64> {
        self.displacement(0.0)
    }

    /// The same motion on another set of harmonics (new ones zero, dropped ones lost): a
    /// guess for an HB with more or fewer harmonics.
    pub fn on(&self, harmonics: Harmonics) -> Motion {
        let n = self.coefficients[0].len();
        let harmonics = harmonics.list();
        let coefficients = harmonics
            .iter()
            .map(|h| match self.harmonics.iter().position(|g| g == h) {
                Some(i) => self.coefficients[i].clone(),
                None => vec![0.0; n],
            })
            .collect();
        Motion {
            harmonics,
            coefficients,
            ..self.clone()
        }
    }
}

/// The HB equations of one system with a fixed set of harmonics and time samples.
pub struct HarmonicBalance<'a, S: MechanicalSystem + ?Sized> {
    system: &'a S,
    n: usize,
    harmonics: Vec<usize>,
    samples: usize,
    /// `cos(h τ_j)`, one row per harmonic.
    cosines: Vec<Vec<f64>>,
    /// The projection weights `w_h`.
    weights: Vec<f64>,
    /// Dense `M`, column-major.
    mass: Vec<f64>,
}

impl<'a, S: MechanicalSystem + ?Sized> HarmonicBalance<'a, S> {
    /// HB with `harmonics` for a system whose internal force is a polynomial of degree
    /// `degree` (3 for cubic springs); the time grid is the smallest that is alias-free for
    /// that degree (module docs).
    pub fn new(system: &'a S, harmonics: Harmonics, degree: usize) -> Self {
        let harmonics = harmonics.list();
        let h_max = *harmonics.iter().max().expect("at least one harmonic");
        let samples = (degree + 1) * h_max.max(1) + 1;
        Self::with_samples(system, harmonics, samples)
    }

    fn with_samples(system: &'a S, harmonics: Vec<usize>, samples: usize) -> Self {
        let n = system.dofs();
        let cosines = harmonics
            .iter()
            .map(|&h| {
                (0..samples)
                    .map(|j| (h as f64 * 2.0 * PI * j as f64 / samples as f64).cos())
                    .collect()
            })
            .collect();
        let weights = harmonics
            .iter()
            .map(|&h| if h == 0 { 1.0 } else { 2.0 } / samples as f64)
            .collect();
        let mut mass = vec![0.0; n * n];
        system.mass().apply(&identity(n), n, &mut mass);
        Self {
            system,
            n,
            harmonics,
            samples,
            cosines,
            weights,
            mass,
        }
    }

    /// The number of time samples per period.
    pub fn samples(&self) -> usize {
        self.samples
    }

    /// The lowest linear mode `(ω₀, φ)` by inverse iteration on `K_t(0)⁻¹ M` (the test's own,
    /// not nnm's eigen-solver), with `φ` scaled so that `max |φ_i| = 1`. Used only as the
    /// first Newton guess. Needs a nonsingular `K_t(0)` (no rigid-body modes) and a simple
    /// lowest frequency.
    pub fn lowest_linear_mode(&self) -> (f64, Vec<f64>) {
        let n = self.n;
        let k0 = self.tangent(&vec![0.0; n]);
        let k0 = Mat::from_fn(n, n, |i, j| k0[j * n + i]);
        let lu = k0.partial_piv_lu();
        let mut phi = vec![1.0; n];
        let mut omega2 = f64::NAN;
        for _ in 0..500 {
            let mut rhs = Mat::from_fn(n, 1, |i, _| dot_col(&self.mass, n, i, &phi));
            lu.solve_in_place(rhs.as_mut());
            let next: Vec<f64> = (0..n).map(|i| rhs[(i, 0)]).collect();
            let scale = next.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let next: Vec<f64> = next.iter().map(|v| v / scale).collect();
            // Rayleigh quotient φᵀ K φ / φᵀ M φ.
            let kphi: f64 = (0..n)
                .map(|i| next[i] * (0..n).map(|j| k0[(i, j)] * next[j]).sum::<f64>())
                .sum();
            let mphi: f64 = (0..n)
                .map(|i| next[i] * dot_col(&self.mass, n, i, &next))
                .sum();
            let change = next
                .iter()
                .zip(&phi)
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            phi = next;
            omega2 = kphi / mphi;
            if change < 1e-14 {
                break;
            }
        }
        // Sign convention: the largest entry positive.
        let big = phi
            .iter()
            .copied()
            .fold(0.0f64, |m, v| if v.abs() > m.abs() { v } else { m });
        let phi = phi.iter().map(|v| v * big.signum()).collect();
        (omega2.sqrt(), phi)
    }

    /// The linear motion `x = scale · φ cos(ω₀ t)` on the lowest mode, as a first guess.
    pub fn linear_guess(&self, scale: f64) -> Motion {
        let (omega, phi) = self.lowest_linear_mode();
        let coefficients = self
            .harmonics
            .iter()
            .map(|&h| {
                if h == 1 {
                    phi.iter().map(|v| v * scale).collect()
                } else {
                    vec![0.0; self.n]
                }
            })
            .collect();
        Motion {
            omega,
            harmonics: self.harmonics.clone(),
            coefficients,
            iterations: 0,
            relative_residual: f64::NAN,
        }
    }

    /// `out = K_t(x)`, dense column-major.
    fn tangent(&self, x: &[f64]) -> Vec<f64> {
        let n = self.n;
        let eye = identity(n);
        let mut out = vec![0.0; n * n];
        self.system.tangent_stiffness(
            x,
            Block::new(&eye, n, n, n),
            BlockMut::new(&mut out, n, n, n),
        );
        out
    }

    /// `x(τ_j)` from the stacked coefficients.
    fn sample(&self, a: &[f64], j: usize) -> Vec<f64> {
        let n = self.n;
        let mut x = vec![0.0; n];
        for (i, c) in self.cosines.iter().enumerate() {
            let c = c[j];
            for (xi, ai) in x.iter_mut().zip(&a[i * n..(i + 1) * n]) {
                *xi += c * ai;
            }
        }
        x
    }

    /// Residual `[R_h…; ℓᵀ x(0) − value]` (the amplitude row scaled by `row_scale`), the
    /// Jacobian, and the residual's scale `max_h max(‖h² λ M a_h‖∞, ‖F_h‖∞)`.
    fn evaluate(
        &self,
        a: &[f64],
        lambda: f64,
        functional: &[f64],
        value: f64,
        row_scale: f64,
    ) -> (Vec<f64>, Mat<f64>, f64) {
        let (n, m) = (self.n, self.harmonics.len());
        let size = n * m + 1;
        let mut residual = vec![0.0; size];
        let mut jacobian = Mat::<f64>::zeros(size, size);
        let mut force = vec![0.0; n];
        for j in 0..self.samples {
            let x = self.sample(a, j);
            self.system.internal_force(&x, &mut force);
            let kt = self.tangent(&x);
            for (i, ci) in self.cosines.iter().enumerate() {
                let wi = self.weights[i] * ci[j];
                for r in 0..n {
                    residual[i * n + r] += wi * force[r];
                }
                for (k, ck) in self.cosines.iter().enumerate() {
                    let w = wi * ck[j];
                    for c in 0..n {
                        for r in 0..n {
                            jacobian[(i * n + r, k * n + c)] += w * kt[c * n + r];
                        }
                    }
                }
            }
        }
        let mut scale = 0.0f64;
        for (i, &h) in self.harmonics.iter().enumerate() {
            let h2 = (h * h) as f64;
            let ai = &a[i * n..(i + 1) * n];
            for r in 0..n {
                let ma = dot_col(&self.mass, n, r, ai);
                // The scale of the cancelling terms, for the relative residual.
                scale = scale
                    .max((h2 * lambda * ma).abs())
                    .max(residual[i * n + r].abs());
                residual[i * n + r] -= h2 * lambda * ma;
                jacobian[(i * n + r, n * m)] = -h2 * ma;
                for c in 0..n {
                    jacobian[(i * n + r, i * n + c)] -= h2 * lambda * self.mass[c * n + r];
                }
            }
        }
        // x(0) = Σ_h a_h since cos(0) = 1 for every harmonic.
        let mut x0 = 0.0;
        for i in 0..m {
            for r in 0..n {
                x0 += functional[r] * a[i * n + r];
                jacobian[(n * m, i * n + r)] = row_scale * functional[r];
            }
        }
        residual[n * m] = row_scale * (x0 - value);
        (residual, jacobian, scale)
    }

    /// Newton from `guess` to the motion with `ℓᵀ x(0) = value`.
    pub fn solve(&self, guess: &Motion, functional: &[f64], value: f64) -> Result<Motion, String> {
        let (n, m) = (self.n, self.harmonics.len());
        assert_eq!(
            guess.harmonics, self.harmonics,
            "guess with other harmonics"
        );
        assert_eq!(functional.len(), n);
        let mut a: Vec<f64> = guess.coefficients.concat();
        let mut lambda = guess.omega * guess.omega;
        // The amplitude row is scaled to the stiffness rows so that the pivoting treats it
        // like them.
        let k0 = self.tangent(&vec![0.0; n]);
        let row_scale = k0.iter().fold(0.0f64, |s, v| s.max(v.abs()));
        let mut converged_once = false;
        for iteration in 1..=30 {
            let (residual, jacobian, _) = self.evaluate(&a, lambda, functional, value, row_scale);
            if residual.iter().any(|r| !r.is_finite()) {
                return Err(format!("non-finite residual at iteration {iteration}"));
            }
            let lu = jacobian.partial_piv_lu();
            let mut step = Mat::from_fn(n * m + 1, 1, |i, _| -residual[i]);
            lu.solve_in_place(step.as_mut());
            let a_norm = a.iter().fold(0.0f64, |s, v| s.max(v.abs()));
            let da = (0..n * m).fold(0.0f64, |s, i| s.max(step[(i, 0)].abs()));
            let dlambda = step[(n * m, 0)];
            for (i, ai) in a.iter_mut().enumerate() {
                *ai += step[(i, 0)];
            }
            lambda += dlambda;
            let correction = (da / a_norm).max((dlambda / lambda).abs());
            if !correction.is_finite() || lambda <= 0.0 {
                return Err(format!("diverged at iteration {iteration}"));
            }
            // Quadratic convergence: once the correction is below 1e-9, one more iteration
            // takes the error to rounding level.
            if converged_once {
                let (residual, _, scale) = self.evaluate(&a, lambda, functional, value, row_scale);
                let worst = residual[..n * m].iter().fold(0.0f64, |s, v| s.max(v.abs()));
                return Ok(Motion {
                    omega: lambda.sqrt(),
                    harmonics: self.harmonics.clone(),
                    coefficients: a.chunks(n).map(<[f64]>::to_vec).collect(),
                    iterations: iteration,
                    relative_residual: worst / scale,
                });
            }
            converged_once = correction < 1e-9;
        }
        Err("no convergence in 30 iterations".into())
    }

    /// Steps the amplitude `ℓᵀ x(0)` from `start`'s to `value` (solving there even when
    /// `start` is already at it, so that `start` may come from other harmonics), each step at
    /// most `max_ratio` times the last amplitude and shortened when Newton fails, with the
    /// previous motion scaled to the new amplitude as the guess.
    pub fn follow(
        &self,
        start: &Motion,
        functional: &[f64],
        value: f64,
        max_ratio: f64,
    ) -> Result<Motion, String> {
        let mut current = start.clone();
        let mut at: f64 = current
            .initial_displacement()
            .iter()
            .zip(functional)
            .map(|(x, l)| x * l)
            .sum();
        let mut ratio = max_ratio;
        let mut failures = 0;
        loop {
            let target = if value / at > ratio {
                at * ratio
            } else if value / at < 1.0 / ratio {
                at / ratio
            } else {
                value
            };
            let mut guess = current.clone();
            for c in &mut guess.coefficients {
                for v in c.iter_mut() {
                    *v *= target / at;
                }
            }
            match self.solve(&guess, functional, target) {
                Ok(next) if target == value => return Ok(next),
                Ok(next) => {
                    current = next;
                    at = target;
                    ratio = (1.0 + 1.5 * (ratio - 1.0)).min(max_ratio);
                }
                Err(e) => {
                    failures += 1;
                    if failures > 30 {
                        return Err(format!("amplitude stepping stalled at {at}: {e}"));
                    }
                    ratio = 1.0 + 0.5 * (ratio - 1.0);
                }
            }
        }
    }
}

fn identity(n: usize) -> Vec<f64> {
    let mut eye = vec![0.0; n * n];
    for i in 0..n {
        eye[i * n + i] = 1.0;
    }
    eye
}

/// Row `r` of the column-major `n × n` matrix `a` times `x`.
fn dot_col(a: &[f64], n: usize, r: usize, x: &[f64]) -> f64 {
    (0..n).map(|c| a[c * n + r] * x[c]).sum()
}

/// `√(xᵀ M x)` with the system's mass operator.
pub fn mass_norm<S: MechanicalSystem + ?Sized>(system: &S, x: &[f64]) -> f64 {
    let mut mx = vec![0.0; x.len()];
    system.mass().apply(x, 1, &mut mx);
    x.iter().zip(&mx).map(|(a, b)| a * b).sum::<f64>().sqrt()
}
