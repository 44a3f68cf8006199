//! The force shape from the forms users give it (docs/method.md eq. (90b)): one amplitude on
//! a few dofs, a whole vector, or an engine-order excitation of a cyclic structure, where
//! dof `j` of sector `s` is driven by `a cos(Ωt − 2πks/N)` — a wave travelling `k` sectors
//! a revolution, as the blades of a disk pass `k` equally spaced obstacles.

use crate::model::{HarmonicForce, MechanicalSystem};

/// How a user gives the force (the job file's `force = { ... }`).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(untagged, deny_unknown_fields)]
pub enum Force {
    /// `amplitude · cos Ωt` on each of `dofs`.
    Dofs {
        /// The forced dofs (0-based).
        dofs: Vec<usize>,
        /// The force on each.
        amplitude: f64,
    },
    /// Engine-order `engine_order` excitation of dof `sector_dof` of every sector.
    EngineOrder {
        /// `k`, from 0 to `N/2`.
        engine_order: usize,
        /// `a`.
        amplitude: f64,
        /// `j`, the dof within a sector (0-based).
        sector_dof: usize,
    },
    /// `F_c = vector`, in phase with `cos Ωt`.
    Vector {
        /// One entry a dof.
        vector: Vec<f64>,
    },
}

/// Why a force cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct ForceError(pub String);

impl Force {
    /// The force amplitude `a` the form gives (1 for a vector, which carries its own size).
    pub fn amplitude(&self) -> f64 {
        match self {
            Force::Dofs { amplitude, .. } | Force::EngineOrder { amplitude, .. } => *amplitude,
            Force::Vector { .. } => 1.0,
        }
    }

    /// The force shape for `system` at unit amplitude (a curve multiplies it by its force
    /// amplitude, [`Self::amplitude`] or a level of a job's `amplitudes`). Rejects dofs out
    /// of range, an engine order on a model without cyclic symmetry or beyond `N/2`, a vector
    /// of the wrong length, and non-finite values.
    pub fn shape<S: MechanicalSystem + ?Sized>(
        &self,
        system: &S,
    ) -> Result<HarmonicForce, ForceError> {
        let n = system.dofs();
        let finite = |name: &str, v: f64| {
            if v.is_finite() {
                Ok(())
            } else {
                Err(ForceError(format!(
                    "the force's {name} must be finite, got {}",
                    crate::number::Number(v)
                )))
            }
        };
        match self {
            Force::Dofs { dofs, amplitude } => {
                finite("amplitude", *amplitude)?;
                if dofs.is_empty() {
                    return Err(ForceError("the force's dofs list is empty".into()));
                }
                let mut cosine = vec![0.0; n];
                for &d in dofs {
                    if d >= n {
                        return Err(ForceError(format!(
                            "forced dof {d} is out of range (the model has {n} dofs)"
                        )));
                    }
                    cosine[d] = 1.0;
                }
                Ok(HarmonicForce::cosine(cosine))
            }
            Force::Vector { vector } => {
                if vector.len() != n {
                    return Err(ForceError(format!(
                        "the force vector has {} entries, the model {n} dofs",
                        vector.len()
                    )));
                }
                for &v in vector {
                    finite("vector entries", v)?;
                }
                Ok(HarmonicForce::cosine(vector.clone()))
            }
            Force::EngineOrder {
                engine_order,
                amplitude,
                sector_dof,
            } => {
                finite("amplitude", *amplitude)?;
                let Some(cyclic) = system.sector_layout() else {
                    return Err(ForceError(
                        "engine-order excitation needs a cyclic model (a bladed disk)".into(),
                    ));
                };
                let (sectors, per) = (cyclic.sectors, cyclic.dofs_per_sector);
                if 2 * engine_order > sectors {
                    return Err(ForceError(format!(
                        "engine order {engine_order} is beyond N/2 = {} (the model has {sectors} sectors)",
                        sectors / 2
                    )));
                }
                if *sector_dof >= per {
                    return Err(ForceError(format!(
                        "sector_dof {sector_dof} is out of range (a sector has {per} dofs)"
                    )));
                }
                let mut force = HarmonicForce::cosine(vec![0.0; n]);
                for s in 0..sectors {
                    // a cos(Ωt − θ_s) = a cos θ_s cos Ωt + a sin θ_s sin Ωt.
                    let theta =
                        2.0 * std::f64::consts::PI * (*engine_order * s) as f64 / sectors as f64;
                    force.cosine[s * per + sector_dof] = theta.cos();
                    force.sine[s * per + sector_dof] = theta.sin();
                }
                Ok(force)
            }
        }
    }

    /// The dofs whose peaks a curve records by default: the forced dofs (an engine-order
    /// force's: `sector_dof` of every sector, i.e. every blade).
    pub fn default_output_dofs<S: MechanicalSystem + ?Sized>(&self, system: &S) -> Vec<usize> {
        match self.shape(system) {
            Ok(shape) => (0..system.dofs())
                .filter(|&i| shape.cosine[i] != 0.0 || shape.sine[i] != 0.0)
                .collect(),
            Err(_) => Vec::new(),
        }
    }
}
