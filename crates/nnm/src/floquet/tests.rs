use super::*;

#[test]
fn trivial_pair_is_excluded_and_instability_detected() {
    // Block diagonal: Jordan block at +1, a rotation (stable pair), a saddle (2, 1/2).
    let mut m = with_trivial_pair(6, 3.0);
    let (c, s) = (0.3f64.cos(), 0.3f64.sin());
    m[(2, 2)] = c;
    m[(2, 3)] = -s;
    m[(3, 2)] = s;
    m[(3, 3)] = c;
    m[(4, 4)] = 2.0;
    m[(5, 5)] = 0.5;
    let f = analyse(&m, DEFAULT_STABILITY_TOLERANCE).unwrap();
    assert_eq!(f.multipliers.len(), 6);
    assert!((f.max_modulus - 2.0).abs() < 1e-12);
    assert!(!f.stable);
    for k in f.trivial {
        assert!((f.multipliers[k].0 - 1.0).abs() < 1e-12);
    }
    m[(4, 4)] = c;
    m[(4, 5)] = s;
    m[(5, 4)] = -s;
    m[(5, 5)] = c;
    let f = analyse(&m, DEFAULT_STABILITY_TOLERANCE).unwrap();
    assert!(f.stable && (f.max_modulus - 1.0).abs() < 1e-12);
}

/// A degenerate partner pair closer to +1 than the numerically split trivial pair: the
/// "closest to +1" rule mistakes it for the trivial pair and reports the wrong multiplier;
/// deflation along the known directions does not.
#[test]
fn deflation_keeps_a_partner_pair_near_one() {
    let mut m = Mat::<f64>::zeros(4, 4);
    // Trivial Jordan block, perturbed as integration error does: eigenvalues 1 ± 1e-4.
    m[(0, 0)] = 1.0;
    m[(0, 1)] = 1.0;
    m[(1, 0)] = 1e-8;
    m[(1, 1)] = 1.0;
    // Partner pair (1 + 1e-5, 1/(1 + 1e-5)): slightly unstable.
    m[(2, 2)] = 1.0 + 1e-5;
    m[(3, 3)] = 1.0 / (1.0 + 1e-5);
    let naive = analyse(&m, 1e-6).unwrap();
    // Fooled: it reports the split trivial pair (1 + 1e-4) as the largest multiplier.
    assert!(
        (naive.max_modulus - (1.0 + 1e-4)).abs() < 1e-6,
        "{}",
        naive.max_modulus
    );
    let (e0, e1) = ([1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]);
    let f = analyse_deflated(&m, [&e0, &e1], 1e-6).unwrap();
    assert!(!f.stable);
    assert!((f.max_modulus - (1.0 + 1e-5)).abs() < 1e-12);
    assert!(f.reciprocity_defect < 1e-12);
    for k in f.trivial {
        assert!((f.multipliers[k].0 - 1.0).abs() < 2e-4);
    }
}

/// An `n × n` monodromy holding only the trivial pair: the Jordan block at `+1` (coupling
/// `shear`) on coordinates 0 and 1; the tests add their pairs beside it.
fn with_trivial_pair(n: usize, shear: f64) -> Mat<f64> {
    let mut m = Mat::<f64>::zeros(n, n);
    m[(0, 0)] = 1.0;
    m[(0, 1)] = shear;
    m[(1, 1)] = 1.0;
    m
}

/// A 2×2 block with eigenvalues `r e^{±iθ}`.
fn rotation(m: &mut Mat<f64>, at: usize, r: f64, theta: f64) {
    let (c, s) = (r * theta.cos(), r * theta.sin());
    m[(at, at)] = c;
    m[(at, at + 1)] = -s;
    m[(at + 1, at)] = s;
    m[(at + 1, at + 1)] = c;
}

