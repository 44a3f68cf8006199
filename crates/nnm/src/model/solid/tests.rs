use std::sync::Arc;

use super::assembly::Body;
use super::element::Geometry;
use super::*;
use crate::MechanicalSystem;
use crate::model::{Block, BlockMut, PolynomialTerms};
use crate::modes::{linear_modes, lowest_modes};

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

/// Pseudo-random numbers in `[−1, 1)` (xorshift), the same sequence every run.
fn random_sequence(mut seed: u64) -> impl FnMut() -> f64 {
    move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}

/// A small box clamped at `x = 0`, stubby enough that every dof matters.
fn small_box(elements: [usize; 3], clamped: &[&str]) -> Solid {
    Solid {
        size: [0.2, 0.1, 0.05],
        elements,
        clamped: clamped.iter().map(|s| s.to_string()).collect(),
        ..Solid::default()
    }
}

/// The grid coordinates of the box's nodes, in node order.
fn grid_coordinates(b: &Solid) -> Vec<[f64; 3]> {
    let grid = b.grid();
    let nodes: usize = grid.iter().product();
    (0..nodes)
        .map(|g| {
            let ijk = [
                g % grid[0],
                (g / grid[0]) % grid[1],
                g / (grid[0] * grid[1]),
            ];
            std::array::from_fn(|d| ijk[d] as f64 * b.size[d] / (grid[d] - 1) as f64)
        })
        .collect()
}

/// A conforming tet10 mesh of the `(2n+1)`-point grid of a box's nodes (node numbering as
/// the box's): each of the `n[0] × n[1] × n[2]` cells cut along its main diagonal into six
/// tetrahedra (Kuhn's split), whose mid-edge nodes are grid nodes. Node `g` at
/// `place([i, j, k])`; a group per face (`x0`, ..., `z1`) with the face's nodes.
fn tet10_grid(elements: [usize; 3], place: impl Fn([usize; 3]) -> [f64; 3]) -> Mesh {
    let grid = elements.map(|n| 2 * n + 1);
    let node = |p: [usize; 3]| p[0] + grid[0] * (p[1] + grid[1] * p[2]);
    let ijk = |g: usize| {
        [
            g % grid[0],
            (g / grid[0]) % grid[1],
            g / (grid[0] * grid[1]),
        ]
    };
    let count: usize = grid.iter().product();
    let nodes: Vec<[f64; 3]> = (0..count).map(|g| place(ijk(g))).collect();
    let reference = tet10::node_coordinates();
    let mut cells = Vec::new();
    for ez in 0..elements[2] {
        for ey in 0..elements[1] {
            for ex in 0..elements[0] {
                for permutation in [
                    [0, 1, 2],
                    [0, 2, 1],
                    [1, 0, 2],
                    [1, 2, 0],
                    [2, 0, 1],
                    [2, 1, 0],
                ] {
                    // The path (0,0,0) → e_π0 → e_π0 + e_π1 → (1,1,1), in grid steps of 2.
                    let mut corner = [0usize; 3];
                    let mut vertices = vec![corner];
                    for &axis in &permutation {
                        corner[axis] += 2;
                        vertices.push(corner);
                    }
                    // Right-handed: swap two vertices where the edges' triple product is
                    // negative (the odd permutations).
                    let edge = |v: usize| vertices[v].map(|c| c as f64);
                    let (a, b, c) = (edge(1), edge(2), edge(3));
                    let volume = a[0] * (b[1] * c[2] - b[2] * c[1])
                        - a[1] * (b[0] * c[2] - b[2] * c[0])
                        + a[2] * (b[0] * c[1] - b[1] * c[0]);
                    if volume < 0.0 {
                        vertices.swap(1, 2);
                    }
                    let base = [2 * ex, 2 * ey, 2 * ez];
                    // A reference node as the combination of the vertices.
                    let at = |v: [f64; 3]| -> [usize; 3] {
                        let l = [1.0 - v[0] - v[1] - v[2], v[0], v[1], v[2]];
                        std::array::from_fn(|d| {
                            let offset: f64 = (0..4).map(|i| l[i] * vertices[i][d] as f64).sum();
                            base[d] + offset.round() as usize
                        })
                    };
                    let nodes: Vec<usize> = reference.iter().map(|&v| node(at(v))).collect();
                    cells.push(nodes);
                }
            }
        }
    }
    let elements = cells
        .into_iter()
        .enumerate()
        .map(|(k, nodes)| MeshElement {
            kind: MeshElementKind::Tet10,
            tag: k as u64 + 1,
            nodes,
        })
        .collect();
    let groups = FACES
        .iter()
        .enumerate()
        .map(|(f, name)| {
            let (axis, end) = (f / 2, f % 2 == 1);
            NodeGroup {
                name: name.to_string(),
                nodes: (0..count)
                    .filter(|&g| ijk(g)[axis] == if end { grid[axis] - 1 } else { 0 })
                    .collect(),
            }
        })
        .collect();
    Mesh {
        nodes,
        elements,
        groups,
    }
}

