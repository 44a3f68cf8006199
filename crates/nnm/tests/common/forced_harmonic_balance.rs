//! Harmonic balance (HB) for forced, damped periodic responses: an independent reference for
//! the shooting frequency-response curves.
//!
//! Test-only code. It sees the structure only through the public [`MechanicalSystem`] trait
//! (mass products, internal force, tangent-stiffness products) and has its own Newton,
//! continuation and fold location, sharing nothing with nnm's shooting, integrators or
//! continuation, so an agreement with a shooting curve checks that whole path.
//!
//! The problem, with `τ = Ω t`:
//!
//! ```text
//!     M x'' + C x' + f_int(x) = F_c cos Ωt + F_s sin Ωt,
//!     x(τ) = c_0 + Σ_{h=1..H} (a_h cos hτ + b_h sin hτ).
//! ```
//!
//! Damping shifts the phase, so every harmonic needs both its cosine and its sine, and the
//! mean `c_0` is kept (no symmetry is assumed). The unknowns are stacked as
//! `z = [c_0; a_1; b_1; …; a_H; b_H]` (each block `n` long), basis `ψ_0 = 1`,
//! `ψ_{2h−1} = cos hτ`, `ψ_{2h} = sin hτ`.
//!
//! The equations: Galerkin projection onto each `ψ_i`, with `d/dt = Ω d/dτ`,
//!
//! ```text
//!     R_0     = F_0(z)
//!     R_cos,h = −h²Ω² M a_h + hΩ C b_h + F_cos,h(z) − δ_h1 F_c
//!     R_sin,h = −h²Ω² M b_h − hΩ C a_h + F_sin,h(z) − δ_h1 F_s
//!     F_i(z)  = w_i Σ_j ψ_i(τ_j) f_int(x(τ_j)),   τ_j = 2πj/N,   w_0 = 1/N,  w_i = 2/N,
//! ```
//!
//! alternating frequency–time (AFT): the internal force is sampled in time and projected.
//! The exact Jacobian is `∂R/∂z = (linear blocks above) + w_i Σ_j ψ_i(τ_j) K_t(x(τ_j)) ψ_k(τ_j)`
//! and `∂R_cos,h/∂Ω = −2h²Ω M a_h + h C b_h`, `∂R_sin,h/∂Ω = −2h²Ω M b_h − h C a_h`.
//!
//! The sampling. For a polynomial force of degree `p`, `f_int(x(τ))` is a trigonometric
//! polynomial of degree `pH` and `f_int · ψ_i` of degree `(p + 1)H`; the `N`-point rectangle
//! rule is exact below degree `N`, so `N = (p + 1)H + 1` makes the projections the exact
//! Galerkin integrals (no aliasing; the Jacobian's `ψ_i K_t ψ_k` has the same degree). The
//! only approximation left is the truncation at `H`, which callers check by adding harmonics.

use std::f64::consts::PI;

use faer::Mat;
use faer::linalg::solvers::Solve;
use nnm::prelude::*;

/// `M x'' + C x' + f_int(x) = F_c cos Ωt + F_s sin Ωt` with dense `M` and `C`.
pub struct ForcedProblem<'a, S: MechanicalSystem + ?Sized> {
    system: &'a S,
    n: usize,
    mass: Mat<f64>,
    damping: Mat<f64>,
    force_cos: Vec<f64>,
    force_sin: Vec<f64>,
    /// Polynomial degree `p` of `f_int` for the alias-free sampling rule (3 for cubic).
    pub degree: usize,
    /// Time samples per period; `None`: `(p + 1)H + 1`.
    pub samples: Option<usize>,
}

