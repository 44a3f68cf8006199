//! The pendulum example (a system written from scratch against `MechanicalSystem`) against the
//! exact period `T = 4 K(sin²(θ0/2))` of `θ'' + sin θ = 0`, up to θ0 = 3 rad.

#[path = "../examples/pendulum.rs"]
mod pendulum;
#[path = "../src/reference.rs"]
#[allow(dead_code)]
mod reference;

#[test]
fn pendulum_backbone_matches_the_exact_period_up_to_three_radians() {
    let points = pendulum::backbone(3.0).unwrap();
    assert!(points.len() > 5, "only {} points", points.len());
    let (first, last) = (points[0], *points.last().unwrap());
    assert!(first.0 < 0.1, "starts at θ0 = {}", first.0);
    assert!(last.0 >= 3.0, "reached only θ0 = {}", last.0);
    let mut worst = 0.0f64;
    for &(amplitude, period) in &points {
        let m = (0.5 * amplitude).sin().powi(2);
        let exact = 4.0 * reference::elliptic_k(m);
        let error = (period - exact).abs() / exact;
        worst = worst.max(error);
        assert!(
            error < 1e-9,
            "θ0 = {amplitude}: T = {period}, exact {exact} (relative error {error:.2e})"
        );
    }
    eprintln!(
        "pendulum: {} points to θ0 = {:.4}, T = {:.6}; worst relative period error {worst:.2e}",
        points.len(),
        last.0,
        last.1
    );
}
