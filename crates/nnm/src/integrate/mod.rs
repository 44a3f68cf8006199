//! Time integration of the motion `z' = g(z)` together with its sensitivities
//! `Φ' = J(z(t)) Φ` (docs/method.md eqs. (3), (11)).
//!
//! [`Integrator`] is the plug-in point: shooting asks it for the flow over one period (or half)
//! and the derivative of that flow along a block of directions, and for the vector field. The
//! implementations compute the sensitivities as the exact derivative of their own discrete
//! flow ("internal differentiation", eq. (29)), so that the shooting Jacobian is the Jacobian
//! of what Newton solves: [`RungeKutta`], explicit embedded pairs ([`DOP853`] by default,
//! [`DOPRI5`]) for non-stiff models, and [`GaussLegendre`] (`collocation/`), implicit
//! collocation for stiff finite-element models; [`IntegrationMethod`] chooses between them.

mod collocation;
pub mod forced;
mod kernels;
mod runge_kutta;
mod tableau;

pub use collocation::{
    Collocation, CollocationLinearization, GAUSS4, GAUSS6, GaussLegendre, RADAU5, RADAU9,
    SPLIT_DOFS,
};
pub use runge_kutta::RungeKutta;
pub use tableau::{DOP853, DOPRI5, ErrorEstimate, Tableau};

use std::sync::Arc;

use crate::model::Block;

/// Integrates the motion of one system and, on request, its variational equations.
pub trait Integrator {
    /// Integrates `z' = g(z)` from `z0` over `duration`; when `sensitivity` is given (the
    /// `2n × k` initial block `Φ(0)`, column-major), also `Φ(t)` on the same steps.
    fn flow(
        &mut self,
        z0: &[f64],
        duration: f64,
        sensitivity: Option<Block<'_>>,
        steps: Steps<'_>,
    ) -> Result<Flow, IntegrationError>;

    /// Integrates like [`Integrator::flow`] (no sensitivities) and keeps what the discrete
    /// flow's linearisation needs, so that `Φ(T) D` can be applied afterwards to any block `D`
    /// without integrating the motion again: matrix-free shooting (docs/method.md §15) asks for
    /// a few such products per Newton iteration instead of `Φ` along every direction. The
    /// default refuses: an integrator must record its steps to offer it.
    fn flow_linearized(
        &mut self,
        _z0: &[f64],
        _duration: f64,
        _steps: Steps<'_>,
    ) -> Result<(Flow, Arc<dyn LinearizedFlow>), IntegrationError> {
        Err(IntegrationError::InvalidInput(
            "this integrator does not record its linearisation; matrix-free shooting needs \
             an implicit collocation method (gauss4, gauss6, radau5, radau9)"
                .into(),
        ))
    }

    /// The states at the ends of `samples` equal divisions of `duration` (the start excluded,
    /// the end included), without sensitivities; `steps` applies to each division. With them,
    /// the whole integration's work counters and step sizes. The default integrates each
    /// division by [`Integrator::flow`]; an integrator that keeps work from step to step (a
    /// factorised stage matrix) overrides it to do all in one pass.
    fn flow_sampled(
        &mut self,
        z0: &[f64],
        duration: f64,
        samples: usize,
        steps: Steps<'_>,
    ) -> Result<(Flow, Vec<Vec<f64>>), IntegrationError> {
        sampled_by_divisions(self, z0, duration, samples, steps)
    }

    /// The vector field `g(z)` (eq. (3)).
    fn field(&self, z: &[f64], out: &mut [f64]);

    /// Total energy of the state `z` (eq. (2)).
    fn energy(&self, z: &[f64]) -> f64;

    /// The local error tolerances in force.
    fn tolerances(&self) -> Tolerances;

    /// Sets the local error tolerances (shooting scales the absolute one to the motion).
    fn set_tolerances(&mut self, tolerances: Tolerances);
}

/// [`Integrator::flow_sampled`] one division at a time (an adaptive integration starts each
/// division with the previous one's last step).
pub(crate) fn sampled_by_divisions<I: Integrator + ?Sized>(
    integrator: &mut I,
    z0: &[f64],
    duration: f64,
    samples: usize,
    steps: Steps<'_>,
) -> Result<(Flow, Vec<Vec<f64>>), IntegrationError> {
    let h = duration / samples.max(1) as f64;
    let mut states: Vec<Vec<f64>> = Vec::with_capacity(samples);
    let mut total = Flow {
        z: z0.to_vec(),
        sensitivity: Vec::new(),
        columns: 0,
        steps: Vec::new(),
        stats: IntegrationStats::default(),
    };
    for _ in 0..samples.max(1) {
        let division = match steps {
            Steps::Adaptive { first_step } => Steps::Adaptive {
                first_step: total.steps.last().copied().or(first_step),
            },
            replay => replay,
        };
        let flow = integrator.flow(&total.z, h, None, division)?;
        total.stats += flow.stats;
        total.steps.extend(&flow.steps);
        total.z.clone_from(&flow.z);
        states.push(flow.z);
    }
    Ok((total, states))
}