impl<'a, S: MechanicalSystem + ?Sized> ForcedProblem<'a, S> {
    /// The problem with forcing `amplitude · (F_c cos Ωt + F_s sin Ωt)`, `p = 3`.
    pub fn new(
        system: &'a S,
        damping: Mat<f64>,
        force_cos: &[f64],
        force_sin: &[f64],
        amplitude: f64,
    ) -> Self {
        let n = system.dofs();
        assert!(damping.nrows() == n && damping.ncols() == n);
        assert!(force_cos.len() == n && force_sin.len() == n);
        let eye: Vec<f64> = (0..n * n)
            .map(|k| if k % (n + 1) == 0 { 1.0 } else { 0.0 })
            .collect();
        let mut mass = vec![0.0; n * n];
        system.mass().apply(&eye, n, &mut mass);
        Self {
            system,
            n,
            mass: Mat::from_fn(n, n, |i, j| mass[j * n + i]),
            damping,
            force_cos: force_cos.iter().map(|v| amplitude * v).collect(),
            force_sin: force_sin.iter().map(|v| amplitude * v).collect(),
            degree: 3,
            samples: None,
        }
    }

    /// The dense mass matrix `M`.
    pub fn mass(&self) -> &Mat<f64> {
        &self.mass
    }

    /// `K_t(x)`, dense, through the trait's block product with the identity.
    pub fn tangent(&self, x: &[f64]) -> Mat<f64> {
        let n = self.n;
        let eye: Vec<f64> = (0..n * n)
            .map(|k| if k % (n + 1) == 0 { 1.0 } else { 0.0 })
            .collect();
        let mut out = vec![0.0; n * n];
        self.system.tangent_stiffness(
            x,
            Block::new(&eye, n, n, n),
            BlockMut::new(&mut out, n, n, n),
        );
        Mat::from_fn(n, n, |i, j| out[j * n + i])
    }

    fn grid(&self, harmonics: usize) -> Grid {
        let samples = self
            .samples
            .unwrap_or((self.degree + 1) * harmonics.max(1) + 1);
        let psi = (0..2 * harmonics + 1)
            .map(|i| {
                let h = ((i + 1) / 2) as f64;
                (0..samples)
                    .map(|j| {
                        let t = 2.0 * PI * j as f64 / samples as f64;
                        match i {
                            0 => 1.0,
                            _ if i % 2 == 1 => (h * t).cos(),
                            _ => (h * t).sin(),
                        }
                    })
                    .collect()
            })
            .collect();
        let weights = (0..2 * harmonics + 1)
            .map(|i| if i == 0 { 1.0 } else { 2.0 } / samples as f64)
            .collect();
        Grid {
            harmonics,
            psi,
            weights,
        }
    }

