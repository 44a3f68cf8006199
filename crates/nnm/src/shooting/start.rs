//! Where a branch starts: the space of allowed initial states, the scales of the unknowns and
//! a first guess — from a linear mode of any [`MechanicalSystem`], or from a user's state and
//! period.

use super::{PhaseCondition, SettingsView, ShiftSymmetry, Shooting, ShootingSetup, Travel};
use crate::linalg;
use crate::model::MechanicalSystem;
use crate::modes::{LinearMode, ModesError, StandingWave, linear_modes};
use crate::symmetry::{Parity, invariant_class, is_odd, parity_of, sample_states};

/// Where a branch starts.
#[derive(Debug, Clone)]
pub struct Start {
    /// Elastic basis `B` (`n × r`, column-major, mass-orthonormal): all elastic modes, the
    /// first `unknown_columns` spanning the subspace the branch lives in.
    pub basis: Vec<f64>,
    /// `M B`.
    pub mass_basis: Vec<f64>,
    /// How many leading columns of `basis` carry the shooting unknowns.
    pub unknown_columns: usize,
    /// The mirror-symmetry class the unknowns were restricted to, if any.
    pub symmetry: Option<Parity>,
    /// Modal amplitude at which the nonlinear forces equal the linear ones along the starting
    /// mode: the amplitude unit of the continuation (see [`ShootingSetup::amplitude_scale`]).
    pub amplitude_scale: f64,
    /// Reference (linear) angular frequency of the branch.
    pub omega: f64,
    /// Initial guess of `z0` (length 2n).
    pub z0: Vec<f64>,
    /// Initial guess of the period.
    pub period: f64,
    /// Whether half-period shooting may be used (when the system is odd and the settings
    /// allow it); false for a branch that breaks the half-wave symmetry.
    pub half_period: bool,
    /// A spatio-temporal symmetry the branch is shot with (a travelling wave's sector shift,
    /// [`Start::travelling_wave`]); `None`: the half-wave one when `half_period` allows it.
    pub shift: Option<ShiftSymmetry>,
    /// State direction (length 2n) whose projection the first corrector holds fixed, and
    /// along which the branch sets off; `None`: `z0` itself (the starting mode's amplitude).
    pub pin: Option<Vec<f64>>,
    /// Phase condition required by this start, overriding the settings' (a switched branch
    /// whose motions are never at rest everywhere at once needs
    /// [`PhaseCondition::FlowOrthogonal`]; so does a start from a state with velocities).
    pub phase: Option<PhaseCondition>,
    /// Whether `basis` spans every elastic mode; a large model's lowest modes only are enough
    /// for the matrix-free formulation (docs/method.md §15), not for the dense one.
    pub complete_basis: bool,
    /// The linear mode (index in the model's list) of each column of `basis`.
    pub basis_modes: Vec<usize>,
    /// The dof of largest amplitude in the starting mode (in `z0` for a start from a state):
    /// whose peak displacement is recorded unless the settings name `output_dofs`.
    pub reference_dof: usize,
}

/// Why a branch could not be started.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum StartError {
    /// The mode asked for (0-based index) is a rigid-body mode: it has no NNM
    /// (docs/method.md §10).
    #[error("mode {0} is a rigid-body mode: it has no nonlinear normal mode")]
    RigidMode(usize),
    /// The mode index is out of range.
    #[error("mode index {index} out of range (the model has {count} modes)")]
    NoSuchMode {
        /// The index asked for (0-based).
        index: usize,
        /// Number of linear modes of the model.
        count: usize,
    },
    /// A bad start energy, state or period (the text says which).
    #[error("invalid start: {0}")]
    Invalid(String),
    /// The linear modal analysis failed.
    #[error(transparent)]
    Modes(#[from] ModesError),
}

impl Start {
    /// Starts on linear mode `index` (0-based, ascending frequency) of `system`, at the
    /// default amplitude of eq. (16) (nonlinear forces 1e-4 of the linear ones; their work on
    /// the mode, when the forces alone leave it linear). Computes the linear
    /// modes; [`Start::from_linear_mode`] takes them when they are already known.
    pub fn from_mode<S: MechanicalSystem + ?Sized>(
        system: &S,
        index: usize,
    ) -> Result<Self, StartError> {
        let modes = linear_modes(system)?;
        Self::from_linear_mode(system, &modes, index, None)
    }

