//! Gmsh meshes of the default solid box (examples/meshes, written by Gmsh through
//! examples/meshes/box.py) against the structured box of the same family, and the one-line
//! errors of meshes nnm cannot take.

use std::path::{Path, PathBuf};

use nnm::MechanicalSystem;
use nnm::model::{Mesh, MeshElementKind, Solid, Structure};
use nnm::modes::lowest_modes;
use nnm_io::gmsh::read_mesh;

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/meshes")
        .join(name)
}

/// The default box's material, clamped at the mesh's `root` and `tip`.
fn clamped_at_both_ends() -> Solid {
    Solid {
        clamped: vec!["root".into(), "tip".into()],
        ..Solid::default()
    }
}

fn frequencies(s: &Structure, count: usize) -> Vec<f64> {
    lowest_modes(s, count)
        .unwrap()
        .iter()
        .map(|m| m.frequency)
        .collect()
}

/// Gmsh's transfinite 10 × 1 × 1 hex27 mesh is the structured box's discretisation, node
/// for node: the same dofs and the same frequencies to the eigensolver's accuracy, whether
/// the file is ASCII or binary.
#[test]
fn gmsh_hex27_box_has_the_structured_box_frequencies() {
    let structured = Solid::default().build().unwrap();
    let expected = frequencies(&structured, 6);
    for file in ["box-hex27.msh", "box-hex27-binary.msh"] {
        let mesh = read_mesh(&example(file)).unwrap();
        assert_eq!(mesh.elements.len(), 10);
        let s = clamped_at_both_ends().build_on_mesh(&mesh).unwrap();
        assert_eq!(s.dofs(), structured.dofs());
        for (w, e) in frequencies(&s, 6).iter().zip(&expected) {
            assert!((w / e - 1.0).abs() < 1e-8, "{file}: {w} vs {e}");
        }
    }
}

/// Gmsh's tet10 mesh: every mid-edge node at the midpoint of its edge (the node order is
/// Gmsh's), and the first three frequencies within the discretisation's difference of a
/// converged structured box (40 × 4 × 2 hex27): 0.1%, where the 10 × 1 × 1 box is 3% stiff.
#[test]
fn gmsh_tet10_box_converges_to_the_structured_box() {
    let mesh = read_mesh(&example("box-tet10.msh")).unwrap();
    assert!(
        mesh.elements
            .iter()
            .all(|e| e.kind == MeshElementKind::Tet10)
    );
    let edges = [[0, 1], [1, 2], [0, 2], [0, 3], [2, 3], [1, 3]];
    for e in &mesh.elements {
        for (k, [a, b]) in edges.iter().enumerate() {
            let (xa, xb, xm) = (
                mesh.nodes[e.nodes[*a]],
                mesh.nodes[e.nodes[*b]],
                mesh.nodes[e.nodes[4 + k]],
            );
            for d in 0..3 {
                assert!(
                    (0.5 * (xa[d] + xb[d]) - xm[d]).abs() < 1e-12,
                    "element {}",
                    e.tag
                );
            }
        }
    }
    let tets = frequencies(&clamped_at_both_ends().build_on_mesh(&mesh).unwrap(), 3);
    let converged = Solid {
        elements: [40, 4, 2],
        ..Solid::default()
    };
    let converged = frequencies(&converged.build().unwrap(), 3);
    for (w, c) in tets.iter().zip(&converged) {
        assert!((w / c - 1.0).abs() < 1e-3, "{w} vs {c}");
    }
}

