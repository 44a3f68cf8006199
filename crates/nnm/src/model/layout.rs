//! Where a model's dofs sit in space: the points of its mesh, the cells that join them, and
//! which dof moves each point along each axis — what a viewer needs to draw a mode shape or
//! an NNM's motion on the structure (ParaView files are written by `nnm_io::vtk`).

/// The shape of a cell, its points in the order of the model's elements (the solid
/// elements' orders are [`crate::model::MeshElementKind`]'s).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CellKind {
    /// A straight segment between two points (a beam element).
    Line,
    /// The quadratic 10-node tetrahedron.
    Tet10,
    /// The triquadratic 27-node hexahedron.
    Hex27,
}

/// A cell: its shape and its points (indices into [`Layout::points`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Cell {
    /// The cell's shape.
    pub kind: CellKind,
    /// Its points.
    pub points: Vec<usize>,
}

/// A model's points in space and how its dofs move them.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Layout {
    /// Reference coordinates (m).
    pub points: Vec<[f64; 3]>,
    /// The cells.
    pub cells: Vec<Cell>,
    /// Per point, the dof of its displacement along x, y and z (`None`: held, or not a dof of
    /// the model — a beam's rotations move no point).
    pub dofs: Vec<[Option<usize>; 3]>,
}

impl Layout {
    /// A beam along x: `nodes` points at `i · length / (nodes − 1)`, a line between each pair of
    /// neighbours, `dofs(i)` the dofs `[u, v, w]` of point `i`.
    pub fn beam(nodes: usize, length: f64, dofs: impl Fn(usize) -> [Option<usize>; 3]) -> Self {
        let step = length / (nodes.max(2) - 1) as f64;
        Self {
            points: (0..nodes).map(|i| [i as f64 * step, 0.0, 0.0]).collect(),
            cells: (1..nodes)
                .map(|i| Cell {
                    kind: CellKind::Line,
                    points: vec![i - 1, i],
                })
                .collect(),
            dofs: (0..nodes).map(dofs).collect(),
        }
    }

    /// The displacement of every point for the model's displacement `x`, `[ux, uy, uz]`
    /// (zero where no dof moves it).
    pub fn displacements(&self, x: &[f64]) -> Vec<[f64; 3]> {
        self.dofs
            .iter()
            .map(|d| d.map(|dof| dof.map_or(0.0, |i| x[i])))
            .collect()
    }

    /// The largest dof the layout refers to, plus one (`0` for none): a model with fewer dofs
    /// cannot be drawn on it.
    pub fn dofs_needed(&self) -> usize {
        self.dofs
            .iter()
            .flatten()
            .flatten()
            .map(|&i| i + 1)
            .max()
            .unwrap_or(0)
    }
}