/// The same body as hex27 box and as tet10 mesh of its grid: `(element, model, node
/// coordinates)`, nodes numbered alike.
fn both_elements(b: &Solid) -> [(&'static str, Structure, Vec<[f64; 3]>); 2] {
    let coordinates = grid_coordinates(b);
    let step: [f64; 3] = std::array::from_fn(|d| b.size[d] / (2 * b.elements[d]) as f64);
    let mesh = tet10_grid(b.elements, |p| {
        std::array::from_fn(|d| p[d] as f64 * step[d])
    });
    [
        ("hex27", b.build().unwrap(), coordinates.clone()),
        ("tet10", b.build_on_mesh(&mesh).unwrap(), coordinates),
    ]
}

/// The dense tangent through the elements' products and through the assembled values.
fn tangents(s: &Structure, x: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let n = x.len();
    let eye: Vec<f64> = (0..n * n)
        .map(|k| if k % (n + 1) == 0 { 1.0 } else { 0.0 })
        .collect();
    let mut kt = vec![0.0; n * n];
    s.tangent_stiffness(
        x,
        Block::new(&eye, n, n, n),
        BlockMut::new(&mut kt, n, n, n),
    );
    let pattern = s.tangent_pattern().expect("assembled").clone();
    let mut values = vec![0.0; pattern.nonzeros()];
    s.tangent_values(x, &mut values);
    let mut assembled = vec![0.0; n * n];
    for i in 0..n {
        for p in pattern.row_start[i]..pattern.row_start[i + 1] {
            assembled[pattern.col[p] * n + i] = values[p];
        }
    }
    (kt, assembled)
}

/// Displacements with strains of a few percent: deep in the nonlinear range.
fn large_state(n: usize, seed: u64) -> Vec<f64> {
    let mut random = random_sequence(seed);
    (0..n).map(|_| 2e-3 * random()).collect()
}

/// The tangent is the Jacobian of the internal force (central differences: the force is
/// cubic, so their error is `h² f'''/6`), the same through the element products and the
/// assembled values, and symmetric.
#[test]
fn tangent_is_symmetric_jacobian_of_force() {
    for (element, s, _) in both_elements(&small_box([2, 1, 1], &["x0"])) {
        let n = s.dofs();
        let x = large_state(n, 0x9e37_79b9_7f4a_7c15);
        let (kt, assembled) = tangents(&s, &x);
        let scale = max_abs(&kt);
        let h = 1e-7;
        for j in 0..n {
            let (mut xp, mut xm) = (x.clone(), x.clone());
            xp[j] += h;
            xm[j] -= h;
            let (mut fp, mut fm) = (vec![0.0; n], vec![0.0; n]);
            s.internal_force(&xp, &mut fp);
            s.internal_force(&xm, &mut fm);
            for i in 0..n {
                let fd = (fp[i] - fm[i]) / (2.0 * h);
                let k = kt[j * n + i];
                assert!(
                    (fd - k).abs() < 1e-7 * scale,
                    "{element} ({i}, {j}): {fd} vs {k}"
                );
                assert!((assembled[j * n + i] - k).abs() < 1e-13 * scale);
                assert!(
                    (kt[i * n + j] - k).abs() < 1e-13 * scale,
                    "{element} ({i}, {j})"
                );
            }
        }
    }
}

/// The internal force is the gradient of the potential, the total and the nonlinear part
/// alone (central differences; the potential is quartic).
#[test]
fn force_is_gradient_of_potential() {
    for (element, s, _) in both_elements(&small_box([2, 1, 1], &["x0"])) {
        let n = s.dofs();
        let x = large_state(n, 0x2545_f491_4f6c_dd1d);
        let nonlinear = |x: &[f64]| s.elements().iter().map(|e| e.potential(x)).sum::<f64>();
        let (mut f, mut f_nl) = (vec![0.0; n], vec![0.0; n]);
        s.internal_force(&x, &mut f);
        s.nonlinear_force(&x, &mut f_nl);
        let (scale, scale_nl) = (max_abs(&f), max_abs(&f_nl));
        assert!(scale_nl > 1e-2 * scale, "the state is nonlinear");
        let h = 1e-7;
        for i in 0..n {
            let (mut xp, mut xm) = (x.clone(), x.clone());
            xp[i] += h;
            xm[i] -= h;
            let fd = (s.potential_energy(&xp) - s.potential_energy(&xm)) / (2.0 * h);
            assert!(
                (fd - f[i]).abs() < 1e-7 * scale,
                "{element} dof {i}: {fd} vs {}",
                f[i]
            );
            let fd = (nonlinear(&xp) - nonlinear(&xm)) / (2.0 * h);
            assert!(
                (fd - f_nl[i]).abs() < 1e-7 * scale_nl,
                "{element} dof {i}: {fd} vs {}",
                f_nl[i]
            );
        }
    }
}

/// A free body has exactly six rigid-body modes: the three translations and three rotations
/// are in `K`'s null space to round-off, and the modal analysis finds six rigid modes, the
/// first elastic one far above round-off.
#[test]
fn free_body_has_six_rigid_body_modes() {
    for (element, s, coordinates) in both_elements(&small_box([2, 1, 1], &[])) {
        let n = s.dofs();
        let k = s.stiffness();
        let k_scale = k.entries().fold(0.0f64, |m, e| m.max(e.2.abs()));
        for mode in 0..6 {
            let r: Vec<f64> = (0..n)
                .map(|d| {
                    let (x, c) = (coordinates[d / 3], d % 3);
                    if mode < 3 {
                        f64::from(u8::from(c == mode))
                    } else {
                        // e_axis × X
                        let axis = mode - 3;
                        let (p, q) = ((axis + 1) % 3, (axis + 2) % 3);
                        if c == q {
                            x[p]
                        } else if c == p {
                            -x[q]
                        } else {
                            0.0
                        }
                    }
                })
                .collect();
            let kr = k.times(&r);
            assert!(
                max_abs(&kr) < 1e-13 * k_scale * max_abs(&r),
                "{element} rigid motion {mode}: |K r| = {:e}",
                max_abs(&kr)
            );
        }
        let modes = linear_modes(&s).unwrap();
        assert_eq!(modes.iter().filter(|m| m.rigid).count(), 6, "{element}");
        assert!(modes[..6].iter().all(|m| m.rigid));
        let highest = modes.last().unwrap().frequency;
        assert!(modes[6].frequency > 1e-3 * highest);
    }
}

/// SVK is objective: a finite rigid rotation (plus a translation) of a free body strains
/// nothing, so the internal force `K x + f_nl(x)` vanishes to round-off of its linear part
/// alone and the potential to round-off of `½ xᵀ K x`.
#[test]
fn finite_rigid_rotation_gives_no_force() {
    let b = small_box([2, 2, 1], &[]);
    // Rotation by 0.9 rad about (1, 2, 3)/√14 (Rodrigues).
    let axis = [1.0, 2.0, 3.0].map(|v: f64| v / 14f64.sqrt());
    let (sin, cos) = 0.9f64.sin_cos();
    let rotation: [[f64; 3]; 3] = std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            let cross = match (i, j) {
                (0, 1) => -axis[2],
                (0, 2) => axis[1],
                (1, 0) => axis[2],
                (1, 2) => -axis[0],
                (2, 0) => -axis[1],
                (2, 1) => axis[0],
                _ => 0.0,
            };
            let delta = if i == j { 1.0 } else { 0.0 };
            cos * delta + sin * cross + (1.0 - cos) * axis[i] * axis[j]
        })
    });
    let translation = [0.01, -0.02, 0.005];
    for (element, s, coordinates) in both_elements(&b) {
        let n = s.dofs();
        let x: Vec<f64> = coordinates
            .iter()
            .flat_map(|p| {
                (0..3).map(move |i| {
                    (0..3).map(|j| rotation[i][j] * p[j]).sum::<f64>() - p[i] + translation[i]
                })
            })
            .collect();
        assert_eq!(x.len(), n);
        let kx = s.stiffness().times(&x);
        let mut f = vec![0.0; n];
        s.internal_force(&x, &mut f);
        assert!(
            max_abs(&f) < 1e-12 * max_abs(&kx),
            "{element}: |f| = {:e} against |K x| = {:e}",
            max_abs(&f),
            max_abs(&kx)
        );
        let linear = 0.5 * crate::linalg::dot(&x, &kx);
        assert!(s.potential_energy(&x).abs() < 1e-12 * linear);
    }
}