    /// `(R, ∂R/∂z (if asked), ∂R/∂Ω, scale)`, the scale being the largest term that cancels
    /// in any row (for a relative residual).
    fn evaluate(&self, z: &[f64], omega: f64, g: &Grid, jacobian: bool) -> Evaluation {
        let (n, m) = (self.n, g.psi.len());
        let mut residual = vec![0.0; n * m];
        let mut jz = jacobian.then(|| Mat::<f64>::zeros(n * m, n * m));
        let mut f = vec![0.0; n];
        for j in 0..g.psi[0].len() {
            let mut x = vec![0.0; n];
            for (i, p) in g.psi.iter().enumerate() {
                for r in 0..n {
                    x[r] += p[j] * z[i * n + r];
                }
            }
            self.system.internal_force(&x, &mut f);
            let kt = jz.as_ref().map(|_| self.tangent(&x));
            for i in 0..m {
                let wi = g.weights[i] * g.psi[i][j];
                for r in 0..n {
                    residual[i * n + r] += wi * f[r];
                }
                if let (Some(jz), Some(kt)) = (jz.as_mut(), kt.as_ref()) {
                    for k in 0..m {
                        let w = wi * g.psi[k][j];
                        for c in 0..n {
                            for r in 0..n {
                                jz[(i * n + r, k * n + c)] += w * kt[(r, c)];
                            }
                        }
                    }
                }
            }
        }
        let mut scale = residual.iter().fold(0.0f64, |s, v| s.max(v.abs()));
        let mut jomega = vec![0.0; n * m];
        let (mm, cc) = (&self.mass, &self.damping);
        let mul = |a: &Mat<f64>, v: &[f64], r: usize| (0..n).map(|c| a[(r, c)] * v[c]).sum::<f64>();
        for h in 1..=g.harmonics {
            let (ic, is, hf) = (2 * h - 1, 2 * h, h as f64);
            let (a, b) = (&z[ic * n..(ic + 1) * n], &z[is * n..(is + 1) * n]);
            for r in 0..n {
                let (ma, mb, ca, cb) = (mul(mm, a, r), mul(mm, b, r), mul(cc, a, r), mul(cc, b, r));
                let (fc, fs) = if h == 1 {
                    (self.force_cos[r], self.force_sin[r])
                } else {
                    (0.0, 0.0)
                };
                let w2 = hf * hf * omega * omega;
                let cos_terms = [-w2 * ma, hf * omega * cb, -fc];
                let sin_terms = [-w2 * mb, -hf * omega * ca, -fs];
                for t in cos_terms.iter().chain(&sin_terms) {
                    scale = scale.max(t.abs());
                }
                residual[ic * n + r] += cos_terms.iter().sum::<f64>();
                residual[is * n + r] += sin_terms.iter().sum::<f64>();
                jomega[ic * n + r] = -2.0 * hf * hf * omega * ma + hf * cb;
                jomega[is * n + r] = -2.0 * hf * hf * omega * mb - hf * ca;
                if let Some(jz) = jz.as_mut() {
                    for c in 0..n {
                        jz[(ic * n + r, ic * n + c)] -= w2 * mm[(r, c)];
                        jz[(is * n + r, is * n + c)] -= w2 * mm[(r, c)];
                        jz[(ic * n + r, is * n + c)] += hf * omega * cc[(r, c)];
                        jz[(is * n + r, ic * n + c)] -= hf * omega * cc[(r, c)];
                    }
                }
            }
        }
        Evaluation {
            residual,
            jz,
            jomega,
            scale: if scale > 0.0 { scale } else { 1.0 },
        }
    }

    /// The augmented Jacobian `[∂R/∂z ∂R/∂Ω; ℓᵀ]` at `y = (z, Ω)`.
    fn bordered(&self, y: &[f64], g: &Grid, row: &[f64]) -> (Evaluation, Mat<f64>) {
        let size = y.len() - 1;
        let mut e = self.evaluate(&y[..size], y[size], g, true);
        let jz = e.jz.take().unwrap();
        let a = Mat::from_fn(size + 1, size + 1, |i, j| match (i < size, j < size) {
            (true, true) => jz[(i, j)],
            (true, false) => e.jomega[i],
            (false, _) => row[j],
        });
        (e, a)
    }

    /// Newton on `R(z, Ω) = 0, ℓᵀ(z, Ω) = value` from `y`. Stops after a correction below
    /// 1e-10 relative to `‖y‖∞`: quadratic convergence has then taken the error to rounding,
    /// whereas a small residual alone is not enough near a resonance, where `‖J⁻¹‖` is large.
    /// Returns `(y, iterations, relative residual ‖R‖∞ / scale)`.
    fn correct(
        &self,
        mut y: Vec<f64>,
        g: &Grid,
        row: &[f64],
        value: f64,
        max_iterations: usize,
    ) -> Result<(Vec<f64>, usize, f64), String> {
        let size = y.len() - 1;
        let mut small_step = false;
        for iteration in 0..=max_iterations {
            let (e, a) = self.bordered(&y, g, row);
            let relative = e.residual.iter().fold(0.0f64, |s, v| s.max(v.abs())) / e.scale;
            if !relative.is_finite() {
                return Err(format!("non-finite residual at iteration {iteration}"));
            }
            if small_step {
                return Ok((y, iteration, relative));
            }
            if iteration == max_iterations {
                break;
            }
            let lin: f64 = row.iter().zip(&y).map(|(l, v)| l * v).sum::<f64>() - value;
            let mut rhs = Mat::from_fn(
                size + 1,
                1,
                |i, _| {
                    if i < size { -e.residual[i] } else { -lin }
                },
            );
            a.partial_piv_lu().solve_in_place(rhs.as_mut());
            let norm = y.iter().fold(0.0f64, |s, v| s.max(v.abs()));
            let step = (0..=size).fold(0.0f64, |s, i| s.max(rhs[(i, 0)].abs()));
            for (i, v) in y.iter_mut().enumerate() {
                *v += rhs[(i, 0)];
            }
            if !step.is_finite() {
                return Err(format!("diverged at iteration {}", iteration + 1));
            }
            small_step = step < 1e-10 * norm.max(1e-300);
        }
        Err(format!("no convergence in {max_iterations} iterations"))
    }

