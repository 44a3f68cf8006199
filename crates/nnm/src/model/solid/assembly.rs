//! A solid body from its elements: free dofs numbered, `M` and `K` assembled from the
//! elements' consistent mass and linear stiffness, and one [`SolidElement`] per element for
//! the nonlinear force (docs/method.md eq. (104)).

use std::sync::Arc;

use super::element::{Geometry, SolidElement};
use super::material::StVenantKirchhoff;
use super::tet10;
use crate::model::{Cell, CellKind, Layout, ModelError, NonlinearElement, SparseMatrix, Structure};

/// Elements over numbered nodes, which nodes are clamped, and the material.
pub(super) struct Body {
    /// Number of nodes.
    pub nodes: usize,
    /// The nodes' reference coordinates (m).
    pub coordinates: Vec<[f64; 3]>,
    /// Per element: its nodes (in its reference element's order) and its geometry.
    pub elements: Vec<(Vec<usize>, Arc<Geometry>)>,
    /// Per node: whether its three dofs are removed.
    pub clamped: Vec<bool>,
    pub material: StVenantKirchhoff,
    pub density: f64,
}

impl Body {
    /// Dof `3 · node + component` of the free nodes in ascending order, `None` where clamped
    /// (the `fixed_dofs` convention).
    pub fn dof_numbers(&self) -> Vec<Option<usize>> {
        let mut next = 0;
        (0..3 * self.nodes)
            .map(|d| {
                (!self.clamped[d / 3]).then(|| {
                    next += 1;
                    next - 1
                })
            })
            .collect()
    }

    /// The nodes, the elements as cells, and each node's dofs: what a viewer draws.
    pub fn layout(&self) -> Layout {
        let numbers = self.dof_numbers();
        Layout {
            points: self.coordinates.clone(),
            cells: self
                .elements
                .iter()
                .map(|(nodes, _)| Cell {
                    kind: if nodes.len() == tet10::NODES {
                        CellKind::Tet10
                    } else {
                        CellKind::Hex27
                    },
                    points: nodes.clone(),
                })
                .collect(),
            dofs: (0..self.nodes)
                .map(|g| [0, 1, 2].map(|c| numbers[3 * g + c]))
                .collect(),
        }
    }

    /// The model: sparse `M` and `K`, one nonlinear element per finite element.
    pub fn build(&self) -> Result<Structure, ModelError> {
        let numbers = self.dof_numbers();
        let n = numbers.iter().flatten().count();
        if n == 0 {
            return Err(ModelError::InvalidParameter(
                "every node is clamped: the model has no degrees of freedom".into(),
            ));
        }
        let (mut mass, mut stiffness) = (Vec::new(), Vec::new());
        let mut elements: Vec<Box<dyn NonlinearElement>> = Vec::with_capacity(self.elements.len());
        // Elements sharing a geometry share its matrices too.
        let mut matrices: Option<(*const Geometry, Vec<f64>, Vec<f64>)> = None;
        for (nodes, geometry) in &self.elements {
            let key = Arc::as_ptr(geometry);
            if matrices.as_ref().is_none_or(|(k, _, _)| *k != key) {
                matrices = Some((
                    key,
                    geometry.mass(self.density),
                    geometry.stiffness(&self.material),
                ));
            }
            let (_, mass_e, stiffness_e) = matrices.as_ref().expect("just set");
            let dofs: Vec<Option<usize>> = nodes
                .iter()
                .flat_map(|&node| (0..3).map(move |c| 3 * node + c))
                .map(|d| numbers[d])
                .collect();
            let m = dofs.len();
            for (a, da) in dofs.iter().enumerate() {
                let Some(i) = *da else { continue };
                for (b, db) in dofs.iter().enumerate() {
                    let Some(j) = *db else { continue };
                    let (mv, kv) = (mass_e[a * m + b], stiffness_e[a * m + b]);
                    if mv != 0.0 {
                        mass.push((i, j, mv));
                    }
                    if kv != 0.0 {
                        stiffness.push((i, j, kv));
                    }
                }
            }
            elements.push(Box::new(SolidElement::new(
                dofs,
                Arc::clone(geometry),
                self.material,
            )));
        }
        let sparse = |t: &[(usize, usize, f64)]| {
            SparseMatrix::from_triplets(n, t).map_err(ModelError::InvalidParameter)
        };
        Structure::new(sparse(&mass)?, sparse(&stiffness)?, elements)
    }
}
