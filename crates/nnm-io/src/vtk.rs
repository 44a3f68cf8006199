//! ParaView output: a model's motion on its [`Layout`] as VTK unstructured-grid files
//! (`.vtu`, written by the `vtkio` crate), one per frame, indexed by a `.pvd` collection
//! whose time steps are the frames' times — what FE users open to watch a mode shape or an
//! NNM's motion (ParaView: open the `.pvd`, then "Warp By Vector" on `displacement`).

use std::path::Path;

use nnm::model::{CellKind, Layout, MeshElementKind};
use vtkio::model::{
    Attribute, Attributes, ByteOrder, CellType, Cells, DataSet, IOBuffer, UnstructuredGridPiece,
    Version, VertexNumbers, Vtk,
};

use crate::error::{FileError, io_reason};

/// VTK's point order of its quadratic tetrahedron (cell type 24): the vertices, then the
/// mid-edge points of these edges.
const VTK_TET10_EDGES: [[usize; 2]; 6] = [[0, 1], [1, 2], [0, 2], [0, 3], [1, 3], [2, 3]];

/// VTK's point order of its triquadratic hexahedron (cell type 29) on `[−1, 1]³`: the
/// vertices, the mid-edge points of the edges 0–1, 1–2, 2–3, 3–0, 4–5, 5–6, 6–7, 7–4, 0–4,
/// 1–5, 2–6, 3–7, the centres of the faces x = −1, x = 1, y = −1, y = 1, z = −1, z = 1, and
/// the centre.
const VTK_HEX27: [[f64; 3]; 27] = [
    [-1.0, -1.0, -1.0],
    [1.0, -1.0, -1.0],
    [1.0, 1.0, -1.0],
    [-1.0, 1.0, -1.0],
    [-1.0, -1.0, 1.0],
    [1.0, -1.0, 1.0],
    [1.0, 1.0, 1.0],
    [-1.0, 1.0, 1.0],
    [0.0, -1.0, -1.0],
    [1.0, 0.0, -1.0],
    [0.0, 1.0, -1.0],
    [-1.0, 0.0, -1.0],
    [0.0, -1.0, 1.0],
    [1.0, 0.0, 1.0],
    [0.0, 1.0, 1.0],
    [-1.0, 0.0, 1.0],
    [-1.0, -1.0, 0.0],
    [1.0, -1.0, 0.0],
    [1.0, 1.0, 0.0],
    [-1.0, 1.0, 0.0],
    [-1.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.0, -1.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, -1.0],
    [0.0, 0.0, 1.0],
    [0.0, 0.0, 0.0],
];

/// The cells of `layout` as VTK's connectivity, offsets and types (its point orders).
fn cells(layout: &Layout) -> Cells {
    let order = |kind: MeshElementKind, format: &[[f64; 3]]| {
        // For each of VTK's points, nnm's: the inverse of nnm's positions in VTK's order.
        let ours = kind.order_in(format).expect("VTK's cell has every node");
        let mut inverse = vec![0; ours.len()];
        for (a, &v) in ours.iter().enumerate() {
            inverse[v] = a;
        }
        inverse
    };
    let tet10 = order(
        MeshElementKind::Tet10,
        &MeshElementKind::tet10_with_edges(&VTK_TET10_EDGES),
    );
    let hex27 = order(MeshElementKind::Hex27, &VTK_HEX27);
    let (mut connectivity, mut offsets, mut types) = (Vec::new(), Vec::new(), Vec::new());
    for cell in &layout.cells {
        let (kind, permutation) = match cell.kind {
            CellKind::Line => (CellType::Line, None),
            CellKind::Tet10 => (CellType::QuadraticTetra, Some(&tet10)),
            CellKind::Hex27 => (CellType::TriquadraticHexahedron, Some(&hex27)),
        };
        match permutation {
            Some(p) => connectivity.extend(p.iter().map(|&a| cell.points[a] as u64)),
            None => connectivity.extend(cell.points.iter().map(|&a| a as u64)),
        }
        offsets.push(connectivity.len() as u64);
        types.push(kind);
    }
    Cells {
        cell_verts: VertexNumbers::XML {
            connectivity,
            offsets,
        },
        types,
    }
}

/// Writes the frames `(t, x)` (time and the model's displacement) of a motion on `layout`:
/// `<pvd>` (a ParaView collection, its time steps the frames' `t`) and the frames as
/// `<pvd without .pvd>/frame-NNN.vtu`, each with the point data `displacement`. `x` has the
/// model's dofs ([`Layout::dofs_needed`] at least).
pub fn write_motion(
    pvd: &Path,
    layout: &Layout,
    frames: &[(f64, Vec<f64>)],
) -> Result<(), FileError> {
    let fail = |path: &Path, message: String| FileError {
        path: path.to_owned(),
        message,
    };
    let needed = layout.dofs_needed();
    if let Some((_, x)) = frames.iter().find(|(_, x)| x.len() < needed) {
        return Err(fail(
            pvd,
            format!("a frame has {} dofs, the layout needs {needed}", x.len()),
        ));
    }
    let folder = pvd.with_extension("");
    std::fs::create_dir_all(&folder)
        .map_err(|e| fail(&folder, format!("cannot create: {}", io_reason(&e))))?;
    let points: Vec<f64> = layout.points.iter().flatten().copied().collect();
    let cells = cells(layout);
    let digits = frames.len().saturating_sub(1).to_string().len().max(3);
    let stem = folder
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut collection = String::from(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\">\n  <Collection>\n",
    );
    for (k, (t, x)) in frames.iter().enumerate() {
        let name = format!("frame-{k:0digits$}.vtu");
        let displacement: Vec<f64> = layout.displacements(x).into_iter().flatten().collect();
        let vtk = Vtk {
            version: Version::new_xml(1, 0),
            title: String::new(),
            byte_order: ByteOrder::LittleEndian,
            file_path: None,
            data: DataSet::inline(UnstructuredGridPiece {
                points: IOBuffer::F64(points.clone()),
                cells: cells.clone(),
                data: Attributes {
                    point: vec![Attribute::vectors("displacement").with_data(displacement)],
                    cell: Vec::new(),
                },
            }),
        };
        let path = folder.join(&name);
        vtk.export(&path)
            .map_err(|e| fail(&path, format!("cannot write: {e}")))?;
        collection += &format!(
            "    <DataSet timestep=\"{t:e}\" file=\"{}/{name}\"/>\n",
            xml_attribute(&stem)
        );
    }
    collection += "  </Collection>\n</VTKFile>\n";
    std::fs::write(pvd, collection)
        .map_err(|e| fail(pvd, format!("cannot write: {}", io_reason(&e))))
}

/// `text` as the value of an XML attribute in double quotes.
fn xml_attribute(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}