/// One pair of each kind: elliptic, through +1, through -1, and a Krein quadruplet. The
/// pairs must come out with the right partners and kinds, unstable ones first, and
/// `σ = μ + 1/μ` must be the pair's invariant.
#[test]
fn pairs_are_matched_and_classified() {
    let mut m = with_trivial_pair(12, 0.5);
    rotation(&mut m, 2, 1.0, 0.7);
    m[(4, 4)] = 1.3;
    m[(5, 5)] = 1.0 / 1.3;
    m[(6, 6)] = -1.2;
    m[(7, 7)] = -1.0 / 1.2;
    rotation(&mut m, 8, 1.1, 0.9);
    rotation(&mut m, 10, 1.0 / 1.1, 0.9);
    let f = analyse(&m, DEFAULT_STABILITY_TOLERANCE).unwrap();
    assert_eq!(f.pairs.len(), 5);
    assert_eq!(f.unstable_pairs, 4);
    assert!(f.reciprocity_defect < 1e-12, "{}", f.reciprocity_defect);
    let kinds: Vec<PairKind> = f.pairs.iter().map(|p| p.kind).collect();
    assert_eq!(kinds.iter().filter(|k| **k == PairKind::Complex).count(), 2);
    assert!(kinds.contains(&PairKind::PositiveReal));
    assert!(kinds.contains(&PairKind::NegativeReal));
    assert_eq!(kinds[4], PairKind::Elliptic, "unstable pairs first");
    for p in &f.pairs {
        let sigma = p.trace();
        match p.kind {
            PairKind::Elliptic => {
                assert!((sigma.0 - 2.0 * 0.7f64.cos()).abs() < 1e-12 && sigma.1.abs() < 1e-12);
                assert!(p.multiplier.1 > 0.0);
            }
            PairKind::PositiveReal => assert!((sigma.0 - (1.3 + 1.0 / 1.3)).abs() < 1e-12),
            PairKind::NegativeReal => assert!((sigma.0 + 1.2 + 1.0 / 1.2).abs() < 1e-12),
            PairKind::Complex => {
                // (μ, 1/μ) with μ = 1.1 e^{±0.9i}: σ is complex, not 2 Re μ.
                assert!(sigma.1.abs() > 0.1);
                assert!((modulus(p.multiplier) - 1.1).abs() < 1e-12);
            }
        }
    }
}

/// Split analysis of a block-diagonal monodromy (class {0, 1, 4, 5}, rest {2, 3}): the same
/// multipliers as the whole-matrix analysis; and the whole-matrix path when the blocks
/// are coupled.
#[test]
fn split_analysis_matches_the_whole_and_falls_back_when_coupled() {
    let mut m = Mat::<f64>::zeros(6, 6);
    // Class: trivial Jordan block on (0, 1), a saddle on (4, 5).
    m[(0, 0)] = 1.0;
    m[(0, 1)] = 0.7;
    m[(1, 1)] = 1.0;
    m[(4, 4)] = 1.5;
    m[(5, 5)] = 1.0 / 1.5;
    // Rest: a rotation on (2, 3).
    rotation(&mut m, 2, 1.0, 0.4);
    let (e0, e1) = (
        [1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0, 0.0, 0.0],
    );
    let class = [0, 1, 4, 5];
    let whole = analyse_deflated(&m, [&e0, &e1], 1e-6).unwrap();
    let split = analyse_deflated_split(&m, [&e0, &e1], &class, 1e-6).unwrap();
    let sigmas = |f: &Floquet| {
        let mut v: Vec<f64> = f.pairs.iter().map(|p| p.trace().0).collect();
        v.sort_by(f64::total_cmp);
        v
    };
    assert_eq!(sigmas(&whole).len(), 2);
    for (a, b) in sigmas(&whole).iter().zip(sigmas(&split)) {
        assert!((a - b).abs() < 1e-12, "{a} {b}");
    }
    assert_eq!(split.unstable_pairs, 1);
    // Coupled blocks: the split is not valid and must not be used.
    m[(2, 4)] = 0.3;
    let coupled = analyse_deflated_split(&m, [&e0, &e1], &class, 1e-6).unwrap();
    let reference = analyse_deflated(&m, [&e0, &e1], 1e-6).unwrap();
    assert_eq!(coupled, reference);
}