    /// The curve's tangent `t` at `y`: `[∂R/∂z ∂R/∂Ω; ℓᵀ] t = [0; 1]` (not normalised).
    fn tangent_at(&self, y: &[f64], g: &Grid, row: &[f64]) -> Vec<f64> {
        let (_, a) = self.bordered(y, g, row);
        let size = y.len() - 1;
        let mut rhs = Mat::from_fn(size + 1, 1, |i, _| if i == size { 1.0 } else { 0.0 });
        a.partial_piv_lu().solve_in_place(rhs.as_mut());
        (0..=size).map(|i| rhs[(i, 0)]).collect()
    }

    /// The linear response on the first harmonic, `[K_0 − Ω²M, ΩC; −ΩC, K_0 − Ω²M] [a_1; b_1]
    /// = [F_c; F_s]` with `K_0 = K_t(0)`: the default Newton guess.
    fn linear_guess(&self, omega: f64, harmonics: usize) -> Vec<f64> {
        let n = self.n;
        let k0 = self.tangent(&vec![0.0; n]);
        let d = Mat::from_fn(n, n, |i, j| k0[(i, j)] - omega * omega * self.mass[(i, j)]);
        let a = Mat::from_fn(2 * n, 2 * n, |i, j| match (i < n, j < n) {
            (true, true) => d[(i, j)],
            (true, false) => omega * self.damping[(i, j - n)],
            (false, true) => -omega * self.damping[(i - n, j)],
            (false, false) => d[(i - n, j - n)],
        });
        let mut rhs = Mat::from_fn(2 * n, 1, |i, _| {
            if i < n {
                self.force_cos[i]
            } else {
                self.force_sin[i - n]
            }
        });
        a.partial_piv_lu().solve_in_place(rhs.as_mut());
        let mut z = vec![0.0; n * (2 * harmonics + 1)];
        for i in 0..2 * n {
            z[n + i] = rhs[(i, 0)];
        }
        z
    }
}

struct Grid {
    harmonics: usize,
    /// `ψ_i(τ_j)`, one row per basis function.
    psi: Vec<Vec<f64>>,
    weights: Vec<f64>,
}

struct Evaluation {
    residual: Vec<f64>,
    jz: Option<Mat<f64>>,
    jomega: Vec<f64>,
    scale: f64,
}

/// One periodic response `x(τ) = c_0 + Σ_h (a_h cos hτ + b_h sin hτ)` at `Ω`.
#[derive(Debug, Clone)]
pub struct Coefficients {
    /// Forcing frequency `Ω` (rad/s).
    pub omega: f64,
    /// `H`.
    pub harmonics: usize,
    /// `[c_0; a_1; b_1; …; a_H; b_H]`, each block `n` long.
    pub z: Vec<f64>,
    /// Newton iterations of the solve.
    pub iterations: usize,
    /// `‖R‖∞ / scale` at convergence.
    pub relative_residual: f64,
}

impl Coefficients {
    fn n(&self) -> usize {
        self.z.len() / (2 * self.harmonics + 1)
    }