    /// Starts on linear mode `index` scaled to the linear energy `energy`; when `energy` is
    /// `None`, at the amplitude where the nonlinear forces are 1e-4 of the linear ones (so
    /// the first point is nearly linear whatever the units of the model), or where their work
    /// on the mode is, when there it is a hundred times less ([`starting_amplitude`]: a
    /// quadratic coupling, which has not moved the frequency yet). When the structure
    /// has a verified mirror symmetry, the unknowns are restricted to the invariant class of
    /// the starting mode ([`crate::symmetry`]); [`Start::unrestricted`] undoes that.
    pub fn from_linear_mode<S: MechanicalSystem + ?Sized>(
        system: &S,
        modes: &[LinearMode],
        index: usize,
        energy: Option<f64>,
    ) -> Result<Self, StartError> {
        let mode = mode_at(modes, index)?;
        if mode.rigid {
            return Err(StartError::RigidMode(index));
        }
        let n = system.dofs();
        // Rigid-body modes are left out of the unknowns only when the nonlinear forces leave
        // them alone; otherwise they are kept like any other mode.
        let amplitude_scale = weakly_nonlinear_amplitude(system, &mode.shape, 1.0);
        let decoupled = rigid_modes_decouple(system, modes, amplitude_scale);
        let kept = |k: usize| !modes[k].rigid || !decoupled;
        // Kept modes, those of the starting mode's invariant class first.
        let class = if decoupled {
            invariant_class(system, modes, index, amplitude_scale)
        } else {
            None
        };
        let mut order: Vec<usize> = match &class {
            Some((_, members)) => members.clone(),
            None => (0..modes.len()).filter(|&k| kept(k)).collect(),
        };
        let unknown_columns = order.len();
        let rest: Vec<usize> = (0..modes.len())
            .filter(|k| kept(*k) && !order.contains(k))
            .collect();
        order.extend(rest);
        let basis: Vec<f64> = order.iter().flat_map(|&k| modes[k].shape.clone()).collect();
        let amplitude = match energy {
            Some(e) if e.is_finite() && e > 0.0 => (2.0 * e).sqrt() / mode.frequency,
            Some(e) => {
                return Err(StartError::Invalid(format!(
                    "start energy must be positive, got {}",
                    crate::number::Number(e)
                )));
            }
            None => starting_amplitude(system, &mode.shape),
        };
        let mut z0 = vec![0.0; 2 * n];
        for (z, s) in z0.iter_mut().zip(&mode.shape) {
            *z = amplitude * s;
        }
        Ok(Self {
            mass_basis: times_mass(system, &basis),
            basis,
            unknown_columns,
            symmetry: class.map(|(parity, _)| parity),
            amplitude_scale,
            omega: mode.frequency,
            z0,
            period: 2.0 * std::f64::consts::PI / mode.frequency,
            half_period: true,
            shift: None,
            pin: None,
            phase: None,
            complete_basis: modes.len() >= n,
            basis_modes: order,
            reference_dof: largest_entry(&mode.shape),
        })
    }