/// What a damping integrator leaves: a resolved mode just inside the circle (kept, on the
/// circle to the tolerance), a damped mode well inside and a real multiplier near 0 without
/// their reciprocal partners (dropped), and a genuinely unstable real pair and quadruplet,
/// both members moved inward by the damping (kept, unstable).
#[test]
fn without_damped_drops_unpartnered_multipliers_inside_the_circle() {
    let mut m = with_trivial_pair(16, 0.5);
    rotation(&mut m, 2, 1.0 - 1e-5, 0.7);
    rotation(&mut m, 4, 0.77, 1.2);
    m[(6, 6)] = 0.002;
    m[(7, 7)] = 1.3 * (1.0 - 1e-3);
    m[(8, 8)] = (1.0 - 1e-3) / 1.3;
    rotation(&mut m, 9, 1.1 * (1.0 - 1e-3), 0.9);
    rotation(&mut m, 11, (1.0 - 1e-3) / 1.1, 0.9);
    m[(13, 13)] = -0.5;
    m[(14, 14)] = 0.9;
    m[(15, 15)] = 0.99;
    let tolerance = DEFAULT_STABILITY_TOLERANCE;
    let all = analyse(&m, tolerance).unwrap();
    assert_eq!(all.multipliers.len(), 16);
    let kept = all.without_damped(tolerance);
    // The trivial pair, the resolved mode's pair, the real pair and the quadruplet.
    assert_eq!(
        kept.multipliers.len(),
        2 + 2 + 2 + 4,
        "{:?}",
        kept.multipliers
    );
    assert!(kept.multipliers.iter().all(|z| {
        let r = modulus(*z);
        (r - 1.0).abs() < 1e-3
            || (r - 1.3).abs() < 0.01
            || (r - 1.1).abs() < 0.01
            || (r - 1.0 / 1.3).abs() < 0.01
            || (r - 1.0 / 1.1).abs() < 0.01
    }));
    assert!(!kept.stable);
    assert_eq!(kept.unstable_pairs, 3, "{:?}", kept.pairs);
    assert_eq!(
        kept.pairs
            .iter()
            .filter(|p| p.kind == PairKind::Elliptic)
            .count(),
        1
    );
}

/// A pair through `+1` and a quadruplet of a mode the integrator damps by 2% (both members
/// moved inward, `|μ ν| = 0.96`) keep both members: the events of modes at the edge of what
/// the step resolves are not lost with their damping.
#[test]
fn without_damped_keeps_unstable_pairs_of_damped_modes() {
    let mut m = with_trivial_pair(8, 0.5);
    m[(2, 2)] = 1.01 * 0.98;
    m[(3, 3)] = 0.98 / 1.01;
    rotation(&mut m, 4, 1.05 * 0.98, 0.8);
    rotation(&mut m, 6, 0.98 / 1.05, 0.8);
    let tolerance = DEFAULT_STABILITY_TOLERANCE;
    let kept = analyse(&m, tolerance).unwrap().without_damped(tolerance);
    assert_eq!(kept.multipliers.len(), 8, "{:?}", kept.multipliers);
}

/// A symplectic monodromy in the coordinates `(ω_c q_c, q̇_c)` (ω_c = 1): the trivial block on
/// mode 0, mode 1 turned by +1.0 and mode 2 by −1.5 (its multiplier in the upper half plane is
/// then the conjugate's: the opposite Krein signature), mixed by the symplectic shear
/// `[[I, 0], [A, I]]` with `A` symmetric, which changes no signature.
fn two_rotations(shear: f64) -> Mat<f64> {
    let mut m = Mat::<f64>::zeros(6, 6);
    m[(0, 0)] = 1.0;
    m[(0, 3)] = 0.3;
    m[(3, 3)] = 1.0;
    for (mode, angle) in [(1, 1.0f64), (2, -1.5f64)] {
        let (c, s) = (angle.cos(), angle.sin());
        m[(mode, mode)] = c;
        m[(mode, mode + 3)] = s;
        m[(mode + 3, mode)] = -s;
        m[(mode + 3, mode + 3)] = c;
    }
    let mut a = Mat::<f64>::identity(6, 6);
    let mut inverse = Mat::<f64>::identity(6, 6);
    for (i, j, v) in [(1, 1, 0.4), (1, 2, 0.3), (2, 1, 0.3), (2, 2, -0.2)] {
        a[(i + 3, j)] = shear * v;
        inverse[(i + 3, j)] = -shear * v;
    }
    &(&a * &m) * &inverse
}

