//! Three-dimensional solids of a St. Venant–Kirchhoff material (docs/method.md §20,
//! eqs. (103)–(108)): Green–Lagrange strain, second Piola–Kirchhoff stress, consistent mass,
//! and the nonlinear force and tangent computed element by element at every call — exactly
//! cubic in the displacement, assembled on the fixed pattern of `K` and never expanded into
//! a global tensor (a 27-node element alone would couple 81³ cubic terms).

mod assembly;
mod element;
mod hex27;
mod material;
mod mesh;
mod tet10;

use std::sync::Arc;

use serde::de::{self, Deserializer, SeqAccess, Visitor};

use self::assembly::Body;
use self::element::Geometry;
use self::material::StVenantKirchhoff;
use super::{Layout, ModelError, Structure};
use crate::number::Number;

pub use self::mesh::{Mesh, MeshElement, MeshElementKind, NodeGroup};

/// The elements of a structured box.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SolidElementKind {
    /// The triquadratic 27-node hexahedron, 3×3×3 Gauss points: it does not lock in bending,
    /// so one element through the thickness of a plate or beam carries its bending.
    Hex27,
}

/// A box `[0, Lx] × [0, Ly] × [0, Lz]` meshed by `nx × ny × nz` elements, some of its faces
/// clamped (`family = "solid"`).
///
/// Nodes: the `(2nx+1) × (2ny+1) × (2nz+1)` grid, node `i + (2nx+1)(j + (2ny+1) k)` at
/// `(i Lx/2nx, j Ly/2ny, k Lz/2nz)`; dof `3 · node + component` (x, y, z), the clamped nodes'
/// dofs removed and the rest numbered in ascending order (the `fixed_dofs` convention;
/// [`Self::node_dofs`]).
///
/// The defaults are the aluminium box `1 × 0.1 × 0.01 m` (E = 70 GPa, ν = 0.33,
/// ρ = 2700 kg/m³) clamped at both ends — the three-dimensional twin of the built-in von
/// Kármán beam, whose bending stretches it and hardens it — with `10 × 1 × 1` elements
/// (513 dofs).
///
/// With [`Self::mesh`] the body is a mesh read from a file instead (tet10 and hex27
/// elements, [`Self::build_on_mesh`]): `box`, `elements` and `element` do not apply, and
/// `clamped` names the mesh's physical groups.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Solid {
    /// The element type.
    pub element: SolidElementKind,
    /// The box's edges `[Lx, Ly, Lz]` (m).
    #[serde(rename = "box")]
    pub size: [f64; 3],
    /// Elements along each edge.
    pub elements: [usize; 3],
    /// The clamped faces: `"x0"` (the face `x = 0`), `"x1"` (`x = Lx`), `"y0"`, ... — a name
    /// or a list; none leaves the body free (six rigid-body modes).
    #[serde(deserialize_with = "faces")]
    pub clamped: Vec<String>,
    /// Young's modulus `E` (Pa).
    pub youngs_modulus: f64,
    /// Poisson's ratio `ν`, in `(−1, 0.5)`.
    pub poisson_ratio: f64,
    /// Density `ρ` (kg/m³).
    pub density: f64,
    /// A mesh file instead of the box (`mesh = { file = "blade.msh" }`), read by the I/O
    /// layer (`nnm_io`), which hands the mesh to [`Self::build_on_mesh`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mesh: Option<MeshFile>,
}

/// Where a solid's mesh comes from.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshFile {
    /// A Gmsh MSH 4.1 file (ASCII or binary), relative to the job file.
    pub file: String,
}

impl Default for Solid {
    fn default() -> Self {
        Self {
            element: SolidElementKind::Hex27,
            size: [1.0, 0.1, 0.01],
            elements: [10, 1, 1],
            clamped: vec!["x0".into(), "x1".into()],
            youngs_modulus: 70e9,
            poisson_ratio: 0.33,
            density: 2700.0,
            mesh: None,
        }
    }
}

/// The box's faces, in the order of their names: `x0`, `x1`, `y0`, `y1`, `z0`, `z1`.
const FACES: [&str; 6] = ["x0", "x1", "y0", "y1", "z0", "z1"];

