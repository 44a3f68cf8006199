//! The solid family end to end: a St. Venant–Kirchhoff box's first NNM computed through its
//! element-by-element force equals the same model's written as global polynomial tensors and
//! read back through the tensor path (what an FE code's export gives), point for point; and
//! the backbone hardens (membrane stretching of a box clamped at both ends).
//!
//! Why two points only: the global tensors of even this 81-dof box hold millions of
//! monomials, and their branch takes 14 times the element path's time (measured, four
//! points: 2.6 s against 36 s) — the reason solids are computed element by element.

use std::ops::ControlFlow;

use nnm::model::{NonlinearElement, PolynomialTerms, Solid, Structure};
use nnm::prelude::*;

/// The box and the same box as `M`, `K` and one tensor element.
fn box_and_its_tensor_twin() -> (Structure, Structure) {
    let solid = Solid {
        size: [0.2, 0.02, 0.005],
        elements: [2, 1, 1],
        ..Solid::default()
    }
    .build()
    .unwrap();
    let mut terms = PolynomialTerms::default();
    for e in solid.elements() {
        terms.append(e.polynomial_terms().expect("a polynomial element"));
    }
    let tensor = terms
        .summed()
        .into_tensor(solid.dofs())
        .expect("a gradient");
    let elements: Vec<Box<dyn NonlinearElement>> = vec![Box::new(tensor)];
    let twin = Structure::new(
        solid.mass_matrix().clone(),
        solid.stiffness().clone(),
        elements,
    )
    .unwrap();
    (solid, twin)
}

/// Both backbones from the default start, default settings (events on), two points: the same
/// points to the shooting's accuracy (energies to 1e-7, frequencies to 1e-10: the shooting
/// tolerance is 1e-8, and the two forces differ by round-off), and hardening.
#[test]
fn element_force_and_global_tensors_give_the_same_backbone() {
    let (solid, twin) = box_and_its_tensor_twin();
    let mut settings = Settings::default();
    settings.limits.max_points = 2;
    let backbone = |s: &Structure| {
        let modes = linear_modes(s).unwrap();
        let start = Start::from_linear_mode(s, &modes, 0, None).unwrap();
        let branch = continue_branch(s, &start, &settings, |_| ControlFlow::Continue(())).unwrap();
        (modes[0].frequency, branch)
    };
    let (omega, a) = backbone(&solid);
    let (omega_twin, b) = backbone(&twin);
    assert!((omega / omega_twin - 1.0).abs() < 1e-12);
    assert_eq!(a.points.len(), 2);
    assert_eq!(a.points.len(), b.points.len());
    for (p, q) in a.points.iter().zip(&b.points) {
        assert!(
            (p.energy / q.energy - 1.0).abs() < 1e-7,
            "{} vs {}",
            p.energy,
            q.energy
        );
        assert!((p.frequency / q.frequency - 1.0).abs() < 1e-10);
    }
    for w in a.points.windows(2) {
        assert!(w[1].energy > w[0].energy && w[1].frequency > w[0].frequency);
    }
    let shift = a.points.last().unwrap().frequency / omega - 1.0;
    assert!(shift > 0.0, "the box hardens: {shift:e}");
}