    /// The start of a branch as a job asks for it: the standing wave of mode `index`,
    /// restricted to its symmetry class unless `settings.start.symmetry` is off, or with
    /// `travel` the travelling wave of its pair; at `settings.start.energy_start` if given.
    pub fn for_branch<'s, S: MechanicalSystem + ?Sized>(
        system: &S,
        modes: &[LinearMode],
        index: usize,
        travel: Option<Travel>,
        settings: impl Into<SettingsView<'s>>,
    ) -> Result<Self, StartError> {
        let settings = settings.into();
        let energy = settings.start.energy_start;
        if let Some(travel) = travel {
            if settings.shooting.formulation == super::Formulation::MatrixFree {
                return Err(StartError::Invalid(
                    "travelling waves are shot with the dense formulation; set formulation = \"dense\" or \"auto\"".into(),
                ));
            }
            return Self::travelling_wave(system, modes, index, travel, energy);
        }
        let start = Self::from_linear_mode(system, modes, index, energy)?;
        Ok(if settings.start.symmetry {
            start
        } else {
            start.unrestricted()
        })
    }

    /// Starts on the travelling wave of the degenerate pair that mode `index` belongs to
    /// (docs/method.md §17): `x0 = a φ_cos`, `v0 = ±a ω φ_sin`, the linear motion
    /// `a (φ_cos cos ωt ± φ_sin sin ωt)` whose pattern turns round the structure at constant
    /// shape. Every elastic mode is an unknown (a travelling wave keeps no mirror symmetry),
    /// the phase condition is the flow-orthogonal one (its motion is never at rest), and it is
    /// shot over `T/q` with its sector shift ([`ShiftSymmetry::travelling_wave`]), which also
    /// keeps Newton away from the standing waves of the same pair (docs/method.md eq. (83)).
    pub fn travelling_wave<S: MechanicalSystem + ?Sized>(
        system: &S,
        modes: &[LinearMode],
        index: usize,
        travel: Travel,
        energy: Option<f64>,
    ) -> Result<Self, StartError> {
        let mode = mode_at(modes, index)?;
        let name = match mode.label() {
            label if label.is_empty() => index.to_string(),
            label => format!("({label})"),
        };
        let not_travelling =
            |why: &str| StartError::Invalid(format!("mode {name} has no travelling wave: {why}"));
        let cyclic = system
            .cyclic_symmetry()
            .ok_or_else(|| not_travelling("the model declares no cyclic symmetry"))?;
        let label = mode
            .cyclic
            .filter(|c| c.pattern.is_some())
            .ok_or_else(|| not_travelling("it is not a member of a degenerate pair"))?;
        let partner = |wave: StandingWave| {
            modes.iter().enumerate().find(|(_, m)| {
                m.cyclic.is_some_and(|c| {
                    c.circles == label.circles
                        && c.diameters == label.diameters
                        && c.pattern == Some(wave)
                })
            })
        };
        let (Some((cos_index, cos)), Some((_, sin))) =
            (partner(StandingWave::Cos), partner(StandingWave::Sin))
        else {
            return Err(not_travelling("its partner standing wave was not found"));
        };
        let standing = Self::from_linear_mode(system, modes, cos_index, energy)?.unrestricted();
        let n = system.dofs();
        let omega = cos.frequency;
        let amplitude = linalg::norm(&standing.z0[..n]) / linalg::norm(&cos.shape);
        let sign = travel.sign();
        let mut z0 = standing.z0.clone();
        for (v, s) in z0[n..].iter_mut().zip(&sin.shape) {
            *v = sign * amplitude * omega * s;
        }
        // The sector shift `s` for which the linear wave at `t = T/q` is `P z0`.
        let linear_at = |t: f64| -> Vec<f64> {
            let (c, s) = ((omega * t).cos(), (omega * t).sin());
            let mut z = vec![0.0; 2 * n];
            for i in 0..n {
                z[i] = amplitude * (c * cos.shape[i] + sign * s * sin.shape[i]);
                z[n + i] = amplitude * omega * (-s * cos.shape[i] + sign * c * sin.shape[i]);
            }
            z
        };
        let period = 2.0 * std::f64::consts::PI / omega;
        let scale = linalg::norm(&z0);
        let shift = ShiftSymmetry::travelling_wave(cyclic, label.diameters, |shift| {
            let expected = linear_at(period / shift.divisions as f64);
            let shifted = shift.apply(&z0);
            let error: f64 = expected
                .iter()
                .zip(&shifted)
                .map(|(a, b)| (a - b).powi(2))
                .sum::<f64>()
                .sqrt();
            error <= 1e-8 * scale
        })
        .ok_or_else(|| {
            not_travelling(&format!(
                "no sector shift maps its pattern onto itself a fraction of a period later ({} diameters, {} sectors)",
                label.diameters, cyclic.sectors
            ))
        })?;
        Ok(Self {
            z0,
            period,
            omega,
            half_period: false,
            shift: Some(shift),
            phase: Some(PhaseCondition::FlowOrthogonal),
            ..standing
        })
    }

    /// Starts from a guess of a periodic motion: its initial state `z0 = [x0; v0]` and
    /// period. Every elastic mode is an unknown; with non-zero velocities the
    /// flow-orthogonal phase condition is used. The first corrector holds the projection on
    /// `z0` fixed.
    pub fn from_state<S: MechanicalSystem + ?Sized>(
        system: &S,
        z0: &[f64],
        period: f64,
    ) -> Result<Self, StartError> {
        let n = system.dofs();
        if z0.len() != 2 * n {
            return Err(StartError::Invalid(format!(
                "the state has length {}, expected 2 x {n} dofs",
                z0.len()
            )));
        }
        if !(period.is_finite() && period > 0.0) || z0.iter().any(|v| !v.is_finite()) {
            return Err(StartError::Invalid(format!(
                "the period must be positive and the state finite (period {})",
                crate::number::Number(period)
            )));
        }
        let modes = linear_modes(system)?;
        let elastic_modes: Vec<usize> = (0..modes.len()).filter(|&k| !modes[k].rigid).collect();
        let elastic: Vec<&LinearMode> = elastic_modes.iter().map(|&k| &modes[k]).collect();
        let basis: Vec<f64> = elastic.iter().flat_map(|m| m.shape.clone()).collect();
        let shape_norm = linalg::norm(&z0[..n]);
        let amplitude_scale = if shape_norm > 0.0 {
            let shape: Vec<f64> = z0[..n].iter().map(|x| x / shape_norm).collect();
            weakly_nonlinear_amplitude(system, &shape, 1.0)
        } else {
            1.0
        };
        let moving = z0[n..].iter().any(|&v| v != 0.0);
        Ok(Self {
            mass_basis: times_mass(system, &basis),
            unknown_columns: elastic.len(),
            basis,
            symmetry: None,
            amplitude_scale,
            omega: 2.0 * std::f64::consts::PI / period,
            z0: z0.to_vec(),
            period,
            half_period: !moving,
            shift: None,
            pin: None,
            phase: moving.then_some(PhaseCondition::FlowOrthogonal),
            complete_basis: modes.len() >= n,
            basis_modes: elastic_modes,
            reference_dof: largest_entry(&z0[..n]),
        })
    }

    /// The shooting problem of a branch from this start: its unknowns, scales and settings
    /// (half-period shooting only for odd systems under the zero-velocity phase condition).
    pub fn shooting<'a, 's, S: MechanicalSystem + ?Sized>(
        &self,
        system: &'a S,
        settings: impl Into<SettingsView<'s>>,
    ) -> Shooting<'a, S> {
        let settings = settings.into();
        let phase = self.phase.unwrap_or(settings.shooting.phase);
        let setup = ShootingSetup {
            basis: self.basis.clone(),
            mass_basis: self.mass_basis.clone(),
            unknown_columns: self.unknown_columns,
            omega_ref: self.omega,
            phase,
            amplitude_scale: self.amplitude_scale,
            shift: self.shift.clone().or_else(|| {
                if !(self.half_period
                    && settings.shooting.half_period
                    && phase == PhaseCondition::ZeroVelocity)
                {
                    return None;
                }
                if is_odd(system, self.amplitude_scale) {
                    return Some(ShiftSymmetry::half_wave());
                }
                parity_of(system, &self.z0, self.amplitude_scale).map(ShiftSymmetry::parity)
            }),
            phase_reference: self.z0.clone(),
            complete_basis: self.complete_basis,
            basis_modes: self.basis_modes.clone(),
            output_dofs: self.output_dofs(settings),
        };
        Shooting::new(system, setup, settings)
    }

    /// The dofs whose peak displacements every point of the branch records: the settings'
    /// `output_dofs`, or the [`Self::reference_dof`].
    pub fn output_dofs<'s>(&self, settings: impl Into<SettingsView<'s>>) -> Vec<usize> {
        let settings = settings.into();
        if settings.output.output_dofs.is_empty() {
            vec![self.reference_dof]
        } else {
            settings.output.output_dofs.clone()
        }
    }

    /// The same start with the unknowns spanning every elastic mode (no symmetry restriction).
    pub fn unrestricted(mut self) -> Self {
        self.unknown_columns = self.basis.len() / (self.z0.len() / 2);
        self.symmetry = None;
        self
    }

    /// The first guess in the unknowns of `shooting`, and the direction the first corrector
    /// pins (docs/method.md eq. (23)).
    pub fn first_guess<S: MechanicalSystem + ?Sized>(
        &self,
        shooting: &Shooting<'_, S>,
    ) -> (Vec<f64>, Vec<f64>) {
        let u0 = shooting.unknowns_from_state(&self.z0, self.period);
        let pin = match &self.pin {
            Some(direction) => shooting.unknowns_from_state(direction, 0.0),
            None => u0.clone(),
        };
        (u0, pin)
    }
}