#[test]
fn pairs_on_the_circle_carry_their_krein_signatures() {
    let (e0, e3) = (
        [1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, 1.0, 0.0, 0.0],
    );
    let sign_at = |f: &Floquet, angle: f64| {
        let pair = f
            .pairs
            .iter()
            .find(|p| (p.multiplier.1.atan2(p.multiplier.0) - angle).abs() < 1e-9)
            .unwrap_or_else(|| panic!("no pair at angle {angle}: {:?}", f.pairs));
        pair.krein.expect("a signature")
    };
    for shear in [0.0, 1.0] {
        let m = two_rotations(shear);
        let f = DenseFloquet
            .analyse(&m, [&e0, &e3], None, Some(&[1.0, 1.0, 1.0]), 1e-6)
            .unwrap();
        assert_eq!((sign_at(&f, 1.0).block, sign_at(&f, 1.0).sign), (0, 1));
        assert_eq!((sign_at(&f, 1.5).block, sign_at(&f, 1.5).sign), (0, -1));
        // Coupled by the shear, both pairs move modes 1 and 2; apart, each its own.
        let expected = if shear == 0.0 {
            [0b010, 0b100]
        } else {
            [0b110, 0b110]
        };
        assert_eq!([sign_at(&f, 1.0).modes, sign_at(&f, 1.5).modes], expected);
        // Without the form there is no signature.
        let plain = DenseFloquet
            .analyse(&m, [&e0, &e3], None, None, 1e-6)
            .unwrap();
        assert!(plain.pairs.iter().all(|p| p.krein.is_none()));
    }
    // Split into a class (modes 0, 1) and the rest (mode 2): each pair keeps its sign, in
    // its own block; frequencies other than 1 rescale the form but not its sign here.
    let class = [0, 1, 3, 4];
    let f = DenseFloquet
        .analyse(
            &two_rotations(0.0),
            [&e0, &e3],
            Some(&class),
            Some(&[1.0, 2.0, 3.0]),
            1e-6,
        )
        .unwrap();
    assert_eq!((sign_at(&f, 1.0).block, sign_at(&f, 1.0).sign), (0, 1));
    assert_eq!((sign_at(&f, 1.5).block, sign_at(&f, 1.5).sign), (1, -1));
}

/// A monodromy with the trivial Jordan block at `+1` and one 2×2 block per pair given as
/// `(r, Some(θ))` for `r e^{±iθ}`, or `(μ, None)` for the real pair `(μ, 1/μ)`.
pub(crate) fn monodromy_with_pairs(pairs: &[(f64, Option<f64>)]) -> Mat<f64> {
    let mut m = with_trivial_pair(2 + 2 * pairs.len(), 0.3);
    for (k, &(r, angle)) in pairs.iter().enumerate() {
        let at = 2 + 2 * k;
        match angle {
            Some(theta) => rotation(&mut m, at, r, theta),
            None => {
                m[(at, at)] = r;
                m[(at + 1, at + 1)] = 1.0 / r;
            }
        }
    }
    m
}

/// The invariant shift matches the two sets of invariants in sorted order (the matching that
/// moves the farthest least on a line), whatever order the analyses list the pairs in, and
/// clamps what lies beyond ±2.2.
#[test]
fn invariant_shift_is_the_largest_move_of_the_sorted_invariants() {
    let analysis =
        |pairs: &[(f64, Option<f64>)]| analyse(&monodromy_with_pairs(pairs), 1e-4).unwrap();
    let sigma = |theta: f64| 2.0 * theta.cos();
    let a = analysis(&[(1.0, Some(0.5)), (1.0, Some(1.0)), (5.0, None)]);
    // Listed the other way round, each invariant moved a little; the real pair off the
    // circle grew far beyond 2.2, which counts as nothing.
    let b = analysis(&[(30.0, None), (1.0, Some(1.03)), (1.0, Some(0.52))]);
    let shift = a.invariant_shift(&b).unwrap();
    let expected = (sigma(1.0) - sigma(1.03))
        .abs()
        .max((sigma(0.5) - sigma(0.52)).abs());
    assert!((shift - expected).abs() < 1e-12, "{shift} vs {expected}");
    // Different numbers of pairs (partial spectra) do not compare.
    let c = analysis(&[(1.0, Some(0.5)), (1.0, Some(1.0))]);
    assert!(a.invariant_shift(&c).is_none());
}