/// The derivative of one integration's discrete flow map, `D ↦ Φ(T) D`, recorded by
/// [`Integrator::flow_linearized`]: exactly what the sensitivities integrated with the motion
/// would give along `D`.
pub trait LinearizedFlow: Send + Sync {
    /// The state dimension `2n`.
    fn dimension(&self) -> usize;
    /// `out = Φ(T) D` for `columns` directions `D` (`2n × columns`, column-major).
    fn apply(&self, directions: &[f64], columns: usize, out: &mut [f64]);
    /// `out ≈ Φ(T) D` to about `accuracy` relative: what a Newton correction needs, cheaper
    /// where the exact products iterate (the split stage systems, eq. (32f)). Exact unless
    /// a flow says otherwise.
    fn apply_approximately(
        &self,
        directions: &[f64],
        columns: usize,
        out: &mut [f64],
        _accuracy: f64,
    ) {
        self.apply(directions, columns, out);
    }
}

/// The integration schemes available from settings and job files.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum IntegrationMethod {
    /// Chosen per branch from the model's stiffness ([`IntegrationMethod::resolve`]):
    /// [`IntegrationMethod::Dop853`] unless the highest linear frequency exceeds
    /// [`STIFF_RATIO`] times the branch's, then [`IntegrationMethod::Gauss6`] up to
    /// [`SYMPLECTIC_DOFS`] dofs and [`IntegrationMethod::Radau9`] above.
    #[default]
    Auto,
    /// Dormand–Prince 8(5,3) (4-6x fewer evaluations than DOPRI5 at the shooting tolerances
    /// used here; see runge_kutta.rs).
    Dop853,
    /// Dormand–Prince 5(4).
    Dopri5,
    /// Two-stage Gauss–Legendre collocation (implicit, order 4, symplectic): for stiff models.
    Gauss4,
    /// Three-stage Gauss–Legendre collocation (implicit, order 6, symplectic): for stiff models.
    Gauss6,
    /// Three-stage Radau IIA collocation (implicit, order 5, L-stable: damps the unresolved
    /// stiff modes).
    Radau5,
    /// Five-stage Radau IIA collocation (implicit, order 9, L-stable): the stiff integrator
    /// above [`SYMPLECTIC_DOFS`], where order 5 needs two to ten times the steps.
    Radau9,
}

/// Above this ratio of the highest linear frequency to the branch's, [`IntegrationMethod::Auto`]
/// integrates implicitly. An explicit pair's step is held by stability to `ω_max h ≲ 5`, while
/// the motion needs about `ω h ≈ 0.1`: from ~50× on, stability sets the step. Measured: at
/// 1414× (a stiff 2-DOF model) DOP853 takes 1232 steps a half period against Gauss6's 35, at
/// ~4000× (the ECL beam) a branch takes 580 s against 14.5 s; the bladed disk (≤ 14×), Duffing
/// and the two-DOF system stay explicit.
pub const STIFF_RATIO: f64 = 100.0;

/// Stiff models of at most this many dofs are integrated by [`IntegrationMethod::Gauss6`],
/// larger ones by [`IntegrationMethod::Radau9`] (docs/method.md §6, "aliasing").
///
/// Why order 9 rather than Radau5 above: the Richardson estimate of the slow part's global
/// error (eq. (32d)) sets the steps, and order 5 needs 2.2–4× as many for 5/3 of the stages.
/// Measured, `nnm run`, events off unless said: ECL beam to +20%, 100 elements 1.75 → 1.47 s
/// (9,871 → 4,334 steps), 400 elements 8.1 → 7.0 s; von Kármán beam, 200 elements, to +8%,
/// events on: 45.1 → 43.4 s, 384 → 281 MB (the +8% point's energy the same to 4e-10); the
/// 513-dof hex27 box, first 4 points: 49 → 25 s, 1.18 → 0.79 GB (115 → 28 steps an
/// integration), the points the same to 1e-9.
///
/// Gauss–Legendre keeps every unresolved mode on the unit circle with an aliased phase, and
/// the more modes a mesh has, the more of them fall near a resonance with the motion's
/// harmonics in the discrete flow. Measured on the ECL beam to +20%: at 19 elements (38 dofs)
/// Gauss6 is exact to 1e-11 against harmonic balance and faster; at 50 elements it crawled
/// through aliased resonance tongues (320 points, 86 s, 77 points flagged unstable with
/// `|μ|` up to 1.0099, none of them physical), and from 70 elements the first point did not
/// converge. Radau IIA damps the unresolved modes (`R(∞) = 0`): 26 points in 7 s at 50
/// elements, 20 points in 30 s at 100, 2.8e-11 against harmonic balance at 19; the price is
/// that the resolved modes' multipliers sit inside the unit circle by the scheme's
/// dissipation (`1 − |μ| ≈ 1e-5` for the second mode of the 50-element beam).
pub const SYMPLECTIC_DOFS: usize = 64;

