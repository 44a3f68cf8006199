//! Matrix-free forced shooting (docs/method.md eq. (102a)): the Jacobian of the shooting
//! residual as products with the recorded linearised flow, Newton corrections by GMRES, and
//! the Floquet multipliers of largest modulus by an Arnoldi process on the same products.
//!
//! **Why.** The dense formulation integrates `2n + 2` sensitivity directions and factorises a
//! `(2n + 1)`-square Jacobian, then takes every eigenvalue of the `2n`-square monodromy: O(n²)
//! memory and O(n² · steps + n³) work a point — a minute a point at 2,000 dofs. Damped and
//! integrated by Radau IIA (L-stable), a finite-element model's unresolved modes decay over
//! a forcing period, so `P Φ` is numerically of the rank of the few resolved modes and
//! `P Φ − I` is `−I` plus that rank: GMRES converges in about that many products, each a
//! replay of the recorded steps (one stage solve a step, no factorisation), whatever `n`.
//!
//! **Coordinates.** The unknowns are the problem's scaled ones (`u = D⁻¹ z0`, `D` the
//! displacement and velocity scales): the Jacobian's state block is `D⁻¹ P Φ D − I`, its last
//! column the parameter sensitivity `D⁻¹ P ∂z/∂p · s_p`.

use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use crate::integrate::LinearizedFlow;
use crate::krylov::{Arnoldi, gmres};
use crate::linalg::{self, Complex, DenseLu, Mat};

/// Relative residual each GMRES solve is taken to: well below the continuation's tolerance,
/// so that the corrector converges as with the exact Jacobian.
const GMRES_TOLERANCE: f64 = 1e-11;
/// A linear residual below this fraction of the continuation's tolerance (times the
/// unknowns' norm) is small enough whatever the right-hand side (inexact Newton, eq. (74a)).
const NEWTON_FORCING: f64 = 1e-3;
/// The accuracy GMRES's products take each step's split stage solve to, relative to the state
/// the step ends in (docs/method.md eq. (32g)): the products then come out within about that
/// of exact ones, and an inexact Newton correction contracts by about that. Why not to
/// round-off: on the 10⁴-dof von Kármán beam (Radau9) this takes 1.7 refinement sweeps a
/// solve against 3.9, for the same corrections (residuals 1e-11–1e-9 after one iteration).
/// Arnoldi's products are exact: the multipliers decide stability.
const NEWTON_PRODUCT_ACCURACY: f64 = 1e-4;
/// Most GMRES products a solve (memory: this many vectors of `2n + 1`).
const MAX_GMRES: usize = 400;
/// Most Arnoldi steps of a Floquet analysis, and the new direction's size below which the
/// Krylov space counts as invariant (the rest of the spectrum damped below it).
const MAX_ARNOLDI: usize = 120;
/// Fewest Arnoldi steps before the Ritz values above the floor may be taken as converged, and
/// the steps in a row their converged set must keep its size.
const MIN_ARNOLDI: usize = 8;
const SETTLED_STEPS: usize = 3;
const ARNOLDI_INVARIANT: f64 = 1e-10;

/// The Jacobian of the forced shooting rows with respect to the scaled unknowns, as products.
pub struct ForcedOperator {
    flow: Arc<dyn LinearizedFlow>,
    /// `P` of the shot map, per state coordinate: `+1` over a whole period, the half-wave
    /// symmetry's signs `S` over half of one (eq. (99b)).
    flip: Vec<f64>,
    /// `D`: the scale of each state coordinate.
    scales: Vec<f64>,
    /// `∂rows/∂u_p`, the parameter's column.
    parameter_column: Vec<f64>,
    /// A linear residual small enough whatever `‖b‖` (eq. (74a)).
    enough: f64,
    /// Products made, counted for the curve's statistics.
    products: Arc<AtomicUsize>,
    /// The shot map's Krylov space at a recent point, which preconditions the solves.
    subspace: Option<Arc<Subspace>>,
}

/// The shot map's dominant Krylov space at a point: `V` (orthonormal, `k` vectors) and its
/// image `U = A V`, from the Arnoldi process of that point's Floquet analysis. The shot map
/// of the next points is close to `U Vᵀ`: a damped model's other directions decay over the
/// period (module notes), and the point has moved little. So `[U Vᵀ − I, c; bᵀ, 0]`, solved
/// in the `k + 1` coordinates, preconditions the next bordered solves (eq. (102b)).
pub(super) struct Subspace {
    basis: Vec<Vec<f64>>,
    images: Vec<Vec<f64>>,
    /// `I − VᵀU` (`k × k`), the same in every bordered solve it preconditions.
    projected: Vec<Vec<f64>>,
}