    /// `a_h` (`h ≥ 1`), or `c_0` for `h = 0`.
    pub fn cosine(&self, h: usize) -> &[f64] {
        let (n, i) = (self.n(), if h == 0 { 0 } else { 2 * h - 1 });
        &self.z[i * n..(i + 1) * n]
    }

    /// `b_h`, `h ≥ 1`.
    pub fn sine(&self, h: usize) -> &[f64] {
        let n = self.n();
        &self.z[2 * h * n..(2 * h + 1) * n]
    }

    /// `(x_d, dx_d/dτ, d²x_d/dτ²)` at `τ`.
    pub fn dof_at(&self, dof: usize, tau: f64) -> [f64; 3] {
        let mut out = [self.cosine(0)[dof], 0.0, 0.0];
        for h in 1..=self.harmonics {
            let (a, b, hf) = (self.cosine(h)[dof], self.sine(h)[dof], h as f64);
            let (s, c) = (hf * tau).sin_cos();
            out[0] += a * c + b * s;
            out[1] += hf * (-a * s + b * c);
            out[2] -= hf * hf * (a * c + b * s);
        }
        out
    }

    /// The same response on `harmonics` (new ones zero, dropped ones lost): a guess for an
    /// HB with more or fewer harmonics.
    pub fn on(&self, harmonics: usize) -> Coefficients {
        let n = self.n();
        let mut z = vec![0.0; n * (2 * harmonics + 1)];
        let keep = n * (2 * harmonics.min(self.harmonics) + 1);
        z[..keep].copy_from_slice(&self.z[..keep]);
        Coefficients {
            harmonics,
            z,
            ..self.clone()
        }
    }
}

/// The HB response at the fixed frequency `Ω` with `harmonics` = `H`, by Newton from `guess`
/// (moved onto `H` harmonics) or, without one, from the linear first-harmonic response.
/// Fails unless the relative residual reaches 1e-11.
pub fn solve<S: MechanicalSystem + ?Sized>(
    problem: &ForcedProblem<'_, S>,
    omega: f64,
    harmonics: usize,
    guess: Option<&Coefficients>,
) -> Result<Coefficients, String> {
    let g = problem.grid(harmonics);
    let mut y = match guess {
        Some(c) => c.on(harmonics).z,
        None => problem.linear_guess(omega, harmonics),
    };
    y.push(omega);
    let mut row = vec![0.0; y.len()];
    *row.last_mut().unwrap() = 1.0;
    let (y, iterations, relative) = problem.correct(y, &g, &row, omega, 50)?;
    to_coefficients(y, harmonics, iterations, relative)
}

fn to_coefficients(
    mut y: Vec<f64>,
    harmonics: usize,
    iterations: usize,
    relative_residual: f64,
) -> Result<Coefficients, String> {
    if relative_residual > 1e-11 {
        return Err(format!(
            "stalled at relative residual {relative_residual:e}"
        ));
    }
    let omega = y.pop().unwrap();
    Ok(Coefficients {
        omega,
        harmonics,
        z: y,
        iterations,
        relative_residual,
    })
}

/// Step control of [`frequency_response`] (arclength in the plain Euclidean norm of
/// `(z, Ω)`).
#[derive(Debug, Clone, Copy)]
pub struct Steps {
    pub initial: f64,
    pub min: f64,
    pub max: f64,
    pub max_points: usize,
}

/// A point of the curve with its unit tangent `(dz/ds, dΩ/ds)` in the direction of travel.
#[derive(Debug, Clone)]
pub struct CurvePoint {
    pub solution: Coefficients,
    pub tangent: Vec<f64>,
}