impl IntegrationMethod {
    /// The concrete method for a branch of `system` at angular frequency `omega`: `Auto`
    /// estimates the highest linear frequency by power iteration on `M⁻¹ K_t(0)` (an order of
    /// magnitude is all it needs) and compares it with [`STIFF_RATIO`]` × omega`.
    pub fn resolve<S: crate::model::MechanicalSystem + ?Sized>(
        self,
        system: &S,
        omega: f64,
    ) -> IntegrationMethod {
        if self != IntegrationMethod::Auto {
            return self;
        }
        let form = crate::model::ExplicitForm::new(system);
        let n = system.dofs();
        let zero = vec![0.0; n];
        let mut v: Vec<f64> = (0..n).map(|i| 1.0 + ((i * 7919) % 13) as f64).collect();
        let mut lambda = 0.0f64;
        let mut av = vec![0.0; n];
        for _ in 0..40 {
            let norm = crate::linalg::norm(&v);
            if !(norm > 0.0 && norm.is_finite()) {
                break;
            }
            v.iter_mut().for_each(|x| *x /= norm);
            form.acceleration_tangent(&zero, &v, 1, &mut av);
            lambda = crate::linalg::norm(&av);
            std::mem::swap(&mut v, &mut av);
        }
        if lambda.sqrt() <= STIFF_RATIO * omega {
            IntegrationMethod::Dop853
        } else if n <= SYMPLECTIC_DOFS {
            IntegrationMethod::Gauss6
        } else {
            IntegrationMethod::Radau9
        }
    }

    /// The relative tolerance the method is given for a shooting tolerance `tolerance`. The
    /// explicit pairs control the *local* error of every step, which accumulates over the
    /// period: `factor × tolerance` (`integration_factor`, default 1e-3). The collocation
    /// methods estimate the *global* error over the horizon directly, so a tenth of the
    /// tolerance is enough for Newton to converge to it — and a tighter target would make them
    /// resolve stiff modes excited only at round-off-like amplitudes.
    pub fn relative_tolerance(self, tolerance: f64, factor: f64) -> f64 {
        match self {
            IntegrationMethod::Dop853 | IntegrationMethod::Dopri5 | IntegrationMethod::Auto => {
                factor * tolerance
            }
            IntegrationMethod::Gauss4
            | IntegrationMethod::Gauss6
            | IntegrationMethod::Radau5
            | IntegrationMethod::Radau9 => 0.1 * tolerance,
        }
    }

    /// Every variant, in declaration order.
    pub const ALL: [IntegrationMethod; 7] = [
        IntegrationMethod::Auto,
        IntegrationMethod::Dop853,
        IntegrationMethod::Dopri5,
        IntegrationMethod::Gauss4,
        IntegrationMethod::Gauss6,
        IntegrationMethod::Radau5,
        IntegrationMethod::Radau9,
    ];