impl Subspace {
    /// The space of the first `k` Arnoldi vectors (`k` the steps taken): `U = V_(k+1) H̄`.
    fn of(arnoldi: &Arnoldi) -> Option<Self> {
        let k = arnoldi.steps();
        let (basis, columns) = (&arnoldi.basis, arnoldi.columns());
        if k == 0 {
            return None;
        }
        let n = basis[0].len();
        let images: Vec<Vec<f64>> = columns
            .iter()
            .map(|h| {
                let mut u = vec![0.0; n];
                for (v, &c) in basis.iter().zip(h) {
                    u.iter_mut().zip(v).for_each(|(u, v)| *u += c * v);
                }
                u
            })
            .collect();
        let basis = basis[..k].to_vec();
        let projected = (0..k)
            .map(|i| {
                (0..k)
                    .map(|j| {
                        let identity = if i == j { 1.0 } else { 0.0 };
                        identity - linalg::dot(&basis[i], &images[j])
                    })
                    .collect()
            })
            .collect();
        Some(Self {
            basis,
            images,
            projected,
        })
    }

    /// The preconditioner of the bordered solve with parameter column `c` and border `b`:
    /// `None` when its small system is singular.
    fn bordered<'a>(&'a self, c: &'a [f64], b: &'a [f64]) -> Option<Preconditioner<'a>> {
        let k = self.basis.len();
        let n2 = c.len();
        let (vc, bu): (Vec<f64>, Vec<f64>) = (
            self.basis.iter().map(|v| linalg::dot(v, c)).collect(),
            self.images
                .iter()
                .map(|u| linalg::dot(&b[..n2], u))
                .collect(),
        );
        let bc = linalg::dot(&b[..n2], c);
        // [[I − VᵀU, −Vᵀc], [bᵀU, bᵀc]] (the border's own last entry multiplies η too).
        let small = Mat::from_fn(k + 1, k + 1, |i, j| match (i < k, j < k) {
            (true, true) => self.projected[i][j],
            (true, false) => -vc[i],
            (false, true) => bu[j],
            (false, false) => bc + b[n2],
        });
        let lu = DenseLu::new(small.as_ref());
        // A singular system leaves non-finite solutions: tried on a unit vector.
        let mut probe = vec![1.0; k + 1];
        lu.solve_in_place(&mut probe, 1);
        probe
            .iter()
            .all(|x| x.is_finite())
            .then_some(Preconditioner {
                subspace: self,
                c,
                b,
                lu,
            })
    }
}

/// `[U Vᵀ − I, c; bᵀ, b_p]⁻¹` by elimination in the subspace's coordinates (eq. (102b)).
struct Preconditioner<'a> {
    subspace: &'a Subspace,
    c: &'a [f64],
    b: &'a [f64],
    lu: DenseLu,
}

impl Preconditioner<'_> {
    /// `[y; η]` with `−y + U Vᵀ y + c η = r`, `bᵀ [y; η] = ρ`: `y = U α + c η − r` where
    /// `α = Vᵀ y` solves the small system.
    fn apply(&self, w: &[f64]) -> Vec<f64> {
        let n2 = self.c.len();
        let k = self.subspace.basis.len();
        let r = &w[..n2];
        let mut small: Vec<f64> = self
            .subspace
            .basis
            .iter()
            .map(|v| -linalg::dot(v, r))
            .collect();
        small.push(w[n2] + linalg::dot(&self.b[..n2], r));
        self.lu.solve_in_place(&mut small, 1);
        let eta = small[k];
        let mut y: Vec<f64> = self.c.iter().zip(r).map(|(c, r)| c * eta - r).collect();
        for (u, &a) in self.subspace.images.iter().zip(&small) {
            y.iter_mut().zip(u).for_each(|(y, u)| *y += a * u);
        }
        y.push(eta);
        y
    }
}

impl std::fmt::Debug for ForcedOperator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ForcedOperator")
            .field("dimension", &self.scales.len())
            .finish()
    }
}

impl ForcedOperator {
    /// The operator of one exact evaluation: the recorded `flow`, the shot map's sign
    /// `flip` (per state coordinate), the unknowns' `scales`, and the parameter's column of
    /// the Jacobian;
    /// `tolerance` the continuation's and `size` the unknowns' norm (the linear solves'
    /// floor).
    pub(super) fn new(
        flow: Arc<dyn LinearizedFlow>,
        flip: Vec<f64>,
        scales: Vec<f64>,
        parameter_column: Vec<f64>,
        tolerance: f64,
        size: f64,
        products: Arc<AtomicUsize>,
    ) -> Self {
        Self {
            flow,
            flip,
            scales,
            parameter_column,
            enough: NEWTON_FORCING * tolerance * size,
            products,
            subspace: None,
        }
    }

    /// The operator whose bordered solves are preconditioned by `subspace`, a recent point's
    /// Krylov space (eq. (102b)); `None`: not preconditioned.
    pub(super) fn preconditioned_by(mut self, subspace: Option<Arc<Subspace>>) -> Self {
        self.subspace = subspace;
        self
    }