/// `clamped`: one face name, or a list of them.
fn faces<'de, D: Deserializer<'de>>(deserializer: D) -> Result<Vec<String>, D::Error> {
    struct Faces;
    impl<'de> Visitor<'de> for Faces {
        type Value = Vec<String>;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("a face name such as \"x0\", or a list of them")
        }
        fn visit_str<E: de::Error>(self, v: &str) -> Result<Self::Value, E> {
            Ok(vec![v.to_string()])
        }
        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
            let mut names = Vec::new();
            while let Some(name) = seq.next_element::<String>()? {
                names.push(name);
            }
            Ok(names)
        }
    }
    deserializer.deserialize_any(Faces)
}

impl Solid {
    /// Grid points along each edge, `2 n + 1`.
    fn grid(&self) -> [usize; 3] {
        self.elements.map(|n| 2 * n + 1)
    }

    /// Whether grid node `(i, j, k)` lies on a clamped face.
    fn is_clamped(&self, ijk: [usize; 3]) -> bool {
        let grid = self.grid();
        self.clamped.iter().any(|face| {
            let axis = FACES.iter().position(|f| f == face).expect("validated") / 2;
            let at_end = face.ends_with('1');
            ijk[axis] == if at_end { grid[axis] - 1 } else { 0 }
        })
    }

    /// The body: nodes, elements (all one geometry) and clamped nodes.
    fn body(&self) -> Result<Body, ModelError> {
        let grid = self.grid();
        let node = |i: usize, j: usize, k: usize| i + grid[0] * (j + grid[1] * k);
        let step: [f64; 3] = std::array::from_fn(|a| self.size[a] / (2 * self.elements[a]) as f64);
        let reference = hex27::gauss_points();
        let corner: Vec<[f64; 3]> = (0..hex27::NODES)
            .map(|a| {
                let local = [a % 3, (a / 3) % 3, a / 9];
                std::array::from_fn(|d| local[d] as f64 * step[d])
            })
            .collect();
        let geometry = Arc::new(Geometry::new(&reference, &corner).map_err(|det| {
            ModelError::InvalidParameter(format!(
                "the box's elements are degenerate (det J = {})",
                Number(det)
            ))
        })?);
        let [nx, ny, nz] = self.elements;
        let mut elements = Vec::with_capacity(nx * ny * nz);
        for ez in 0..nz {
            for ey in 0..ny {
                for ex in 0..nx {
                    let nodes = (0..hex27::NODES)
                        .map(|a| node(2 * ex + a % 3, 2 * ey + (a / 3) % 3, 2 * ez + a / 9))
                        .collect();
                    elements.push((nodes, Arc::clone(&geometry)));
                }
            }
        }
        let nodes = grid.iter().product();
        let coordinates = (0..nodes)
            .map(|g| {
                let ijk = [
                    g % grid[0],
                    (g / grid[0]) % grid[1],
                    g / (grid[0] * grid[1]),
                ];
                std::array::from_fn(|d| ijk[d] as f64 * step[d])
            })
            .collect();
        let clamped = (0..nodes)
            .map(|g| {
                self.is_clamped([
                    g % grid[0],
                    (g / grid[0]) % grid[1],
                    g / (grid[0] * grid[1]),
                ])
            })
            .collect();
        Ok(Body {
            nodes,
            coordinates,
            elements,
            clamped,
            material: StVenantKirchhoff::new(self.youngs_modulus, self.poisson_ratio),
            density: self.density,
        })
    }

    /// The dofs `[x, y, z]` of grid node `node` of the box (`None` where clamped, beyond the
    /// grid, or for a solid on a mesh: its numbering is the mesh's, [`Self::model_on_mesh`]'s
    /// layout).
    pub fn node_dofs(&self, node: usize) -> Option<[usize; 3]> {
        if self.mesh.is_some() {
            return None;
        }
        let grid = self.grid();
        let nodes: usize = grid.iter().product();
        if node >= nodes {
            return None;
        }
        let ijk = |g: usize| {
            [
                g % grid[0],
                (g / grid[0]) % grid[1],
                g / (grid[0] * grid[1]),
            ]
        };
        if self.is_clamped(ijk(node)) {
            return None;
        }
        let before = (0..node).filter(|&g| !self.is_clamped(ijk(g))).count();
        Some([0, 1, 2].map(|c| 3 * before + c))
    }