/// The patch test on a mesh of unequal, sheared elements (hex27, and the same nodes cut into
/// tet10): under an affine displacement the
/// stress is constant, so the internal force (linear and nonlinear) at every interior node
/// vanishes to round-off of the boundary nodes' forces.
#[test]
fn affine_displacement_passes_the_patch_test() {
    // Element boundaries along each axis, unequal; mid-side nodes halfway (straight edges).
    let breaks = [0.0, 0.35, 1.0];
    let axis: Vec<f64> = (0..5)
        .map(|i| {
            if i % 2 == 0 {
                breaks[i / 2]
            } else {
                0.5 * (breaks[i / 2] + breaks[i / 2 + 1])
            }
        })
        .collect();
    let shear = [[1.0, 0.2, 0.1], [0.0, 0.9, 0.3], [0.0, 0.0, 0.7]];
    let node = |i: usize, j: usize, k: usize| i + 5 * (j + 5 * k);
    let coordinates: Vec<[f64; 3]> = (0..125)
        .map(|g| {
            let p = [axis[g % 5], axis[(g / 5) % 5], axis[g / 25]];
            std::array::from_fn(|r| (0..3).map(|c| shear[r][c] * p[c]).sum())
        })
        .collect();
    let reference = hex27::gauss_points();
    let mut elements = Vec::new();
    for ez in 0..2 {
        for ey in 0..2 {
            for ex in 0..2 {
                let nodes: Vec<usize> = (0..27)
                    .map(|a| node(2 * ex + a % 3, 2 * ey + (a / 3) % 3, 2 * ez + a / 9))
                    .collect();
                let corners: Vec<[f64; 3]> = nodes.iter().map(|&g| coordinates[g]).collect();
                let geometry = Geometry::new(&reference, &corners).unwrap();
                elements.push((nodes, Arc::new(geometry)));
            }
        }
    }
    let body = Body {
        nodes: 125,
        coordinates: coordinates.clone(),
        elements,
        clamped: vec![false; 125],
        material: material::StVenantKirchhoff::new(70e9, 0.33),
        density: 2700.0,
    };
    // The same nodes cut into tet10 elements.
    let tets = tet10_grid([2, 2, 2], |p| coordinates[node(p[0], p[1], p[2])]);
    let tets = Solid {
        clamped: vec![],
        ..Solid::default()
    }
    .build_on_mesh(&tets)
    .unwrap();
    for (element, s) in [("hex27", body.build().unwrap()), ("tet10", tets)] {
        let gradient = [
            [0.02, -0.01, 0.03],
            [0.015, 0.01, -0.02],
            [-0.01, 0.025, 0.005],
        ];
        let x: Vec<f64> = coordinates
            .iter()
            .flat_map(|p| (0..3).map(move |i| (0..3).map(|j| gradient[i][j] * p[j]).sum::<f64>()))
            .collect();
        let mut f_nl = vec![0.0; x.len()];
        s.nonlinear_force(&x, &mut f_nl);
        let f_lin = s.stiffness().times(&x);
        let interior = |g: usize| {
            [g % 5, (g / 5) % 5, g / 25]
                .iter()
                .all(|&c| (1..4).contains(&c))
        };
        for f in [&f_lin, &f_nl] {
            let scale = max_abs(f);
            assert!(scale > 0.0);
            for g in (0..125).filter(|&g| interior(g)) {
                for c in 0..3 {
                    assert!(
                        f[3 * g + c].abs() < 1e-12 * scale,
                        "{element} node {g}: {:e} of {scale:e}",
                        f[3 * g + c]
                    );
                }
            }
        }
    }
}