    /// The method's name in job files and settings (serde's kebab-case spelling), for
    /// messages that name it.
    pub fn name(self) -> &'static str {
        match self {
            IntegrationMethod::Auto => "auto",
            IntegrationMethod::Dop853 => "dop853",
            IntegrationMethod::Dopri5 => "dopri5",
            IntegrationMethod::Gauss4 => "gauss4",
            IntegrationMethod::Gauss6 => "gauss6",
            IntegrationMethod::Radau5 => "radau5",
            IntegrationMethod::Radau9 => "radau9",
        }
    }

    /// Left to the branch: [`Self::resolve`] picks the method from the model's stiffness, and
    /// shooting may still trade it for one its formulation needs (a collocation method for
    /// matrix-free shooting). A method named by the user is kept as it is.
    pub fn is_auto(self) -> bool {
        self == IntegrationMethod::Auto
    }

    /// A collocation method (Gauss–Legendre, Radau IIA): implicit, and able to record its
    /// linearised steps for matrix-free shooting. Its steps are equal, their number set from
    /// a global error estimate over the horizon ([`Self::relative_tolerance`]), so a
    /// converged point's motion can be sampled on the shooting's own step.
    pub fn is_collocation(self) -> bool {
        matches!(
            self,
            IntegrationMethod::Gauss4
                | IntegrationMethod::Gauss6
                | IntegrationMethod::Radau5
                | IntegrationMethod::Radau9
        )
    }

    /// Symplectic (Gauss–Legendre): `|R(iωh)| = 1`, so every mode, resolved or not, keeps its
    /// multipliers on the unit circle — neither damped nor amplified, only its phase aliased
    /// when unresolved (docs/method.md §6). The choice when nothing may be damped.
    pub fn is_symplectic(self) -> bool {
        matches!(self, IntegrationMethod::Gauss4 | IntegrationMethod::Gauss6)
    }

    /// Damps the modes its step does not resolve (Radau IIA, L-stable: `R(∞) = 0`;
    /// docs/method.md §6, "Aliasing, and the damping collocation"). Their multipliers fall
    /// inside the unit circle without reciprocal partners, so stability sees only the
    /// resolved modes; and their block of `Φ(T)` is numerically zero, so GMRES on `Φ − I`
    /// converges in about the rank of the resolved modes (docs/method.md §15), which makes
    /// matrix-free shooting the cheaper formulation.
    pub fn damps_unresolved_modes(self) -> bool {
        matches!(self, IntegrationMethod::Radau5 | IntegrationMethod::Radau9)
    }

    /// The integrator of this method for `system` (`Auto` unresolved: DOP853; resolve first).
    pub fn integrator<'a, S: crate::model::MechanicalSystem + ?Sized>(
        self,
        system: &'a S,
        tolerances: Tolerances,
    ) -> Box<dyn Integrator + 'a> {
        match self {
            IntegrationMethod::Dop853 | IntegrationMethod::Auto => {
                Box::new(RungeKutta::new(system, &DOP853, tolerances))
            }
            IntegrationMethod::Dopri5 => Box::new(RungeKutta::new(system, &DOPRI5, tolerances)),
            IntegrationMethod::Gauss4 => Box::new(GaussLegendre::new(system, &GAUSS4, tolerances)),
            IntegrationMethod::Gauss6 => Box::new(GaussLegendre::new(system, &GAUSS6, tolerances)),
            IntegrationMethod::Radau5 => Box::new(GaussLegendre::new(system, &RADAU5, tolerances)),
            IntegrationMethod::Radau9 => Box::new(GaussLegendre::new(system, &RADAU9, tolerances)),
        }
    }
}

/// Time integration: the method, and its accuracy relative to the continuation tolerance
/// ([`IntegrationMethod::relative_tolerance`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct IntegrationSettings {
    /// The integration method (default [`IntegrationMethod::Auto`]: chosen per branch from
    /// the model's stiffness).
    pub integrator: IntegrationMethod,
    /// Integrator relative tolerance as a fraction of the continuation tolerance (default
    /// 1e-3: the integration error must sit well below the residual Newton converges to).
    pub integration_factor: f64,
}

impl Default for IntegrationSettings {
    fn default() -> Self {
        Self {
            integrator: IntegrationMethod::Auto,
            integration_factor: 1e-3,
        }
    }
}

/// Local error tolerances: a step is accepted when the scaled error norm
/// `‖err_i / (atol_i + relative·max(|z_i|, |z_new,i|))‖_rms ≤ 1`, with `atol_i = absolute`
/// for displacements and `absolute · velocity_scale` for velocities (velocities are a
/// frequency times displacements: the scale keeps the test independent of the time unit).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerances {
    /// Relative tolerance, on `max(|z_i|, |z_new,i|)`.
    pub relative: f64,
    /// Absolute tolerance of the displacements (shooting sets it from the motion's size).
    pub absolute: f64,
    /// Factor on `absolute` for the velocities: a frequency (shooting uses `ω_ref`).
    pub velocity_scale: f64,
}

impl Tolerances {
    /// Absolute tolerance of state component `i` of `n2`.
    pub(crate) fn absolute_at(&self, i: usize, n2: usize) -> f64 {
        if 2 * i < n2 {
            self.absolute
        } else {
            self.absolute * self.velocity_scale
        }
    }
}

