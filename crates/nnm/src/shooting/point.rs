//! The points of a branch of periodic motions, and [`Shooting`] as a [`ContinuationProblem`].

use super::{Evaluation, PhaseCondition, Shooting, ShootingError};
use crate::continuation::{ContinuationProblem, Detail, Solution};
use crate::floquet::Floquet;
use crate::model::MechanicalSystem;

/// A converged point of a branch.
#[derive(Debug, Clone, serde::Serialize)]
pub struct BranchPoint {
    /// Position on the branch (0 for the first point); at an event, the point it follows.
    pub index: usize,
    /// Total energy `E(z0)`.
    pub energy: f64,
    /// `dE/ds` along the unit tangent: changes sign at a fold.
    pub energy_slope: f64,
    /// Period `T` (s).
    pub period: f64,
    /// `2π / T` (rad/s).
    pub frequency: f64,
    /// Initial state `z0 = [x0; v0]`.
    pub z0: Vec<f64>,
    /// Multipliers and stability (docs/method.md §7); empty for location trials that need
    /// none.
    pub floquet: Floquet,
    /// `‖W H‖ / ‖W z0‖` at convergence (of the half-period problem when shooting over half a
    /// period).
    pub relative_residual: f64,
    /// The same over the full period, `‖W (z(T) - z0)‖ / ‖W z0‖`.
    pub full_period_residual: f64,
    /// Newton iterations of the accepted corrector.
    pub iterations: usize,
    /// Arclength step that led here (0 for the first point).
    pub step: f64,
    /// Unknowns `u = (q, τ)` and unit tangent there (for restarts and branch switching).
    pub unknowns: Vec<f64>,
    /// Unit tangent `du/ds`, oriented along the branch (docs/method.md eq. (20)).
    pub tangent: Vec<f64>,
    /// Why the point is where it is, when not a regular continuation step: placed exactly
    /// on a requested value or on the limit that ended the branch (docs/method.md eqs.
    /// (26a)–(26b)).
    pub label: Option<PointLabel>,
    /// `max_t |x_d(t)|` over the period for each of the settings' `output_dofs` (docs/method.md
    /// eq. (87)); measured by [`crate::branch`] for the points it delivers, empty otherwise.
    pub peak_displacements: Vec<f64>,
    /// The motion's largest (mode, harmonic) components by share of its time-averaged linear
    /// energy (eq. (84)); measured like `peak_displacements`.
    pub content: Vec<crate::analysis::ModalComponent>,
    /// Backbone, tongue or another family, relative to the branch's first point (eq. (86));
    /// set by [`crate::branch`] as the branch is followed.
    pub regime: Option<crate::analysis::Regime>,
    /// The force whose resonance peak this motion is, by energy balance (docs/method.md
    /// eq. (111)), when the settings ask for it; measured like `peak_displacements`.
    pub resonance: Option<crate::analysis::ResonanceForce>,
}

/// What put a point exactly where it is (the `label` column of `<branch>.csv`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PointLabel {
    /// On a value of `at_energies`.
    AtEnergy,
    /// On a value of `at_frequencies`.
    AtFrequency,
    /// On `energy_max`, ending the branch.
    EnergyMax,
    /// On `frequency_shift_max`, ending the branch.
    FrequencyShiftMax,
}

impl PointLabel {
    /// The label as written in the output (`at_energy`, `at_frequency`, `energy_max`,
    /// `frequency_shift_max`).
    pub fn name(self) -> &'static str {
        match self {
            PointLabel::AtEnergy => "at_energy",
            PointLabel::AtFrequency => "at_frequency",
            PointLabel::EnergyMax => "energy_max",
            PointLabel::FrequencyShiftMax => "frequency_shift_max",
        }
    }
}