/// The first three bending modes through the thickness of a slender clamped–clamped box
/// (`ν = 0`, so that the section bends as a beam's does) converge to Euler–Bernoulli theory
/// `ω_k = (β_k L)² √(E I / (ρ A L⁴))` as the mesh refines, to the shear and rotary-inertia
/// difference the beam theory neglects: Timoshenko's first-order correction
/// `−(β_k L)² (1 + E/κG) r²/(2 L²)`, `r² = h²/12`, `κ = 5/6`: −3.2e-4, −8.7e-4 and −1.7e-3
/// here. Measured (docs/validation.md): +3.1%, +0.60%, +0.053%, −0.036% for the first mode
/// on 8, 16, 32 and 64 elements along the box; the 64-element frequencies lie 15%, 1% and 7%
/// of the correction from it (the first-order formula is itself approximate: asserted 25%).
#[test]
fn bending_frequencies_converge_to_euler_bernoulli() {
    const BETA: [f64; 3] = [
        4.730_040_744_862_704,
        7.853_204_624_095_838,
        10.995_607_838_001_67,
    ];
    let base = Solid {
        size: [1.0, 0.02, 0.01],
        poisson_ratio: 0.0,
        clamped: vec!["x0".into(), "x1".into()],
        ..Solid::default()
    };
    let thickness = base.size[2];
    let scale = (base.youngs_modulus * thickness * thickness / 12.0 / (base.density)).sqrt();
    let mut errors = Vec::new();
    for nx in [8, 16, 32, 64] {
        let b = Solid {
            elements: [nx, 1, 1],
            ..base.clone()
        };
        let s = b.build().unwrap();
        let modes = lowest_modes(&s, 12).unwrap();
        // Bending through the thickness: the z displacement dominates.
        let bending: Vec<f64> = modes
            .iter()
            .filter(|m| {
                let part = |c: usize| {
                    m.shape
                        .iter()
                        .skip(c)
                        .step_by(3)
                        .fold(0.0f64, |a, v| a.max(v.abs()))
                };
                part(2) > 10.0 * part(1).max(part(0))
            })
            .map(|m| m.frequency)
            .take(3)
            .collect();
        assert_eq!(bending.len(), 3, "{nx} elements");
        let e: Vec<f64> = bending
            .iter()
            .zip(BETA)
            .map(|(w, beta)| w / (beta * beta * scale / b.size[0].powi(2)) - 1.0)
            .collect();
        eprintln!("{nx} x 1 x 1: relative to Euler-Bernoulli {e:?}");
        errors.push(e);
    }
    let kappa_g_over_e = 5.0 / 6.0 / (2.0 * (1.0 + base.poisson_ratio));
    let timoshenko =
        |beta: f64| -beta * beta * (1.0 + 1.0 / kappa_g_over_e) * thickness.powi(2) / 24.0;
    for k in 0..3 {
        let shear = timoshenko(BETA[k]);
        for fine in 1..errors.len() {
            let distance = |e: &[f64]| (e[k] - shear).abs();
            assert!(
                distance(&errors[fine]) < distance(&errors[fine - 1]),
                "mode {k}"
            );
        }
        let finest = errors.last().unwrap();
        assert!(
            (finest[k] - shear).abs() < 0.25 * shear.abs(),
            "mode {k}: {finest:?}"
        );
    }
}