/// The HB frequency-response curve from `omega_start` to `omega_end` by pseudo-arclength
/// continuation of `R(z, Ω) = 0`: secant predictor `y_p = y_k + Δs d` (the first step along the
/// tangent), corrected by Newton on the bordered system `[R(y) = 0; dᵀ(y − y_p) = 0]`. A step
/// is refused (and halved) when Newton fails or moves farther from the prediction than `Δs`
/// (a jump to another branch); it grows by 1.5 after quick convergence. The last point is
/// solved at exactly `omega_end`; turning back past `omega_start` is an error. Each point stores the exact unit tangent, whose
/// Ω-component changes sign at a fold ([`folds`]).
pub fn frequency_response<S: MechanicalSystem + ?Sized>(
    problem: &ForcedProblem<'_, S>,
    harmonics: usize,
    omega_start: f64,
    omega_end: f64,
    steps: &Steps,
) -> Result<Vec<CurvePoint>, String> {
    let g = problem.grid(harmonics);
    let first = solve(problem, omega_start, harmonics, None)?;
    let size = first.z.len();
    let mut y: Vec<f64> = first.z.iter().copied().chain([omega_start]).collect();
    let e_omega: Vec<f64> = (0..=size).map(|i| (i == size) as u8 as f64).collect();
    let sense = (omega_end - omega_start).signum();
    let mut direction = normalised(problem.tangent_at(&y, &g, &e_omega), sense);
    let mut points = vec![CurvePoint {
        solution: first,
        tangent: direction.clone(),
    }];
    let mut ds = steps.initial;
    while points.len() < steps.max_points {
        let predicted: Vec<f64> = y.iter().zip(&direction).map(|(v, d)| v + ds * d).collect();
        let value: f64 = direction.iter().zip(&predicted).map(|(d, v)| d * v).sum();
        let accepted = match problem.correct(predicted.clone(), &g, &direction, value, 8) {
            Ok((next, iterations, relative)) if relative < 1e-11 => {
                (distance(&next, &predicted) < ds).then_some((next, iterations, relative))
            }
            _ => None,
        };
        let Some((next, iterations, relative)) = accepted else {
            ds *= 0.5;
            if ds < steps.min {
                return Err(format!("step below minimum near Ω = {}", y[size]));
            }
            continue;
        };
        if (next[size] - omega_start) * sense < 0.0 {
            return Err(format!(
                "the curve turned back past Ω_start = {omega_start}"
            ));
        }
        if (next[size] - omega_end) * sense > 0.0 {
            // Past the end: the point at Ω_end, from the chord between the last two.
            let f = (omega_end - y[size]) / (next[size] - y[size]);
            let guess: Vec<f64> = y.iter().zip(&next).map(|(a, b)| a + f * (b - a)).collect();
            let (end, its, rel) = problem.correct(guess, &g, &e_omega, omega_end, 50)?;
            let tangent = oriented(problem.tangent_at(&end, &g, &direction), &direction);
            let solution = to_coefficients(end, harmonics, its, rel)?;
            points.push(CurvePoint { solution, tangent });
            return Ok(points);
        }
        let tangent = oriented(problem.tangent_at(&next, &g, &direction), &direction);
        let secant: Vec<f64> = next.iter().zip(&y).map(|(a, b)| a - b).collect();
        direction = oriented(secant, &tangent);
        y = next.clone();
        points.push(CurvePoint {
            solution: to_coefficients(next, harmonics, iterations, relative)?,
            tangent,
        });
        if iterations <= 3 {
            ds = (1.5 * ds).min(steps.max);
        }
    }
    Err(format!(
        "{} points without reaching Ω_end",
        steps.max_points
    ))
}

fn normalised(v: Vec<f64>, sign: f64) -> Vec<f64> {
    let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let s = if v.last().unwrap() * sign < 0.0 {
        -1.0
    } else {
        1.0
    };
    v.iter().map(|x| s * x / norm).collect()
}

fn oriented(v: Vec<f64>, reference: &[f64]) -> Vec<f64> {
    let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let s = v
        .iter()
        .zip(reference)
        .map(|(a, b)| a * b)
        .sum::<f64>()
        .signum();
    v.iter().map(|x| s * x / norm).collect()
}

fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