    /// The material constants: positive, finite `E` and `ρ`, `−1 < ν < 0.5`.
    fn validate_material(&self) -> Result<(), ModelError> {
        let invalid = |s: String| Err(ModelError::InvalidParameter(s));
        for (name, value) in [
            ("youngs_modulus", self.youngs_modulus),
            ("density", self.density),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return invalid(format!(
                    "{name} must be positive and finite, got {}",
                    Number(value)
                ));
            }
        }
        let nu = self.poisson_ratio;
        if !(nu > -1.0 && nu < 0.5) {
            return invalid(format!(
                "poisson_ratio must lie strictly between -1 and 0.5, got {}",
                Number(nu)
            ));
        }
        Ok(())
    }

    fn validate(&self) -> Result<(), ModelError> {
        let invalid = |s: String| Err(ModelError::InvalidParameter(s));
        for (axis, &n) in ["x", "y", "z"].iter().zip(&self.elements) {
            if !(1..=100_000).contains(&n) {
                return invalid(format!(
                    "elements along {axis} must be between 1 and 100000, got {n}"
                ));
            }
        }
        let count: usize = self.elements.iter().product();
        if count > 1_000_000 {
            return invalid(format!("{count} elements: at most 1000000"));
        }
        for (axis, &l) in ["x", "y", "z"].iter().zip(&self.size) {
            if !(l.is_finite() && l > 0.0) {
                return invalid(format!(
                    "box edge along {axis} must be positive and finite, got {}",
                    Number(l)
                ));
            }
        }
        self.validate_material()?;
        if let Some(face) = self.clamped.iter().find(|f| !FACES.contains(&f.as_str())) {
            return invalid(format!(
                "clamped face `{face}` is not a face of the box (x0, x1, y0, y1, z0, z1)"
            ));
        }
        Ok(())
    }

    /// Builds the box's model (eq. (104)). A solid with a [`Self::mesh`] file is built by
    /// the I/O layer, which reads the file: here it is an error.
    pub fn build(&self) -> Result<Structure, ModelError> {
        self.box_body()?.build()
    }

    /// The box's body, its parameters checked; a solid with a mesh file is refused (the I/O
    /// layer reads the file and builds on it).
    fn box_body(&self) -> Result<Body, ModelError> {
        if let Some(mesh) = &self.mesh {
            return Err(ModelError::InvalidParameter(format!(
                "the mesh file `{}` must be read first (nnm_io::job reads it; or Solid::build_on_mesh)",
                mesh.file
            )));
        }
        self.validate()?;
        self.body()
    }

    /// Builds the model on `mesh` (its tet10 and hex27 elements, the nodes of the physical
    /// groups named in `clamped` held), with this solid's material; `box`, `elements` and
    /// `element` are not used.
    pub fn build_on_mesh(&self, mesh: &Mesh) -> Result<Structure, ModelError> {
        Ok(self.model_on_mesh(mesh)?.0)
    }

    /// [`Self::build_on_mesh`], with the mesh's [`Layout`] (its body nodes, elements and dofs).
    pub fn model_on_mesh(&self, mesh: &Mesh) -> Result<(Structure, Layout), ModelError> {
        self.validate_material()?;
        let body = mesh.body(
            &self.clamped,
            StVenantKirchhoff::new(self.youngs_modulus, self.poisson_ratio),
            self.density,
        )?;
        Ok((body.build()?, body.layout()))
    }

    /// The box's grid nodes, elements and dofs (a solid on a mesh: [`Self::model_on_mesh`]).
    pub fn layout(&self) -> Result<Layout, ModelError> {
        Ok(self.box_body()?.layout())
    }
}

#[cfg(test)]
mod tests;