/// The elements' polynomial terms (eq. (106) expanded), summed over the mesh and read back as
/// one global tensor through the tensor path (which checks that they are a gradient,
/// eq. (59)), give the elements' own force and tangent to round-off, at states deep in the
/// nonlinear range.
#[test]
fn global_tensors_give_the_elements_force_and_tangent() {
    let s = small_box([1, 1, 1], &["x0"]).build().unwrap();
    let n = s.dofs();
    let mut terms = PolynomialTerms::default();
    for e in s.elements() {
        terms.append(e.polynomial_terms().expect("a polynomial element"));
    }
    let tensor = terms.summed().into_tensor(n).expect("a gradient");
    for seed in [1u64, 2, 3] {
        let x = large_state(n, 0x1234_5678 * seed);
        crate::model::checks::assert_tensor_gives_the_elements(&s, &tensor, &x);
    }
}

/// Dofs follow the grid: node `i + (2nx+1)(j + (2ny+1)k)`, clamped nodes left out, the rest
/// ascending; the model has three dofs per free node.
#[test]
fn dofs_follow_the_grid_numbering() {
    let b = small_box([2, 1, 1], &["x0", "x1"]);
    let s = b.build().unwrap();
    // 5 × 3 × 3 nodes, 9 on each clamped face.
    assert_eq!(s.dofs(), 3 * (45 - 18));
    assert_eq!(b.node_dofs(0), None);
    assert_eq!(b.node_dofs(4), None);
    assert_eq!(b.node_dofs(1), Some([0, 1, 2]));
    assert_eq!(b.node_dofs(6), Some([9, 10, 11]));
    assert_eq!(b.node_dofs(45), None);
}

#[test]
fn rejects_bad_parameters() {
    let bad = [
        Solid {
            poisson_ratio: 0.5,
            ..Solid::default()
        },
        Solid {
            poisson_ratio: -1.0,
            ..Solid::default()
        },
        Solid {
            youngs_modulus: 0.0,
            ..Solid::default()
        },
        Solid {
            density: f64::NAN,
            ..Solid::default()
        },
        Solid {
            size: [1.0, -0.1, 0.01],
            ..Solid::default()
        },
        Solid {
            elements: [10, 0, 1],
            ..Solid::default()
        },
        Solid {
            clamped: vec!["w0".into()],
            ..Solid::default()
        },
    ];
    for b in bad {
        let e = b.build().unwrap_err();
        assert!(matches!(e, ModelError::InvalidParameter(_)), "{e}");
    }
}
