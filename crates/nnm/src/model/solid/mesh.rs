//! An unstructured solid mesh as an FE code or a mesher hands it over: nodes, second-order
//! volume elements and named node groups (Gmsh's physical groups). Reading a file is the
//! I/O layer's work (`nnm_io::gmsh`); this module turns the mesh into a body — nodes that
//! no element uses dropped, every element's geometry checked — with the node and dof
//! numbering of docs/job-files.md ("Meshes").

use std::sync::Arc;

use super::assembly::Body;
use super::element::{Geometry, ReferencePoint};
use super::material::StVenantKirchhoff;
use super::{hex27, tet10};
use crate::model::ModelError;
use crate::number::Number;

/// The volume elements a mesh may hold.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MeshElementKind {
    /// The quadratic 10-node tetrahedron, nodes in Gmsh's order (vertices, then the mid-edge
    /// nodes of the edges 0–1, 1–2, 0–2, 0–3, 2–3, 1–3).
    Tet10,
    /// The triquadratic 27-node hexahedron, nodes in the box's order: node `i + 3 (j + 3 k)`
    /// at reference coordinates `(i − 1, j − 1, k − 1)`.
    Hex27,
}

impl MeshElementKind {
    /// The name used in job files and messages.
    pub fn name(self) -> &'static str {
        match self {
            MeshElementKind::Tet10 => "tet10",
            MeshElementKind::Hex27 => "hex27",
        }
    }

    /// Number of nodes.
    pub fn nodes(self) -> usize {
        match self {
            MeshElementKind::Tet10 => tet10::NODES,
            MeshElementKind::Hex27 => hex27::NODES,
        }
    }

    /// The nodes' coordinates on the reference element, in the order [`MeshElement::nodes`]
    /// lists them: what a reader or writer matches its format's node order against.
    pub fn reference_nodes(self) -> Vec<[f64; 3]> {
        match self {
            MeshElementKind::Tet10 => tet10::node_coordinates().to_vec(),
            MeshElementKind::Hex27 => (0..hex27::NODES)
                .map(|a| [a % 3, (a / 3) % 3, a / 9].map(|i| i as f64 - 1.0))
                .collect(),
        }
    }

    /// The reference coordinates of a 10-node tetrahedron's nodes in a format that lists
    /// the vertices, then the mid-edge nodes of `edges` in that order: what
    /// [`Self::order_in`] matches a format's tet10 against.
    pub fn tet10_with_edges(edges: &[[usize; 2]; 6]) -> Vec<[f64; 3]> {
        tet10::with_edges(edges).to_vec()
    }

    /// For each node in nnm's order, its position in a file format's order whose reference
    /// coordinates are `format` (on the same reference element): the format's nodes matched
    /// by coordinates, so that no permutation is written by hand. `None` if `format` lacks
    /// one of the nodes.
    pub fn order_in(self, format: &[[f64; 3]]) -> Option<Vec<usize>> {
        self.reference_nodes()
            .iter()
            .map(|x| {
                format
                    .iter()
                    .position(|y| (0..3).all(|d| (x[d] - y[d]).abs() < 1e-12))
            })
            .collect()
    }

    fn quadrature(self) -> Vec<ReferencePoint> {
        match self {
            MeshElementKind::Tet10 => tet10::quadrature_points(),
            MeshElementKind::Hex27 => hex27::gauss_points(),
        }
    }
}

/// One volume element: its kind, its number in the source (for messages) and its nodes.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshElement {
    /// The element type.
    pub kind: MeshElementKind,
    /// The element's number in the file it came from (Gmsh's element tag).
    pub tag: u64,
    /// Indices into [`Mesh::nodes`], in the order of [`MeshElementKind::reference_nodes`].
    pub nodes: Vec<usize>,
}

/// A named set of nodes (a Gmsh physical group of any dimension).
#[derive(Debug, Clone, PartialEq)]
pub struct NodeGroup {
    /// The group's name (`clamped` names it).
    pub name: String,
    /// Indices into [`Mesh::nodes`].
    pub nodes: Vec<usize>,
}

/// Nodes, volume elements and named node groups.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    /// Coordinates (m), in the source's order (Gmsh: ascending node tag).
    pub nodes: Vec<[f64; 3]>,
    /// The volume elements.
    pub elements: Vec<MeshElement>,
    /// The named node groups.
    pub groups: Vec<NodeGroup>,
}