/// Mode `index` of `modes`, or why there is none.
fn mode_at(modes: &[LinearMode], index: usize) -> Result<&LinearMode, StartError> {
    modes.get(index).ok_or(StartError::NoSuchMode {
        index,
        count: modes.len(),
    })
}

/// Index of the entry of largest magnitude (the first of equals; 0 for an empty slice).
fn largest_entry(values: &[f64]) -> usize {
    (0..values.len())
        .rev()
        .max_by(|&a, &b| values[a].abs().total_cmp(&values[b].abs()))
        .unwrap_or(0)
}

/// `M B` for the columns of `basis`.
fn times_mass<S: MechanicalSystem + ?Sized>(system: &S, basis: &[f64]) -> Vec<f64> {
    let n = system.dofs();
    let mut out = vec![0.0; basis.len()];
    system.mass().apply(basis, basis.len() / n, &mut out);
    out
}

/// Whether every rigid-body mode `u` decouples from the nonlinear forces:
/// `f_int(x + c u) = f_int(x)` and `uᵀ f_int(x) = 0` at sample states (true of forces that
/// depend on differences of displacements, as in a free-floating structure). Only then is a
/// rigid shift periodic for every period and a rigid velocity a pure drift, so that the rigid
/// modes can be removed from the shooting unknowns and from the Floquet analysis.
fn rigid_modes_decouple<S: MechanicalSystem + ?Sized>(
    system: &S,
    modes: &[LinearMode],
    amplitude: f64,
) -> bool {
    let n = system.dofs();
    let samples = sample_states(n, amplitude);
    modes.iter().filter(|m| m.rigid).all(|rigid| {
        samples.iter().all(|x| {
            let shifted: Vec<f64> = x
                .iter()
                .zip(&rigid.shape)
                .map(|(a, u)| a + 0.7 * amplitude * u)
                .collect();
            let (mut f, mut g) = (vec![0.0; n], vec![0.0; n]);
            system.internal_force(x, &mut f);
            system.internal_force(&shifted, &mut g);
            let scale = f.iter().fold(1e-300f64, |m, v| m.max(v.abs()));
            let invariant = f
                .iter()
                .zip(&g)
                .all(|(a, b)| (a - b).abs() <= 1e-10 * scale);
            let projection: f64 = linalg::dot(&f, &rigid.shape);
            let norm_u = linalg::norm(&rigid.shape);
            invariant && projection.abs() <= 1e-10 * scale * norm_u * (n as f64).sqrt()
        })
    })
}