/// The turning points in Ω of `curve`, located between every pair of neighbouring points whose
/// tangents' Ω-components differ in sign. Near a fold Ω is no parameter, but the coefficient
/// `z_k` with the largest tangent component is: on the chart `z_k = s` the curve is
/// `R(z, Ω) = 0, z_k = s`, its tangent from `[∂R/∂z ∂R/∂Ω; e_kᵀ] t = [0; 1]` gives
/// `g(s) = dΩ/ds = t_Ω` exactly, and the fold is the root of `g`, found by Illinois regula
/// falsi until `s` stops moving (1e-13 relative). Ω at the fold is then exact to rounding
/// (an error δs in `s` moves Ω by `O(δs²)`). Returns the responses at the folds.
pub fn folds<S: MechanicalSystem + ?Sized>(
    problem: &ForcedProblem<'_, S>,
    curve: &[CurvePoint],
) -> Result<Vec<Coefficients>, String> {
    let mut found = Vec::new();
    for pair in curve.windows(2) {
        let (p, q) = (&pair[0], &pair[1]);
        let size = p.solution.z.len();
        if p.tangent[size] * q.tangent[size] >= 0.0 {
            continue;
        }
        let harmonics = p.solution.harmonics;
        let g = problem.grid(harmonics);
        let k = (0..size)
            .max_by(|&i, &j| {
                let (a, b) = (p.tangent[i] + q.tangent[i], p.tangent[j] + q.tangent[j]);
                a.abs().total_cmp(&b.abs())
            })
            .unwrap();
        let ya: Vec<f64> = p
            .solution
            .z
            .iter()
            .copied()
            .chain([p.solution.omega])
            .collect();
        let yb: Vec<f64> = q
            .solution
            .z
            .iter()
            .copied()
            .chain([q.solution.omega])
            .collect();
        let row: Vec<f64> = (0..=size).map(|i| (i == k) as u8 as f64).collect();
        let on_chart = |s: f64| -> Result<(f64, Vec<f64>, usize, f64), String> {
            let f = (s - ya[k]) / (yb[k] - ya[k]);
            let guess = ya.iter().zip(&yb).map(|(a, b)| a + f * (b - a)).collect();
            let (y, its, rel) = problem.correct(guess, &g, &row, s, 50)?;
            let t = problem.tangent_at(&y, &g, &row);
            Ok((t[size], y, its, rel))
        };
        let (mut sa, mut sb) = (ya[k], yb[k]);
        let (mut ga, mut gb) = (on_chart(sa)?.0, on_chart(sb)?.0);
        if ga * gb > 0.0 {
            return Err(format!("no sign change of dΩ/dz_{k} near Ω = {}", ya[size]));
        }
        let (mut last_side, mut previous, mut located) = (0, f64::NAN, false);
        for _ in 0..200 {
            let s = (sa * gb - sb * ga) / (gb - ga);
            let (gs, y, its, rel) = on_chart(s)?;
            if gs == 0.0 || (s - previous).abs() <= 1e-13 * s.abs().max(1e-300) {
                found.push(to_coefficients(y, harmonics, its, rel)?);
                located = true;
                break;
            }
            previous = s;
            if gs * ga > 0.0 {
                (sa, ga) = (s, gs);
                if last_side == -1 {
                    gb *= 0.5;
                }
                last_side = -1;
            } else {
                (sb, gb) = (s, gs);
                if last_side == 1 {
                    ga *= 0.5;
                }
                last_side = 1;
            }
        }
        if !located {
            return Err(format!("fold near Ω = {} not located", ya[size]));
        }
    }
    Ok(found)
}

/// `√(a_1² + b_1²)` of `dof`.
pub fn first_harmonic_amplitude(c: &Coefficients, dof: usize) -> f64 {
    c.cosine(1)[dof].hypot(c.sine(1)[dof])
}