/// How steps are chosen.
#[derive(Debug, Clone, Copy)]
pub enum Steps<'a> {
    /// Error-controlled steps; `first_step` skips the initial-step heuristic.
    Adaptive {
        /// First step size to try (e.g. the previous integration's); `None`: estimated.
        first_step: Option<f64>,
    },
    /// Exactly these step sizes (e.g. a base run's, so that finite-difference perturbations
    /// see the same discrete map).
    Replay(&'a [f64]),
}

/// Work counters of one integration.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct IntegrationStats {
    /// Accepted steps.
    pub steps: usize,
    /// Steps rejected by the error control and retried smaller.
    pub rejected_steps: usize,
    /// Of those, the steps the motion passed but its sensitivities did not (eq. (31b)).
    pub variational_rejections: usize,
    /// Evaluations of the vector field `g(z)`.
    pub rhs_evaluations: usize,
    /// Evaluations of the tangent `A(x)` applied to a block of directions.
    pub tangent_evaluations: usize,
    /// Factorisations of an implicit method's stage system (whole, its low-rank update, or
    /// its split systems together counting one).
    pub factorisations: usize,
}

impl std::ops::AddAssign for IntegrationStats {
    fn add_assign(&mut self, o: Self) {
        self.steps += o.steps;
        self.rejected_steps += o.rejected_steps;
        self.variational_rejections += o.variational_rejections;
        self.rhs_evaluations += o.rhs_evaluations;
        self.tangent_evaluations += o.tangent_evaluations;
        self.factorisations += o.factorisations;
    }
}

/// The end state, the propagated sensitivities and how it was obtained.
#[derive(Debug, Clone)]
pub struct Flow {
    /// `z(T)`.
    pub z: Vec<f64>,
    /// `Φ(T)`, `2n × columns`, column-major (empty when no sensitivities were asked).
    pub sensitivity: Vec<f64>,
    /// Number `k` of directions propagated (0 without sensitivities).
    pub columns: usize,
    /// The accepted step sizes, in order.
    pub steps: Vec<f64>,
    /// Work counters of this integration.
    pub stats: IntegrationStats,
}

/// Why an integration failed.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum IntegrationError {
    /// The adaptive integration needed more than its step budget.
    #[error("time integration exceeded {max_steps} steps at t = {t:.6e}")]
    TooManySteps {
        /// The step budget.
        max_steps: usize,
        /// Time reached when it ran out.
        t: f64,
    },
    /// The step size fell below `1e-14` of the duration.
    #[error("time step became too small at t = {t:.6e} (stiff or diverging motion)")]
    StepSizeUnderflow {
        /// Time at which the step collapsed.
        t: f64,
    },
    /// The state became NaN or infinite.
    #[error("the motion became non-finite at t = {t:.6e}")]
    NotFinite {
        /// Start of the step that produced it (0 for a non-finite initial state).
        t: f64,
    },
    /// An implicit step's stage equations did not converge: the step is too long for the
    /// stage iteration (a forced integration retries on more steps).
    #[error(
        "the stage equations did not converge at t = {t:.6e}; tighten the tolerance or choose \
         another integrator"
    )]
    StagesDiverged {
        /// Start of the step.
        t: f64,
    },
    /// The request itself is wrong: a state or block of the wrong size, or a non-positive
    /// duration (the text says which).
    #[error("invalid integration request: {0}")]
    InvalidInput(String),
}

/// The checks every integrator makes of a request before it integrates: a state of `n2`
/// finite entries, a positive finite duration, a sensitivity block of `n2` rows.
// Negated comparison deliberate: a NaN duration must fail.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub(crate) fn check_request(
    z0: &[f64],
    n2: usize,
    duration: f64,
    sensitivity: Option<Block<'_>>,
) -> Result<(), IntegrationError> {
    if z0.len() != n2 {
        return Err(IntegrationError::InvalidInput(format!(
            "state has length {}, expected {n2}",
            z0.len()
        )));
    }
    if !(duration.is_finite() && duration > 0.0) {
        return Err(IntegrationError::InvalidInput(format!(
            "duration must be positive, got {}",
            crate::number::Number(duration)
        )));
    }
    if let Some(b) = sensitivity
        && b.rows != n2
    {
        return Err(IntegrationError::InvalidInput(format!(
            "sensitivity block has {} rows, expected {n2}",
            b.rows
        )));
    }
    if z0.iter().any(|v| !v.is_finite()) {
        return Err(IntegrationError::NotFinite { t: 0.0 });
    }
    Ok(())
}

#[cfg(test)]
mod tests;