/// The smallest amplitude `c` at which `‖f_nl(c φ)‖ = ratio ‖K c φ‖` (1 when the model is
/// linear along `φ`), with `K = K_t(0)` and `f_nl = f_int - K x` ([`first_crossing`]).
fn weakly_nonlinear_amplitude<S: MechanicalSystem + ?Sized>(
    system: &S,
    shape: &[f64],
    ratio: f64,
) -> f64 {
    let k_norm = linalg::norm(&split_force(system, shape, 1.0).1);
    first_crossing(system, shape, ratio, |nonlinear, _, c| {
        linalg::norm(nonlinear) / (c * k_norm)
    })
    .unwrap_or(1.0)
}

/// The default starting amplitude along mode `φ` (eq. (16)): where the nonlinear force is
/// `10⁻⁴` of the linear one ([`weakly_nonlinear_amplitude`]) — unless there its work on the
/// mode, `φᵀ f_nl(c φ)`, is below a hundredth of that, relative to the linear force's
/// `c φᵀ K φ`: a nonlinearity that only couples the mode to others (a quadratic one) and has
/// not yet moved its frequency. Then the start is where that work reaches `10⁻⁴` of the
/// linear one's (a frequency shift of about `4·10⁻⁵` when the mode's own nonlinearity is
/// cubic), or the force ratio's amplitude when it never does.
///
/// Why: the von Kármán beam's membrane force, quadratic in the transverse displacement, is
/// `10⁻⁴` of the linear one at `E = 9·10⁻¹² J` on its first bending mode, where the
/// frequency has moved by 1e-12; imported as files (no hand-chosen `energy_start`), its
/// 10⁴-dof branch spent 20 minutes there. Models whose nonlinearity acts on the mode itself
/// keep the force ratio's start.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
fn starting_amplitude<S: MechanicalSystem + ?Sized>(system: &S, shape: &[f64]) -> f64 {
    const RATIO: f64 = 1e-4;
    let work = |nonlinear: &[f64], linear: &[f64], _: f64| {
        (linalg::dot(shape, nonlinear) / linalg::dot(shape, linear)).abs()
    };
    let by_force = weakly_nonlinear_amplitude(system, shape, RATIO);
    let (nonlinear, linear) = split_force(system, shape, by_force);
    // Negated comparison deliberate: a NaN work ratio keeps the force ratio's start.
    if !(work(&nonlinear, &linear, by_force) < 1e-2 * RATIO) {
        return by_force;
    }
    first_crossing(system, shape, RATIO, work).unwrap_or(by_force)
}