impl Mesh {
    /// For each node of [`Self::nodes`], its number in the body — the nodes that some element
    /// uses, in their order — or `None` for a node no element uses (a node of a geometry
    /// point or a surface mesh only).
    fn body_nodes(&self) -> Vec<Option<usize>> {
        let mut used = vec![false; self.nodes.len()];
        for e in &self.elements {
            for &a in &e.nodes {
                used[a] = true;
            }
        }
        let mut next = 0;
        used.into_iter()
            .map(|u| {
                u.then(|| {
                    next += 1;
                    next - 1
                })
            })
            .collect()
    }

    /// The body of this mesh: its volume elements in `material` of `density`, the nodes of
    /// the groups named in `clamped` held. One-line errors for a mesh without volume
    /// elements, a node index out of range, an unknown group, a group with no node on the
    /// body, and an inverted or degenerate element (named by its tag, with `det J`).
    pub(super) fn body(
        &self,
        clamped: &[String],
        material: StVenantKirchhoff,
        density: f64,
    ) -> Result<Body, ModelError> {
        let invalid = |s: String| Err(ModelError::InvalidParameter(s));
        if self.elements.is_empty() {
            return invalid(
                "the mesh has no volume elements (tet10 or hex27): a Gmsh mesh with physical \
                 groups saves only their elements, so add one for the volume"
                    .into(),
            );
        }
        for e in &self.elements {
            if e.nodes.len() != e.kind.nodes() {
                return invalid(format!(
                    "mesh element {} ({}) has {} nodes, expected {}",
                    e.tag,
                    e.kind.name(),
                    e.nodes.len(),
                    e.kind.nodes()
                ));
            }
            if let Some(&a) = e.nodes.iter().find(|&&a| a >= self.nodes.len()) {
                return invalid(format!(
                    "mesh element {} refers to node index {a}, beyond the mesh's {} nodes",
                    e.tag,
                    self.nodes.len()
                ));
            }
        }
        if let Some(x) = self.nodes.iter().flatten().find(|x| !x.is_finite()) {
            return invalid(format!(
                "the mesh has a node coordinate that is not finite ({})",
                Number(*x)
            ));
        }
        let numbers = self.body_nodes();
        let nodes = numbers.iter().flatten().count();
        let mut held = vec![false; nodes];
        for name in clamped {
            let Some(group) = self.groups.iter().find(|g| &g.name == name) else {
                let names: Vec<&str> = self.groups.iter().map(|g| g.name.as_str()).collect();
                return invalid(format!(
                    "clamped group `{name}` is not a physical group of the mesh (it has: {})",
                    if names.is_empty() {
                        "none".to_string()
                    } else {
                        names.join(", ")
                    }
                ));
            };
            let mut any = false;
            for &a in &group.nodes {
                if let Some(b) = numbers.get(a).copied().flatten() {
                    held[b] = true;
                    any = true;
                }
            }
            if !any {
                return invalid(format!(
                    "clamped group `{name}` has no node on the mesh's volume elements: it clamps nothing"
                ));
            }
        }
        let mut references: Vec<(MeshElementKind, Vec<ReferencePoint>)> = Vec::new();
        let mut elements = Vec::with_capacity(self.elements.len());
        for e in &self.elements {
            if !references.iter().any(|(k, _)| *k == e.kind) {
                references.push((e.kind, e.kind.quadrature()));
            }
            let (_, reference) = references
                .iter()
                .find(|(k, _)| *k == e.kind)
                .expect("just added");
            let coordinates: Vec<[f64; 3]> = e.nodes.iter().map(|&a| self.nodes[a]).collect();
            let geometry = Geometry::new(reference, &coordinates).map_err(|det| {
                ModelError::InvalidParameter(format!(
                    "mesh element {} ({}) is inverted or degenerate: det J = {} at a quadrature point",
                    e.tag,
                    e.kind.name(),
                    Number(det)
                ))
            })?;
            let body_nodes = e
                .nodes
                .iter()
                .map(|&a| numbers[a].expect("used by this element"))
                .collect();
            elements.push((body_nodes, Arc::new(geometry)));
        }
        let mut coordinates = vec![[0.0; 3]; nodes];
        for (a, b) in numbers.iter().enumerate() {
            if let Some(b) = b {
                coordinates[*b] = self.nodes[a];
            }
        }
        Ok(Body {
            nodes,
            coordinates,
            elements,
            clamped: held,
            material,
            density,
        })
    }
}