/// A one-element tet10 mesh as MSH 4.1 ASCII: the reference tetrahedron scaled by 0.1 m,
/// the face `x = 0` (nodes 1, 3, 4, 7, 8, 9) as a triangle6 on the surface of physical
/// group "root", the tetrahedron of type `volume_type` with `nodes` in the volume of group
/// "body".
fn one_tet_msh(version: &str, volume_type: u32, nodes: &[usize]) -> String {
    let x = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.5, 0.0, 0.0],
        [0.5, 0.5, 0.0],
        [0.0, 0.5, 0.0],
        [0.0, 0.0, 0.5],
        [0.0, 0.5, 0.5],
        [0.5, 0.0, 0.5],
    ];
    let mut s = format!(
        "$MeshFormat\n{version} 0 8\n$EndMeshFormat\n$PhysicalNames\n2\n2 1 \"root\"\n3 2 \"body\"\n$EndPhysicalNames\n\
         $Entities\n0 0 1 1\n1 0 0 0 0 0.1 0.1 1 1 0\n1 0 0 0 0.1 0.1 0.1 1 2 0\n$EndEntities\n\
         $Nodes\n1 10 1 10\n3 1 0 10\n"
    );
    for tag in 1..=10 {
        s += &format!("{tag}\n");
    }
    for p in x {
        s += &format!("{} {} {}\n", 0.1 * p[0], 0.1 * p[1], 0.1 * p[2]);
    }
    s += "$EndNodes\n$Elements\n2 2 1 2\n2 1 9 1\n1 1 3 4 7 9 8\n";
    s += &format!("3 1 {volume_type} 1\n2");
    for n in nodes {
        s += &format!(" {n}");
    }
    s += "\n$EndElements\n";
    s
}

fn error_of(text: &str, clamped: &[&str]) -> String {
    let dir = std::env::temp_dir().join(format!("nnm-gmsh-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("mesh-{:x}.msh", text.len() * 31 + clamped.len()));
    std::fs::write(&path, text).unwrap();
    let result = read_mesh(&path)
        .map_err(|e| e.to_string())
        .and_then(|mesh: Mesh| {
            Solid {
                clamped: clamped.iter().map(|s| s.to_string()).collect(),
                ..Solid::default()
            }
            .build_on_mesh(&mesh)
            .map(|_| ())
            .map_err(|e| e.to_string())
        });
    std::fs::remove_file(&path).ok();
    let message = result.expect_err("refused");
    assert!(!message.contains('\n'), "one line: {message}");
    message
}

/// The hand-written one-element mesh is read right (so that the errors below are the
/// ones they name): ten nodes, the clamped face's six, 12 free dofs.
#[test]
fn one_element_mesh_is_read() {
    let dir = std::env::temp_dir().join(format!("nnm-gmsh-ok-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("tet.msh");
    std::fs::write(&path, one_tet_msh("4.1", 11, &(1..=10).collect::<Vec<_>>())).unwrap();
    let mesh = read_mesh(&path).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    assert_eq!(mesh.nodes.len(), 10);
    let root = mesh.groups.iter().find(|g| g.name == "root").unwrap();
    assert_eq!(root.nodes, vec![0, 2, 3, 6, 7, 8]);
    let s = Solid {
        clamped: vec!["root".into()],
        ..Solid::default()
    }
    .build_on_mesh(&mesh)
    .unwrap();
    assert_eq!(s.dofs(), 12);
}

#[test]
fn refuses_meshes_it_cannot_take() {
    let good: Vec<usize> = (1..=10).collect();
    // Vertices 2 and 3 swapped (with their edges' nodes): a left-handed element.
    let inverted = [1, 3, 2, 4, 7, 6, 5, 8, 10, 9];
    let cases: [(String, &[&str], &str); 7] = [
        (one_tet_msh("2.2", 11, &good), &["root"], "MSH version 2.2"),
        (one_tet_msh("4.1", 4, &good[..4]), &["root"], "type Tet4"),
        (
            one_tet_msh("4.1", 11, &inverted),
            &["root"],
            "mesh element 2 (tet10) is inverted or degenerate: det J = -",
        ),
        (
            one_tet_msh("4.1", 11, &good),
            &["rooot"],
            "clamped group `rooot` is not a physical group of the mesh (it has: body, root)",
        ),
        (
            one_tet_msh("4.1", 11, &good),
            &["body"],
            "every node is clamped",
        ),
        (
            one_tet_msh("4.1", 11, &good)
                .replace("3 1 11 1\n2 1 2 3 4 5 6 7 8 9 10\n", "")
                .replace("$Elements\n2 2", "$Elements\n1 1"),
            &["root"],
            "no volume elements",
        ),
        (
            "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 2\n".into(),
            &["root"],
            "not a valid MSH 4.1 file",
        ),
    ];
    for (text, clamped, expected) in cases {
        let message = error_of(&text, clamped);
        assert!(
            message.contains(expected),
            "{message:?} should say {expected:?}"
        );
    }
}