/// `(f_nl(c φ), K c φ)`, `K = K_t(0)`, `f_nl = f_int − K x`.
///
/// The linear part `K x` is the internal force itself at `2⁻⁶⁰ x`, scaled back: exact
/// scalings by a power of two, so that the same arithmetic makes both and `f_nl` is read
/// without their round-off. (Formed apart, by the tangent applied to `φ` and times `c`, the
/// two differ by `ε ‖K‖ ‖x‖`, which on a 1,000-element beam, `‖K‖/‖K φ‖ ≈ 10¹⁴`, passes the
/// ratio at every amplitude: the branch started twelve decades too low.)
fn split_force<S: MechanicalSystem + ?Sized>(
    system: &S,
    shape: &[f64],
    c: f64,
) -> (Vec<f64>, Vec<f64>) {
    const TINY: f64 = 1.0 / (1u64 << 60) as f64;
    let n = shape.len();
    let x: Vec<f64> = shape.iter().map(|s| c * s).collect();
    let small: Vec<f64> = x.iter().map(|v| v * TINY).collect();
    let mut linear = vec![0.0; n];
    system.internal_force(&small, &mut linear);
    linear.iter_mut().for_each(|v| *v /= TINY);
    let mut f = vec![0.0; n];
    system.internal_force(&x, &mut f);
    let nonlinear = f.iter().zip(&linear).map(|(f, k)| f - k).collect();
    (nonlinear, linear)
}

/// The smallest amplitude `c` at which `measure(f_nl(c φ), K c φ, c)` exceeds `ratio`
/// ([`split_force`]): the first crossing found by scanning `log c` upwards in half decades
/// from 1e-12, then bisected; `None` when there is none up to 1e12. (The first crossing, not
/// any: a non-polynomial force such as the pendulum's `sin θ - θ` oscillates about the ratio
/// far away.)
// Negated comparisons are deliberate: a NaN ratio must count as "not above".
#[allow(clippy::neg_cmp_op_on_partial_ord)]
fn first_crossing<S: MechanicalSystem + ?Sized>(
    system: &S,
    shape: &[f64],
    ratio: f64,
    measure: impl Fn(&[f64], &[f64], f64) -> f64,
) -> Option<f64> {
    let above = |log_c: f64| {
        let c = 10f64.powf(log_c);
        let (nonlinear, linear) = split_force(system, shape, c);
        measure(&nonlinear, &linear, c) > ratio
    };
    const LOWEST: f64 = -12.0;
    if above(LOWEST) {
        return Some(10f64.powf(LOWEST));
    }
    let first = (1..=48)
        .map(|k| LOWEST + 0.5 * k as f64)
        .find(|&log_c| above(log_c))?;
    let (mut lo, mut hi) = (first - 0.5, first);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if above(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Some(10f64.powf(lo))
}