    /// `out = D⁻¹ P Φ D y`: the shot map's derivative in the scaled unknowns, exact or to
    /// `accuracy` relative.
    fn shot_map(&self, y: &[f64], out: &mut [f64], accuracy: Option<f64>) {
        let d: Vec<f64> = y.iter().zip(&self.scales).map(|(y, s)| y * s).collect();
        match accuracy {
            Some(accuracy) => self.flow.apply_approximately(&d, 1, out, accuracy),
            None => self.flow.apply(&d, 1, out),
        }
        self.products.fetch_add(1, Ordering::Relaxed);
        for ((o, s), p) in out.iter_mut().zip(&self.scales).zip(&self.flip) {
            *o *= p / s;
        }
    }

    /// Solves the bordered system `[J; bᵀ] x = (rhs, c)` by GMRES, `J = [D⁻¹PΦD − I, ∂rows/∂u_p]`
    /// (square: the matrix-free formulation serves models without rigid-body modes).
    pub(super) fn solve_bordered(&self, border: &[f64], rhs: &[f64], border_rhs: f64) -> Vec<f64> {
        let n2 = self.scales.len();
        let apply = |x: &[f64], out: &mut [f64]| {
            self.shot_map(&x[..n2], &mut out[..n2], Some(NEWTON_PRODUCT_ACCURACY));
            for i in 0..n2 {
                out[i] += self.parameter_column[i] * x[n2] - x[i];
            }
            out[n2] = linalg::dot(border, x);
        };
        let mut b = Vec::with_capacity(n2 + 1);
        b.extend_from_slice(rhs);
        b.push(border_rhs);
        let tolerances = (GMRES_TOLERANCE, self.enough);
        // Right-preconditioned by a recent point's Krylov space (eq. (102b)): the residual
        // GMRES minimises is the unpreconditioned one.
        let preconditioner = self
            .subspace
            .as_deref()
            .and_then(|s| s.bordered(&self.parameter_column, border));
        match preconditioner {
            Some(p) => {
                let preconditioned = |w: &[f64], out: &mut [f64]| apply(&p.apply(w), out);
                p.apply(&gmres(preconditioned, &b, tolerances, MAX_GMRES, None).x)
            }
            None => gmres(apply, &b, tolerances, MAX_GMRES, None).x,
        }
    }

    /// The eigenvalues of modulus at least `floor` of the shot map `P Φ(span)` (over half a
    /// period, the multipliers' square roots, eq. (99b)), by an Arnoldi process until each
    /// has converged to [`ARNOLDI_INVARIANT`] — or, when the space becomes invariant first,
    /// every eigenvalue (at [`MAX_ARNOLDI`] steps: every Ritz value, converged or not). Why not always to invariance: a lightly damped mesh has dozens of
    /// multipliers between 1e-10 and the floor (the 200-element von Kármán beam: ~30), which
    /// cannot take part in a crossing of the unit circle but cost a product each. Why a fixed
    /// mixture of every coordinate as the start: it reaches every mode. Returned with the
    /// Krylov space the process built, which preconditions the next solves ([`Subspace`]).
    pub(super) fn shot_map_eigenvalues(
        &self,
        floor: f64,
    ) -> Result<(Vec<Complex>, Option<Subspace>), linalg::LinalgError> {
        let n2 = self.scales.len();
        let mixture: Vec<f64> = (0..n2)
            .map(|i| ((i as f64) * 0.618_033_988_75 + 0.5).sin())
            .collect();
        let mut arnoldi = Arnoldi::new(&mixture).ok_or(linalg::LinalgError::NonFinite)?;
        let mut product = |y: &[f64], out: &mut [f64]| self.shot_map(y, out, None);
        // How many steps in a row the same number of Ritz values above the floor has
        // converged: an eigenvalue the start reaches weakly shows up late, so the set must
        // hold for a few steps (and some must lie above the floor: a response damped below
        // it everywhere is analysed to invariance, so its largest multiplier is still given).
        let mut settled = (0, 0);
        while !arnoldi.invariant && arnoldi.steps() < MAX_ARNOLDI.min(n2) {
            arnoldi.step(&mut product, 1e-14, ARNOLDI_INVARIANT);
            if arnoldi.invariant || arnoldi.steps() < MIN_ARNOLDI {
                continue;
            }
            match arnoldi.converged_ritz_values(floor, ARNOLDI_INVARIANT) {
                Some(values) if !values.is_empty() => {
                    settled = if settled.0 == values.len() {
                        (values.len(), settled.1 + 1)
                    } else {
                        (values.len(), 1)
                    };
                    if settled.1 >= SETTLED_STEPS {
                        return Ok((values, Subspace::of(&arnoldi)));
                    }
                }
                _ => settled = (0, 0),
            }
        }
        let values = linalg::eigenvalues(arnoldi.hessenberg().as_ref())?;
        Ok((values, Subspace::of(&arnoldi)))
    }
}