impl<S: MechanicalSystem + ?Sized> ContinuationProblem for Shooting<'_, S> {
    type Evaluation = Evaluation;
    type Point = BranchPoint;
    type Error = ShootingError;

    fn dimension(&self) -> usize {
        self.unknowns()
    }

    fn evaluate(&mut self, u: &[f64]) -> Result<Evaluation, ShootingError> {
        let reference = std::mem::take(&mut self.phase_reference);
        let result = self.evaluate_with_reference(u, &reference);
        self.phase_reference = reference;
        result
    }

    /// With [`Detail::Full`]: the Floquet analysis (the trivial pair deflated along `g(z0)`
    /// and the family's tangent, docs/method.md eqs. (34)–(35)) and, for a half-period problem, the
    /// check that the motion really is half-wave symmetric.
    // Negated comparison deliberate: a NaN residual must fail.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    fn point(
        &mut self,
        solution: &Solution,
        evaluation: &Evaluation,
        detail: Detail,
    ) -> Result<BranchPoint, ShootingError> {
        let mut point = BranchPoint {
            index: solution.index,
            energy: self.energy(&evaluation.z0),
            energy_slope: self.energy_slope(&solution.u, &solution.tangent),
            period: evaluation.period,
            frequency: 2.0 * std::f64::consts::PI / evaluation.period,
            z0: evaluation.z0.clone(),
            floquet: Floquet::empty(),
            relative_residual: evaluation.relative_residual,
            full_period_residual: f64::NAN,
            iterations: solution.iterations,
            step: solution.step,
            unknowns: solution.u.clone(),
            tangent: solution.tangent.clone(),
            label: None,
            peak_displacements: Vec::new(),
            content: Vec::new(),
            regime: None,
            resonance: None,
        };
        if detail == Detail::Light {
            return Ok(point);
        }
        // A cyclic structure's orbit that is alike in every sector: every multiplier from a
        // few products (eq. (76e)).
        let cyclic = self
            .is_matrix_free()
            .then(|| self.cyclic_floquet(evaluation, &solution.tangent))
            .flatten();
        let floquet = match cyclic {
            Some(floquet) => floquet?,
            None => self.floquet_of(evaluation, solution)?,
        };
        if !point.energy.is_finite() {
            return Err(ShootingError::NonFiniteEnergy(point.energy));
        }
        let full_period_residual = self.full_period_residual(evaluation)?;
        if !(full_period_residual < 100.0 * self.tolerance) {
            return Err(ShootingError::NotHalfWaveSymmetric(full_period_residual));
        }
        point.floquet = floquet;
        point.full_period_residual = full_period_residual;
        Ok(point)
    }

    /// The flow-orthogonal phase condition refers to the last accepted point.
    fn accept(&mut self, point: &BranchPoint) {
        if self.phase == PhaseCondition::FlowOrthogonal {
            self.phase_reference.clone_from(&point.z0);
        }
    }
}

impl<S: MechanicalSystem + ?Sized> Shooting<'_, S> {
    /// The Floquet analysis of a point: of its dense monodromy, or of the Arnoldi projection
    /// of the matrix-free one.
    fn floquet_of(
        &mut self,
        evaluation: &Evaluation,
        solution: &Solution,
    ) -> Result<Floquet, ShootingError> {
        // The trivial pair spans the flow direction g(z0) and the direction along the family:
        // deflate it rather than guess it from the spectrum (degenerate partners also sit
        // near +1, docs/method.md §13).
        let (monodromy, [flow_direction, family_direction], class) = if self.is_matrix_free() {
            let (projected, directions) =
                self.matrix_free_monodromy(evaluation, &solution.tangent)?;
            (projected, directions, None)
        } else {
            let mut monodromy = self.monodromy(evaluation)?;
            let mut flow_direction = self.modal_coordinates(&self.field(&evaluation.z0));
            let mut family_direction =
                self.modal_coordinates(&self.initial_state(&solution.tangent));
            self.energy_scaling(&mut monodromy, [&mut flow_direction, &mut family_direction]);
            let class = self.unknown_block();
            (monodromy, [flow_direction, family_direction], class)
        };
        let floquet = self.floquet.analyse(
            &monodromy,
            [flow_direction.as_slice(), family_direction.as_slice()],
            class.as_deref(),
            (self.krein_signatures && !self.is_matrix_free())
                .then_some(self.modal_frequencies.as_slice()),
            self.stability_tolerance,
        )?;
        Ok(if self.is_matrix_free() {
            floquet.without_damped(self.stability_tolerance)
        } else {
            floquet
        })
    }

    /// `dE/ds` along the unit tangent `t` at unknowns `u`, by the five-point central
    /// difference (exact for the quartic energy of cubic springs; `O(h⁴)` otherwise, with
    /// `h = 1e-3 ‖q‖`).
    fn energy_slope(&self, u: &[f64], t: &[f64]) -> f64 {
        let z = self.initial_state(u);
        let w = self.initial_state(t);
        let h = 1e-3 * crate::linalg::norm(&u[..u.len() - 1]).max(f64::MIN_POSITIVE);
        let energy_at = |c: f64| {
            let shifted: Vec<f64> = z.iter().zip(&w).map(|(a, b)| a + c * h * b).collect();
            self.energy(&shifted)
        };
        (8.0 * (energy_at(1.0) - energy_at(-1.0)) - (energy_at(2.0) - energy_at(-2.0))) / (12.0 * h)
    }
}