/// `max_τ |x_d(τ)|`: the largest of 64·(2H + 1) samples, refined by Newton on
/// `dx_d/dτ = 0` (kept within one sample spacing of the sample).
pub fn peak(c: &Coefficients, dof: usize) -> f64 {
    let samples = 64 * (2 * c.harmonics + 1);
    let spacing = 2.0 * PI / samples as f64;
    let (mut best, mut at) = (0.0f64, 0.0);
    for j in 0..samples {
        let tau = j as f64 * spacing;
        let x = c.dof_at(dof, tau)[0].abs();
        if x > best {
            (best, at) = (x, tau);
        }
    }
    let mut tau = at;
    for _ in 0..20 {
        let [_, d1, d2] = c.dof_at(dof, tau);
        if d2 == 0.0 {
            break;
        }
        let next = tau - d1 / d2;
        if (next - at).abs() > spacing {
            break;
        }
        let done = (next - tau).abs() < 1e-15;
        tau = next;
        if done {
            break;
        }
    }
    best.max(c.dof_at(dof, tau)[0].abs())
}

/// Hill's method: Floquet exponents of the response `c`. A perturbation `e^{λt} y(τ)` with
/// periodic `y` obeys `M(Ω² y_ττ + 2λΩ y_τ + λ² y) + C(Ω y_τ + λ y) + K_t(x(τ)) y = 0`; its
/// Galerkin form is the quadratic eigenproblem `(∂R/∂z + λ Δ_1 + λ² M_H) y = 0`,
/// `Δ_1 = 2Ω M_H D + C_H` (`D` the τ-derivative on the coefficients, `M_H`, `C_H` block
/// diagonal), solved as the companion matrix `[0 I; −M_H⁻¹∂R/∂z −M_H⁻¹Δ_1]`. Each exponent
/// appears shifted by `ikΩ`, `|k| ≤ H`; the truncation spoils the large shifts, so the `2n`
/// with the smallest `|Im λ|` are returned, as `(Re, Im)`. Stable when all `Re λ < 0`
/// (multipliers `e^{2πλ/Ω}` inside the unit circle).
pub fn floquet_exponents<S: MechanicalSystem + ?Sized>(
    problem: &ForcedProblem<'_, S>,
    c: &Coefficients,
) -> Result<Vec<(f64, f64)>, String> {
    let (n, g) = (problem.n, problem.grid(c.harmonics));
    let size = c.z.len();
    let jz = problem.evaluate(&c.z, c.omega, &g, true).jz.unwrap();
    let mut delta1 = Mat::<f64>::zeros(size, size);
    for i in 0..2 * c.harmonics + 1 {
        for r in 0..n {
            for col in 0..n {
                delta1[(i * n + r, i * n + col)] = problem.damping[(r, col)];
            }
        }
    }
    for h in 1..=c.harmonics {
        let (ic, is, w) = (2 * h - 1, 2 * h, 2.0 * c.omega * h as f64);
        for r in 0..n {
            for col in 0..n {
                delta1[(ic * n + r, is * n + col)] = w * problem.mass[(r, col)];
                delta1[(is * n + r, ic * n + col)] = -w * problem.mass[(r, col)];
            }
        }
    }
    let mass_lu = problem.mass.partial_piv_lu();
    let mut companion = Mat::<f64>::zeros(2 * size, 2 * size);
    for i in 0..size {
        companion[(i, size + i)] = 1.0;
    }
    for i in 0..2 * c.harmonics + 1 {
        let block = Mat::from_fn(n, 2 * size, |r, col| {
            if col < size {
                -jz[(i * n + r, col)]
            } else {
                -delta1[(i * n + r, col - size)]
            }
        });
        let solved = mass_lu.solve(&block);
        for r in 0..n {
            for col in 0..2 * size {
                companion[(size + i * n + r, col)] = solved[(r, col)];
            }
        }
    }
    let mut lambda: Vec<(f64, f64)> = companion
        .eigenvalues()
        .map_err(|e| format!("{e:?}"))?
        .into_iter()
        .map(|v| (v.re, v.im))
        .collect();
    lambda.sort_by(|a, b| a.1.abs().total_cmp(&b.1.abs()));
    lambda.truncate(2 * n);
    Ok(lambda)
}
