//! Bifurcations along a branch: detection between consecutive points and location to the
//! continuation tolerance.
//!
//! Multipliers of a conservative system come in pairs `(μ, 1/μ)` with two always at `+1`
//! ([`crate::floquet`]). A pair can leave the unit circle in only three ways, each a codimension-1
//! event of a one-parameter family of periodic orbits:
//! - through `+1` ([`EventKind::BranchPoint`]): another family of the same period meets this one
//!   (typically one that breaks a symmetry of it); when it coincides with a turning point of the
//!   energy along the branch it is the fold itself ([`EventKind::Fold`]: on an energy surface two
//!   orbits of the family merge there, so the surface's return map has a multiplier `+1`);
//! - through `-1` ([`EventKind::PeriodDoubling`]): a family of twice the period branches off;
//! - off the real axis, after two pairs collide on the circle (a Krein collision,
//!   [`EventKind::NeimarkSacker`]): a quadruplet `(μ, 1/μ, μ̄, 1/μ̄)` forms.
//!
//! **Detection** compares consecutive points: the sign of `dE/ds`, and the number of pairs of
//! each unstable kind. **Location** solves the test function's zero on the arclength interval
//! between them with the Illinois variant of regula falsi, each trial point corrected onto the
//! branch. The test functions are smooth across the event, which the multipliers are not:
//! - fold: `dE/ds`;
//! - `±1`: `2 ∓ σ` with `σ = μ + 1/μ` the pair invariant closest to `±2` (near `+1`, `μ = 1 ± √δ`
//!   while `σ = 2 + δ`, linear in the arclength);
//! - Krein collision: `(σ₁ - σ₂)²` for the two colliding invariants, positive while they are
//!   real and distinct, negative (`-4 (Im σ)²`) once they are complex conjugates.

mod location;
mod switching;

pub use location::BifurcationDetector;
pub use switching::{Switch, SwitchError, switch_branch};

#[cfg(test)]
use location::{bisect, illinois};

use crate::floquet::{Floquet, PairKind};
use crate::linalg::Complex;
use crate::shooting::BranchPoint;

/// The kind of a located event.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum EventKind {
    /// Turning point of the energy along the branch (`dE/ds = 0`).
    Fold,
    /// A non-trivial multiplier pair through `+1` away from a fold.
    BranchPoint,
    /// A multiplier pair through `-1`.
    PeriodDoubling,
    /// Two pairs collide on the unit circle and leave it as a complex quadruplet (or the
    /// reverse).
    NeimarkSacker,
}

impl EventKind {
    /// The name used in files (`fold`, `branch-point`, `period-doubling`, `neimark-sacker`).
    pub fn name(self) -> &'static str {
        match self {
            EventKind::Fold => "fold",
            EventKind::BranchPoint => "branch-point",
            EventKind::PeriodDoubling => "period-doubling",
            EventKind::NeimarkSacker => "neimark-sacker",
        }
    }

    /// Short label for plots: F, BP, PD, NS.
    pub fn abbreviation(self) -> &'static str {
        match self {
            EventKind::Fold => "F",
            EventKind::BranchPoint => "BP",
            EventKind::PeriodDoubling => "PD",
            EventKind::NeimarkSacker => "NS",
        }
    }
}

/// A located event.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Event {
    /// What crossed: the energy's turning point, or a multiplier pair through `+1`, `-1` or
    /// into a Krein collision.
    pub kind: EventKind,
    /// Index of the branch point it follows (the event lies between points `after` and
    /// `after + 1`).
    pub after: usize,
    /// Arclength from point `after` to the event.
    pub arclength: f64,
    /// Width of the final bracket on the arclength: the location's uncertainty.
    pub arclength_uncertainty: f64,
    /// The solution at the event (its `index` is `after`).
    pub point: BranchPoint,
    /// The branch's direction there in state space, `dz0/ds` (length 2n), and its period
    /// rate `dT/ds`: what switching needs of the parent, whatever unknowns it was posed in.
    pub state_tangent: Vec<f64>,
    /// `dT/ds` at the event (s per unit arclength): with `state_tangent`, the parent's tangent
    /// that branch switching re-expresses in its own unknowns (docs/method.md §9).
    pub period_rate: f64,
    /// The critical multiplier: the member of the critical pair nearest `+1` (fold, branch
    /// point) or `-1` (period doubling), or the colliding multiplier in the upper half plane.
    pub multiplier: Complex,
    /// How many pairs sit at the critical value within `1e-4` (for a Krein collision, how many
    /// quadruplets form at once): more than one means a bifurcation made degenerate by
    /// symmetry, with several null directions.
    pub multiplicity: usize,
    /// Corrector solves spent on locating it.
    pub location_steps: usize,
    /// Whether the location converged: the test function went to zero within the arclength
    /// tolerance. `false` flags an event seen only as a change of the multipliers' pattern
    /// (e.g. two pairs changing places in one step), placed to within
    /// `arclength_uncertainty` but not to the tolerance.
    pub converged: bool,
}

/// A change between two consecutive points, before location.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Crossing {
    Fold,
    /// A pair through `+1`; `resting` pairs sit at `+1` on both sides (see [`resting`]) and
    /// are left out of its test function.
    PlusOne {
        resting: usize,
    },
    /// A pair through `-1`, with `resting` pairs at `-1` on both sides.
    MinusOne {
        resting: usize,
    },
    /// Invariants `σ` collide near `rho` (the real part of the complex pair): two, or more
    /// when the colliding pairs are degenerate by symmetry (`count` invariants in all).
    Krein {
        rho: f64,
        count: usize,
    },
}

impl Crossing {
    pub(crate) fn kind(self) -> EventKind {
        match self {
            Crossing::Fold => EventKind::Fold,
            Crossing::PlusOne { .. } => EventKind::BranchPoint,
            Crossing::MinusOne { .. } => EventKind::PeriodDoubling,
            Crossing::Krein { .. } => EventKind::NeimarkSacker,
        }
    }

    /// Whether the test function needs the Floquet multipliers (everything but a fold).
    pub(crate) fn needs_floquet(self) -> bool {
        self != Crossing::Fold
    }
}

fn count(floquet: &Floquet, kind: PairKind) -> usize {
    floquet.pairs.iter().filter(|p| p.kind == kind).count()
}

/// The events between two consecutive points. A `+1` crossing in the same interval as a fold
/// is the fold's own (see the module documentation) and is not reported twice.
pub(crate) fn detect(a: &BranchPoint, b: &BranchPoint) -> Vec<Crossing> {
    let mut found = Vec::new();
    let fold = a.energy_slope * b.energy_slope < 0.0;
    if fold {
        found.push(Crossing::Fold);
    }
    let (fa, fb) = (&a.floquet, &b.floquet);
    // A pair counts as crossing `±1` when it leaves (or rejoins) the circle by more than the
    // stability tolerance *and* its invariant passes `±2` in the interval: a pair already
    // beyond `±1` but within the tolerance at `a` crossed earlier (at the linear limit, for
    // the degenerate partner of a standing wave), and only its stability verdict changes here.
    // A pair resting at `±1` ([`is_resting`]) is on either side of it by round-off: it counts
    // as beyond, so that its flips do not cancel (or fake) a crossing.
    let beyond = |f: &Floquet, target: f64| {
        f.pairs
            .iter()
            .filter(|p| {
                p.kind != PairKind::Complex
                    && ((p.trace().0 - target) * target > 0.0 || is_resting(p, target))
            })
            .count()
    };
    // Every event of the list leaves or joins the unit circle, so the number of elliptic
    // pairs changes; a quadruplet landing on the real axis off the circle (complex pairs
    // turning into real ones) changes other counts only and is no bifurcation.
    let on_circle_changed = count(fa, PairKind::Elliptic) != count(fb, PairKind::Elliptic);
    if !fold
        && on_circle_changed
        && count(fa, PairKind::PositiveReal) != count(fb, PairKind::PositiveReal)
        && beyond(fa, 2.0) != beyond(fb, 2.0)
    {
        found.push(Crossing::PlusOne {
            resting: resting(fa, fb, 2.0),
        });
    }
    if on_circle_changed
        && count(fa, PairKind::NegativeReal) != count(fb, PairKind::NegativeReal)
        && beyond(fa, -2.0) != beyond(fb, -2.0)
    {
        found.push(Crossing::MinusOne {
            resting: resting(fa, fb, -2.0),
        });
    }
    // A Krein collision trades pairs on the circle for a quadruplet (or back): the counts
    // of elliptic and complex pairs move in opposite directions. Both falling at once is a
    // fold's pair leaving the circle while a quadruplet lands on the real axis off it.
    let elliptic_change =
        count(fb, PairKind::Elliptic) as isize - count(fa, PairKind::Elliptic) as isize;
    let complex_change =
        count(fb, PairKind::Complex) as isize - count(fa, PairKind::Complex) as isize;
    if elliptic_change * complex_change < 0 {
        // The quadruplet exists on the side with more complex pairs: the new one is the
        // complex invariant farthest from every complex invariant of the other side.
        let (side, other) = if count(fa, PairKind::Complex) > count(fb, PairKind::Complex) {
            (fa, fb)
        } else {
            (fb, fa)
        };
        let complex = || side.pairs.iter().filter(|p| p.kind == PairKind::Complex);
        let novelty = |s: Complex| {
            other
                .pairs
                .iter()
                .filter(|p| p.kind == PairKind::Complex)
                .map(|p| {
                    let t = p.trace();
                    (t.0 - s.0).hypot(t.1.abs() - s.1.abs())
                })
                .fold(f64::INFINITY, f64::min)
        };
        if let Some(pair) =
            complex().max_by(|x, y| novelty(x.trace()).total_cmp(&novelty(y.trace())))
        {
            let sigma = pair.trace();
            let count = complex()
                .filter(|p| {
                    let s = p.trace();
                    (s.0 - sigma.0).hypot(s.1.abs() - sigma.1.abs()) < 1e-4
                })
                .count();
            found.push(Crossing::Krein {
                rho: sigma.0,
                count,
            });
        }
    }
    found
}

/// Whether the change of the multipliers' pattern between two points is more than the
/// `crossings` detected there account for: each pair through `±1` moves one pair between the
/// circle and the real axis, each Krein collision two pairs between the circle and the
/// complex plane (per quadruplet); twins by symmetry count once. More means several changes in one step, some of which may
/// cancel in the counts (a quadruplet born from two real pairs and dissolving onto the circle
/// within one step, beside a fold), so the step must be refined before locating.
pub(crate) fn unexplained(a: &BranchPoint, b: &BranchPoint, crossings: &[Crossing]) -> bool {
    let kinds = [
        PairKind::Elliptic,
        PairKind::PositiveReal,
        PairKind::NegativeReal,
        PairKind::Complex,
    ];
    // Pairs double by symmetry (twins, equal invariants) move together as one crossing.
    let distinct = |f: &Floquet, kind: PairKind| {
        let mut seen: Vec<Complex> = Vec::new();
        for p in f.pairs.iter().filter(|p| p.kind == kind) {
            let s = p.trace();
            let twin = seen.iter().any(|&t| twins(s, t));
            if !twin {
                seen.push(s);
            }
        }
        seen.len()
    };
    // Elliptic pairs damped by more than RESOLUTION_EDGE, found at the end with more pairs
    // only, are the edge of what a damping integrator's step resolves moving, not pairs
    // leaving or joining the circle (docs/method.md eq. (44b)).
    let edge = |f: &Floquet| {
        (f.pairs.iter())
            .filter(|p| {
                p.kind == PairKind::Elliptic
                    && 1.0 - crate::floquet::modulus(p.multiplier) > RESOLUTION_EDGE
            })
            .count() as isize
    };
    // How many of `x` moves are the same pairs as `y` moves (both counts changing the same
    // way): the smaller change, or none.
    let shared = |x: isize, y: isize| {
        if x * y > 0 {
            x.abs().min(y.abs()) as usize
        } else {
            0
        }
    };
    let total = b.floquet.pairs.len() as isize - a.floquet.pairs.len() as isize;
    let resolution = shared(total, edge(&b.floquet) - edge(&a.floquet));
    // A pair already beyond ±1 within the stability tolerance (classed elliptic, its
    // invariant past ±2), or resting there, that leaves the tolerance band changes its
    // verdict, not the pattern: detect() sees no crossing, counting such pairs beyond ±2 at
    // both ends. So where the real pairs of one sign grew as the elliptic ones in that band
    // fell (or the reverse), that many moves are discounted from both kinds. (Counted, the
    // (1,5) standing wave's degenerate partner drifting out of the band from +1 halved a
    // step three times for nothing; reclassifying the band's pairs as real instead made a
    // pair hovering at the resting threshold a change, on the 5,000-sector disk 32 trials.)
    let drift = |target: f64, real: PairKind| {
        let band = |f: &Floquet| {
            (f.pairs.iter())
                .filter(|p| {
                    p.kind == PairKind::Elliptic
                        && ((p.trace().0 - target) * target > 0.0 || is_resting(p, target))
                })
                .count() as isize
        };
        let grew = count(&b.floquet, real) as isize - count(&a.floquet, real) as isize;
        shared(grew, band(&a.floquet) - band(&b.floquet))
    };
    let (to_plus, to_minus) = (
        drift(2.0, PairKind::PositiveReal),
        drift(-2.0, PairKind::NegativeReal),
    );
    // A kind whose pairs are as many at both ends lost and gained none, however its twins
    // merged: two invariants of different pairs passing each other on the circle make a
    // passing twin (the 500-sector disk's 999 elliptic pairs count 493 to 501 distinct ones
    // from point to point, every step refined three times for nothing).
    let moved: usize = kinds
        .iter()
        .map(|&k| {
            let discount = match k {
                PairKind::Elliptic => resolution + to_plus + to_minus,
                PairKind::PositiveReal => to_plus,
                PairKind::NegativeReal => to_minus,
                PairKind::Complex => 0,
            };
            let raw = count(&a.floquet, k).abs_diff(count(&b.floquet, k));
            // (Twins are merged in quadratic time: not where nothing moved, as on the
            // 5,000-sector disk's 10⁴ pairs at every step.)
            // `distinct` merges a complex invariant with its conjugate, so it counts a
            // quadruplet once where `raw` counts its two pairs: twice its count, in pairs.
            let pairs_per_invariant = if k == PairKind::Complex { 2 } else { 1 };
            match raw.saturating_sub(discount) {
                0 => 0,
                raw => raw.min(
                    (pairs_per_invariant
                        * distinct(&a.floquet, k).abs_diff(distinct(&b.floquet, k)))
                    .saturating_sub(discount),
                ),
            }
        })
        .sum();
    let accounted: usize = crossings
        .iter()
        .map(|c| match c {
            Crossing::Krein { count, .. } => 4 * (count / 2).max(1),
            _ => 2,
        })
        .sum();
    moved > accounted
}

/// Whether two pairs on the circle of opposite Krein signatures that move modes in common
/// changed places between the two points, or a pair next to `±1` changed its signature.
/// Such pairs cannot pass each other on the circle, so they met, left it and came back inside
/// the step — an event and its undoing, which leave the counts of [`detect`] alike at both
/// ends (docs/method.md §8, eq. (44a)). Pairs in different blocks of the monodromy, or moving
/// no mode in common (kept apart by a symmetry of the motion), pass each other freely and are
/// compared apart. `false` where a point's pairs carry no signature.
pub(crate) fn hidden(a: &BranchPoint, b: &BranchPoint) -> bool {
    (0..2).any(|block| {
        // The groups are those of both ends together, so that a mode whose share crosses
        // MODE_SHARE between them cannot split a group at one end only.
        let (Some(x), Some(y)) = (on_circle(&a.floquet, block), on_circle(&b.floquet, block))
        else {
            return false;
        };
        let groups = linked_modes(x.iter().chain(&y).map(|p| p.2));
        groups.iter().any(|&group| {
            let (u, v) = (sign_word(&x, group), sign_word(&y, group));
            u.len() == v.len() && u != v
        })
    })
}

/// One block's pairs on the circle as `(σ, sign, modes)`, from `σ = +2` down, twins (equal
/// invariants to round-off) by sign; pairs resting at `±1` and signs too small to tell are
/// left out. `None` when a pair carries no signature.
fn on_circle(f: &Floquet, block: u8) -> Option<Vec<(f64, i8, u128)>> {
    let mut pairs = Vec::new();
    for p in f
        .pairs
        .iter()
        .filter(|p| p.kind == PairKind::Elliptic && !is_resting(p, 2.0) && !is_resting(p, -2.0))
    {
        let krein = p.krein?;
        if krein.block == block && krein.sign != 0 {
            pairs.push((p.trace().0, krein.sign, krein.modes));
        }
    }
    pairs.sort_by(|x, y| y.0.total_cmp(&x.0));
    let mut start = 0;
    for end in 1..=pairs.len() {
        if end == pairs.len() || !twins((pairs[end - 1].0, 0.0), (pairs[end].0, 0.0)) {
            pairs[start..end].sort_by_key(|p| p.1);
            start = end;
        }
    }
    Some(pairs)
}

/// The modes linked through shared members of `masks` (directly or through others): one mask
/// for each set of linked modes.
fn linked_modes(masks: impl Iterator<Item = u128>) -> Vec<u128> {
    let mut groups: Vec<u128> = Vec::new();
    for mask in masks {
        let mut merged = mask;
        groups.retain(|&g| {
            let linked = g & merged != 0;
            if linked {
                merged |= g;
            }
            !linked
        });
        groups.push(merged);
    }
    groups
}

/// The signs, in order, of the pairs whose modes lie in `group`.
fn sign_word(pairs: &[(f64, i8, u128)], group: u128) -> Vec<i8> {
    pairs
        .iter()
        .filter(|p| p.2 & group != 0)
        .map(|p| p.1)
        .collect()
}

/// Whether two invariants are equal to round-off (relative to the first, up to conjugation):
/// pairs degenerate by a symmetry ("twins").
fn twins(s: Complex, t: Complex) -> bool {
    (t.0 - s.0).hypot(t.1.abs() - s.1.abs()) < TWIN_INVARIANT * s.0.abs().max(1.0)
}

/// The test function of a crossing at a point (see the module documentation), and the
/// critical multiplier there.
pub(crate) fn test_function(crossing: Crossing, point: &BranchPoint) -> Option<(f64, Complex)> {
    let pairs = &point.floquet.pairs;
    match crossing {
        // The fold's own pair crosses +1 with it: report the multiplier nearest +1.
        Crossing::Fold => Some((
            point.energy_slope,
            characteristic(pairs, 2.0, 0).map_or((1.0, 0.0), |(_, m)| m),
        )),
        Crossing::PlusOne { resting } => characteristic(pairs, 2.0, resting),
        Crossing::MinusOne { resting } => characteristic(pairs, -2.0, resting),
        Crossing::Krein { rho, .. } => krein_collision(pairs, rho),
    }
}

/// The Krein collision's test function near `rho` (docs/method.md eq. (41)): `(σ₁ − σ₂)²` for
/// two invariants on the circle about to collide, `−4 (Im σ)²` for a quadruplet they formed;
/// both are `4κ (s − s*)` near the collision, so the function is continuous and linear
/// through it. Also returns the critical multiplier.
///
/// The candidates (eq. (41a)) are every quadruplet — any pair whose invariant is complex
/// beyond round-off, including one still within the stability tolerance of the circle and
/// so classed elliptic — and every two invariants on the circle that can meet: neighbours
/// among the pairs of their block that move modes in common (others pass them freely), of
/// opposite Krein signatures where both are known. Of these, the one whose invariants lie
/// nearest `rho` — the farther of two real ones, `max(|Re σ − ρ|, |Im σ|)` for a quadruplet
/// — is taken: near the collision its own invariants close on `rho`, where another pair's
/// stay apart. Taking instead the real invariants nearest `rho` picked two of one group
/// when another group moved nearer, or a pair passing freely, and the function jumped there.
fn krein_collision(pairs: &[crate::floquet::MultiplierPair], rho: f64) -> Option<(f64, Complex)> {
    let conjugate = |m: Complex| if m.1 >= 0.0 { m } else { (m.0, -m.1) };
    let complex_invariant = |s: Complex| s.1.abs() > ROUND_OFF_INVARIANT * s.0.abs().max(1.0);
    // (distance from rho, test function, multiplier)
    let quadruplets = pairs
        .iter()
        .filter(|p| {
            p.kind == PairKind::Complex
                || (p.kind == PairKind::Elliptic && complex_invariant(p.trace()))
        })
        .map(|p| {
            let sigma = p.trace();
            let distance = (sigma.0 - rho).abs().max(sigma.1.abs());
            (distance, -4.0 * sigma.1 * sigma.1, conjugate(p.multiplier))
        });
    struct OnCircle {
        block: u8,
        sigma: f64,
        sign: i8,
        modes: u128,
        multiplier: Complex,
    }
    let mut real: Vec<OnCircle> = pairs
        .iter()
        .filter(|p| p.kind == PairKind::Elliptic && !complex_invariant(p.trace()))
        .map(|p| OnCircle {
            block: p.krein.map_or(u8::MAX, |k| k.block),
            sigma: p.trace().0,
            sign: p.krein.map_or(0, |k| k.sign),
            modes: p.krein.map_or(u128::MAX, |k| k.modes),
            multiplier: p.multiplier,
        })
        .collect();
    real.sort_by(|x, y| x.block.cmp(&y.block).then(x.sigma.total_cmp(&y.sigma)));
    let meetings = (0..real.len()).filter_map(|i| {
        let x = &real[i];
        // Its next neighbour upwards among the pairs it interacts with.
        let y = real[i + 1..]
            .iter()
            .take_while(|y| y.block == x.block)
            .find(|y| y.modes & x.modes != 0)?;
        // Two of one signature pass each other (a twin's members share theirs). A signature
        // too small to tell is that of a pair about to meet (or at ±1): any two apart by
        // more than round-off. Without signatures: any two that are not twins.
        let opposite = match (x.sign, y.sign) {
            _ if x.block == u8::MAX => !twins((x.sigma, 0.0), (y.sigma, 0.0)),
            (0, _) | (_, 0) => {
                (y.sigma - x.sigma).abs() > ROUND_OFF_INVARIANT * x.sigma.abs().max(1.0)
            }
            (a, b) => a != b,
        };
        opposite.then(|| {
            let distance = (x.sigma - rho).abs().max((y.sigma - rho).abs());
            (
                distance,
                (y.sigma - x.sigma).powi(2),
                conjugate(x.multiplier),
            )
        })
    });
    quadruplets
        .chain(meetings)
        .min_by(|x, y| x.0.total_cmp(&y.0))
        .map(|(_, value, multiplier)| (value, multiplier))
}

/// `∏ (target - σ_k)·sign(target)` over the distinct invariants (twins by symmetry counted
/// once), leaving out the `resting` invariants nearest `target`: `det(±I - D)` up to
/// round-off and the resting factors, with `D` the monodromy with its trivial pair deflated,
/// so smooth along the branch. It changes sign when one pair (or one symmetric set of twins)
/// crosses `±1`, while pairs that stay near `±1` without crossing (a degenerate partner, say)
/// do not disturb it, unlike a test on the single pair nearest `±1`. Complex invariants come
/// in conjugates, whose product is positive. Also returns the multiplier of the pair nearest
/// the target among those kept.
///
/// The resting pairs go first, before twins are merged: a crossing pair near its root is
/// within [`TWIN_INVARIANT`] of a resting one and would otherwise be merged into it, leaving
/// the product with the resting pair's round-off sign.
fn characteristic(
    pairs: &[crate::floquet::MultiplierPair],
    target: f64,
    resting: usize,
) -> Option<(f64, Complex)> {
    let distance = |p: &crate::floquet::MultiplierPair| {
        let s = p.trace();
        (s.0 - target).hypot(s.1)
    };
    let mut nearest_first: Vec<&crate::floquet::MultiplierPair> = pairs.iter().collect();
    nearest_first.sort_by(|x, y| distance(x).total_cmp(&distance(y)));
    let kept = nearest_first.get(resting..)?;
    let mut seen: Vec<Complex> = Vec::new();
    let mut value = 1.0f64;
    for p in kept {
        let s = p.trace();
        if seen
            .iter()
            .any(|t| (t.0 - s.0).hypot(t.1 - s.1) < TWIN_INVARIANT * s.0.abs().max(1.0))
        {
            continue;
        }
        seen.push(s);
        if s.1.abs() > TWIN_INVARIANT * s.0.abs().max(1.0) {
            // One of a conjugate pair: the two factors multiply to |target - σ|².
            value *= (target - s.0).hypot(s.1);
        } else {
            value *= (target - s.0) * target.signum();
        }
    }
    let nearest = kept.first()?;
    value.is_finite().then_some((value, nearest.multiplier))
}

/// Elliptic pairs damped by more than this (`1 − |μ|`) sit at the edge of what a damping
/// integrator's step resolves (Radau IIA keeps a resolved mode within ~1e-5–1e-3 of the
/// circle, and [`Floquet::without_damped`] drops those damped by more than ~5% unless a
/// multiplier near their reciprocal passes for a partner): as the period and the steps
/// change along a branch, such a pair is found at one point and not the next. Counted as
/// moved, it had the von Kármán beams' steps halved three times each for nothing — four
/// steps to +8% at 100 to 1,000 elements (12 trial points, the branch 1.5× its time without
/// events), and at 10⁴ dofs trials at their round-off floor.
const RESOLUTION_EDGE: f64 = 1e-2;

/// An invariant whose imaginary part is below this (relative) is real: a pair on the circle
/// has `ν = μ̄` to round-off (1e-15 seen), while a quadruplet's invariant near its collision
/// is complex by far more (its `Im σ` grows like `√(s − s*)`) even within the stability
/// tolerance of the circle.
const ROUND_OFF_INVARIANT: f64 = 1e-10;

/// Invariants this close (relative) are twins: pairs degenerate by a symmetry of the motion.
const TWIN_INVARIANT: f64 = 1e-6;

/// A pair on the unit circle whose invariant is this close to `±2` rests at `±1`: it cannot be
/// told from `±1` at the default stability tolerance (`|μ ∓ 1| = 1e-4` gives `|σ ∓ 2| = 1e-8`),
/// and which side of it the computed invariant falls is round-off. Such pairs are structural:
/// the Jordan block of a decoupled rigid-body mode, the degenerate partner of a standing wave
/// on a family whose quartic energy is blind to the pattern's orientation. On the bladed
/// disk's n = 0 backbones two pairs rest there with `|σ − 2|` from 1e-16 to 5e-10, flipping
/// sides from point to point; counted, they left 13 of the study's 128 branch points to be
/// placed by bisection (5 of 130 without them; docs/method.md eq. (40a)).
const RESTING_INVARIANT: f64 = 1e-8;

fn is_resting(pair: &crate::floquet::MultiplierPair, target: f64) -> bool {
    let s = pair.trace();
    pair.kind == PairKind::Elliptic && (s.0 - target).hypot(s.1) < RESTING_INVARIANT
}

/// How many pairs rest at `target / 2` (`±1`) at both ends of a step: the fewer of the two
/// counts.
fn resting(a: &Floquet, b: &Floquet, target: f64) -> usize {
    let at = |f: &Floquet| f.pairs.iter().filter(|p| is_resting(p, target)).count();
    at(a).min(at(b))
}

/// How many pairs sit at the critical multiplier (within 1e-4 on `σ`), the resting ones not
/// counted.
pub(crate) fn multiplicity(crossing: Crossing, point: &BranchPoint) -> usize {
    let (target, resting) = match crossing {
        Crossing::Fold => (2.0, 0),
        Crossing::PlusOne { resting } => (2.0, resting),
        Crossing::MinusOne { resting } => (-2.0, resting),
        // `count` invariants: σ and σ̄ of each quadruplet.
        Crossing::Krein { count, .. } => return (count / 2).max(1),
    };
    point
        .floquet
        .pairs
        .iter()
        .filter(|p| p.kind != PairKind::Complex && (p.trace().0 - target).abs() < 1e-4)
        .count()
        .saturating_sub(resting)
        .max(1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::floquet;

    /// A point whose monodromy is block diagonal: the trivial Jordan block at +1, then one
    /// 2×2 block per pair given as (modulus, angle) of `r e^{±iθ}`, or a real pair
    /// (`μ`, `1/μ`) when the angle is `None`.
    fn point(energy_slope: f64, pairs: &[(f64, Option<f64>)]) -> BranchPoint {
        let m = crate::floquet::tests::monodromy_with_pairs(pairs);
        BranchPoint {
            index: 0,
            energy: 1.0,
            energy_slope,
            period: 1.0,
            frequency: 1.0,
            z0: vec![],
            floquet: floquet::analyse(&m, 1e-4).unwrap(),
            relative_residual: 0.0,
            full_period_residual: 0.0,
            iterations: 0,
            step: 0.0,
            unknowns: vec![],
            tangent: vec![],
            label: None,
            peak_displacements: vec![],
            content: vec![],
            regime: None,
            resonance: None,
        }
    }

    /// A Krein quadruplet `(r e^{±iθ}, e^{±iθ}/r)` as two blocks.
    fn quadruplet(r: f64, theta: f64) -> [(f64, Option<f64>); 2] {
        [(r, Some(theta)), (1.0 / r, Some(theta))]
    }

    fn assert_sign_change(crossing: Crossing, a: &BranchPoint, b: &BranchPoint) {
        let (fa, fb) = (
            test_function(crossing, a).unwrap().0,
            test_function(crossing, b).unwrap().0,
        );
        assert!(fa * fb < 0.0, "{crossing:?}: {fa} {fb}");
    }

    #[test]
    fn each_kind_of_event_is_detected_and_its_test_function_changes_sign() {
        let other = (1.0, Some(2.0));
        // A pair through +1: e^{±0.01i} → (1.02, 1/1.02).
        let (a, b) = (
            point(1.0, &[(1.0, Some(0.01)), other]),
            point(1.0, &[(1.02, None), other]),
        );
        assert_eq!(detect(&a, &b), vec![Crossing::PlusOne { resting: 0 }]);
        assert_sign_change(Crossing::PlusOne { resting: 0 }, &a, &b);
        // The same with a fold in the interval: the fold's own crossing.
        let b_fold = point(-1.0, &[(1.02, None), other]);
        assert_eq!(detect(&a, &b_fold), vec![Crossing::Fold]);
        // Through -1.
        let (a, b) = (
            point(1.0, &[(1.0, Some(3.1)), other]),
            point(1.0, &[(-1.05, None), other]),
        );
        assert_eq!(detect(&a, &b), vec![Crossing::MinusOne { resting: 0 }]);
        assert_sign_change(Crossing::MinusOne { resting: 0 }, &a, &b);
        // A Krein collision: two pairs at angles 0.9 and 1.0 meet and leave as a quadruplet.
        let a = point(1.0, &[(1.0, Some(0.9)), (1.0, Some(1.0))]);
        let b = point(1.0, &quadruplet(1.05, 0.95));
        let found = detect(&a, &b);
        assert_eq!(found.len(), 1);
        assert_eq!(found[0].kind(), EventKind::NeimarkSacker);
        let fa = test_function(found[0], &a).unwrap().0;
        let fb = test_function(found[0], &b).unwrap().0;
        assert!(fa > 0.0 && fb < 0.0, "{fa} {fb}");
        assert!((fa - (2.0 * 0.9f64.cos() - 2.0 * 1.0f64.cos()).powi(2)).abs() < 1e-12);
    }

    #[test]
    fn changes_that_are_no_bifurcation_are_not_events() {
        // A quadruplet landing on the positive real axis off the circle.
        let a = point(1.0, &quadruplet(1.3, 0.05));
        let b = point(1.0, &[(1.3, None), (1.35, None)]);
        assert!(detect(&a, &b).is_empty());
        // A pair already beyond +1 at `a` (within the stability tolerance) leaving it further:
        // its crossing happened before this step.
        let a = point(1.0, &[(1.00005, None)]);
        let b = point(1.0, &[(1.01, None)]);
        assert!(detect(&a, &b).is_empty());
        // Nor is it a change of the pattern to explain by refining the step; nor is a pair
        // resting at +1 (`|σ − 2| ~ 1e-12`, a standing wave's degenerate partner) that
        // drifts out of the tolerance band.
        assert!(!unexplained(&a, &b, &[]));
        let resting = point(1.0, &[(1.0 + 1e-6, None)]);
        assert!(detect(&resting, &b).is_empty());
        assert!(!unexplained(&resting, &b, &[]));
        // A pair hovering at +1, resting at one end and just inside the circle at the other,
        // changes nothing either.
        let inside = point(1.0, &[(1.0, Some(1e-3))]);
        assert!(detect(&resting, &inside).is_empty());
        assert!(!unexplained(&resting, &inside, &[]));
        assert!(!unexplained(&inside, &resting, &[]));
    }

    /// Twin pairs (double by symmetry) crossing +1 together still change the sign of the
    /// product test, which counts them once.
    #[test]
    fn twin_pairs_crossing_together_change_the_sign() {
        let other = (1.0, Some(2.0));
        let a = point(1.0, &[(1.0, Some(0.01)), (1.0, Some(0.01)), other]);
        let b = point(1.0, &[(1.005, None), (1.005, None), other]);
        assert_eq!(detect(&a, &b), vec![Crossing::PlusOne { resting: 0 }]);
        assert_eq!(multiplicity(Crossing::PlusOne { resting: 0 }, &b), 2);
        assert_sign_change(Crossing::PlusOne { resting: 0 }, &a, &b);
    }

    /// A pair resting at +1 (a rigid-body Jordan block under round-off: real on one side,
    /// complex on the other, `|σ − 2| ~ 1e-12`) neither counts as a crossing nor sets the sign
    /// of the test function of a pair that does cross, even where the crossing pair passes
    /// within twin distance of it.
    #[test]
    fn pairs_resting_at_plus_one_do_not_disturb_a_crossing() {
        let other = (1.0, Some(2.0));
        let below = (1.0, Some(1e-6)); // σ − 2 = −1e-12
        let above = (1.0 + 1e-6, None); // σ − 2 = +1e-12
        // Only the resting pair changes sides: nothing happens.
        let (a, b) = (point(1.0, &[below, other]), point(1.0, &[above, other]));
        assert!(detect(&a, &b).is_empty());
        // A pair crossing +1 while the resting pair changes sides the other way.
        let a = point(1.0, &[(1.0, Some(0.01)), above, other]);
        let b = point(1.0, &[(1.02, None), below, other]);
        let found = detect(&a, &b);
        assert_eq!(found, vec![Crossing::PlusOne { resting: 1 }]);
        assert_eq!(multiplicity(found[0], &b), 1);
        let f = |p: &BranchPoint| test_function(found[0], p).unwrap();
        assert!(f(&a).0 > 0.0 && f(&b).0 < 0.0, "{:?} {:?}", f(&a), f(&b));
        // The critical multiplier is the crossing pair's, not the resting one's.
        assert!((f(&b).1.0 - 1.02).abs() < 1e-12, "{:?}", f(&b).1);
        // Near the root the crossing pair is 2e-7 from σ = 2, within twin distance of the
        // resting pair: the sign is still the crossing pair's, on both sides.
        let near = |angle: Option<f64>, r: f64| point(1.0, &[(r, angle), below, other]);
        let before = near(Some(4.5e-4), 1.0); // σ − 2 ≈ −2e-7
        let after = near(None, 1.0 + 4.5e-4); // σ − 2 ≈ +2e-7
        assert!(f(&before).0 > 0.0 && f(&after).0 < 0.0);
        assert!(f(&before).0.abs() < 1e-6 && f(&after).0.abs() < 1e-6);
    }

    /// The same point with Krein signs on its pairs on the circle (one block): `sign(angle)`
    /// for the pair at that angle, moving the modes `modes(angle)`.
    fn signed(
        mut p: BranchPoint,
        sign: impl Fn(f64) -> i8,
        modes: impl Fn(f64) -> u128,
    ) -> BranchPoint {
        for pair in p.floquet.pairs.iter_mut() {
            if pair.kind == PairKind::Elliptic {
                let angle = pair.multiplier.1.atan2(pair.multiplier.0);
                pair.krein = Some(floquet::Krein {
                    block: 0,
                    sign: sign(angle),
                    modes: modes(angle),
                });
            }
        }
        p
    }

    /// Two pairs on the circle whose order along it is reversed between two points: a
    /// collision and its undoing inside the step if their signatures differ and they move
    /// modes in common; nothing if they are alike, move different modes (a symmetry keeps
    /// them apart), have no signatures, or a pair left the circle.
    #[test]
    fn pairs_of_opposite_signatures_that_changed_places_met_in_between() {
        // The pair at 0.9 moves to 1.12, the one at 1.1 to 0.88.
        let a = point(1.0, &[(1.0, Some(0.9)), (1.0, Some(1.1))]);
        let b = point(1.0, &[(1.0, Some(1.12)), (1.0, Some(0.88))]);
        let is = |first: f64| move |angle: f64| (angle - first).abs() < 1e-9;
        let positive_first = |p: &BranchPoint, first: f64, shared: bool| {
            let is_first = is(first);
            signed(
                p.clone(),
                move |angle| if is_first(angle) { 1 } else { -1 },
                move |angle| {
                    if shared || is_first(angle) {
                        0b11
                    } else {
                        0b100
                    }
                },
            )
        };
        assert!(hidden(
            &positive_first(&a, 0.9, true),
            &positive_first(&b, 1.12, true)
        ));
        assert!(!hidden(
            &positive_first(&a, 0.9, false),
            &positive_first(&b, 1.12, false)
        ));
        // Alike, they pass each other; or they kept their places.
        let alike = |p: &BranchPoint| signed(p.clone(), |_| 1, |_| 1);
        assert!(!hidden(&alike(&a), &alike(&b)));
        assert!(!hidden(
            &positive_first(&a, 0.9, true),
            &positive_first(&b, 0.88, true)
        ));
        assert!(!hidden(&a, &b));
        let quadruplet_at_b = point(1.0, &quadruplet(1.05, 1.0));
        assert!(!hidden(&positive_first(&a, 0.9, true), &quadruplet_at_b));
    }

    /// The Krein test function follows the two pairs that meet: neighbours of opposite
    /// signatures among those moving modes in common, not the two invariants nearest `rho`
    /// (here two of one signature), nor a pair passing between them that moves other modes.
    /// Across the collision it is `(σ₁ − σ₂)²` on one side and `−4 (Im σ)²` on the other,
    /// also for a quadruplet still within the stability tolerance of the circle.
    #[test]
    fn krein_test_function_follows_the_pairs_that_meet() {
        let sigma = |angle: f64| 2.0 * angle.cos();
        // Angles 0.80 and 0.85 of signature +1, 0.95 and 1.00 of −1; 0.90 (+1) moves other
        // modes. The collision is between 0.85 and 0.95; `rho` sits nearer the first group.
        let angles = [0.80, 0.85, 0.90, 0.95, 1.00];
        let before = point(1.0, &angles.map(|a| (1.0, Some(a))));
        let sign = |angle: f64| if angle < 0.92 { 1 } else { -1 };
        let modes = |angle: f64| {
            if (angle - 0.90).abs() < 1e-9 {
                0b100
            } else {
                0b11
            }
        };
        let before = signed(before, sign, modes);
        let rho = sigma(0.83);
        let krein = Crossing::Krein { rho, count: 2 };
        let (f, _) = test_function(krein, &before).unwrap();
        let expected = (sigma(0.85) - sigma(0.95)).powi(2);
        assert!((f - expected).abs() < 1e-12 * expected, "{f} vs {expected}");
        // After: the two met and left as a quadruplet near angle 0.9.
        let (r, theta) = (1.01, 0.9);
        let after = point(
            1.0,
            &[
                (1.0, Some(0.80)),
                (1.0, Some(0.90)),
                (1.0, Some(1.00)),
                (r, Some(theta)),
                (1.0 / r, Some(theta)),
            ],
        );
        let after = signed(after, sign, modes);
        let (f, _) = test_function(krein, &after).unwrap();
        // σ = μ + 1/μ for μ = r e^{iθ}: Im σ = (r − 1/r) sin θ.
        let im = (r - 1.0 / r) * theta.sin();
        assert!((f + 4.0 * im * im).abs() < 1e-9 * im * im, "{f}");
        // Within the stability tolerance (1e-4) the quadruplet's pairs are classed elliptic,
        // yet their invariants are complex: still the quadruplet's value, negative.
        // A pair of the same signature at 0.84 lies nearer `rho` than the quadruplet: the
        // old rule mixed it with one of the quadruplet's invariants.
        let r = 1.00005;
        let inside = point(
            1.0,
            &[
                (1.0, Some(0.80)),
                (1.0, Some(0.84)),
                (r, Some(theta)),
                (1.0 / r, Some(theta)),
            ],
        );
        let inside = signed(inside, |_| 1, |_| 0b11);
        assert!(
            inside
                .floquet
                .pairs
                .iter()
                .all(|p| p.kind == PairKind::Elliptic)
        );
        let (f, _) = test_function(krein, &inside).unwrap();
        let im = (r - 1.0 / r) * theta.sin();
        assert!((f + 4.0 * im * im).abs() < 1e-6 * im * im, "{f}");
    }

    /// Two pairs on the circle passing each other (equal invariants at one end: one twin
    /// group there, two at the other) move no pair off the circle: nothing to explain.
    #[test]
    fn pairs_passing_each_other_on_the_circle_are_no_unexplained_change() {
        let a = point(1.0, &[(1.0, Some(1.0)), (1.0, Some(1.0)), (1.0, Some(2.0))]);
        let b = point(
            1.0,
            &[(1.0, Some(0.98)), (1.0, Some(1.02)), (1.0, Some(2.0))],
        );
        assert!(detect(&a, &b).is_empty());
        assert!(!unexplained(&a, &b, &[]));
        // A pair leaving the circle beside them is one.
        let c = point(1.0, &[(1.0, Some(0.98)), (1.0, Some(1.02)), (1.3, None)]);
        assert!(unexplained(&a, &c, &[]));
    }

    /// Two quadruplets born in one step (from twin pairs, as on the n = 1 families, where
    /// the harmonics' blocks repeat each invariant) are more than the one Krein collision
    /// detected there explains: a quadruplet's conjugate invariants count once among the
    /// distinct ones but twice among the pairs. Counted once, the step was not refined and
    /// the second collision was lost (the (1,8) family between E = 4.8 and 7.1).
    #[test]
    fn two_quadruplets_in_one_step_are_more_than_one_collision() {
        let a = point(
            1.0,
            &[
                (1.0, Some(0.5)),
                (1.0, Some(0.5)),
                (1.0, Some(0.6)),
                (1.0, Some(0.6)),
            ],
        );
        let [p, q] = quadruplet(1.02, 0.55);
        let [r, s] = quadruplet(1.03, 0.57);
        let b = point(1.0, &[p, q, r, s]);
        let found = detect(&a, &b);
        assert_eq!(found.len(), 1);
        assert!(unexplained(&a, &b, &found));
        // One quadruplet from one twin set of pairs is what the collision explains.
        let one = point(1.0, &[(1.0, Some(0.5)), (1.0, Some(0.6)), p, q]);
        let found = detect(&a, &one);
        assert_eq!(found.len(), 1);
        assert!(!unexplained(&a, &one, &found), "{found:?}");
    }

    /// A pair damped by 5% found at one end only is the edge of what a damping integrator's
    /// step resolves moving (RESOLUTION_EDGE): nothing to explain. A pair on the circle found
    /// at one end only is a change.
    #[test]
    fn a_damped_pair_at_one_end_only_is_no_unexplained_change() {
        let resolved = point(1.0, &[(1.0, Some(1.0)), (1.0, Some(2.0))]);
        let edge = point(
            1.0,
            &[(1.0, Some(1.0)), (1.0, Some(2.0)), (0.95, Some(0.5))],
        );
        assert_eq!(count(&edge.floquet, PairKind::Elliptic), 3);
        assert!(detect(&resolved, &edge).is_empty());
        assert!(!unexplained(&resolved, &edge, &[]));
        assert!(!unexplained(&edge, &resolved, &[]));
        let circle = point(1.0, &[(1.0, Some(1.0)), (1.0, Some(2.0)), (1.0, Some(0.5))]);
        assert!(unexplained(&resolved, &circle, &[]));
    }

    #[test]
    fn bisection_brackets_the_change_and_never_claims_convergence() {
        let located = bisect(1.0, 1e-9, 40, |s| Ok((s > 0.3, s))).unwrap();
        assert!((located.arclength - 0.3).abs() < 1e-9);
        assert!(located.uncertainty < 1e-9);
        assert!(!located.converged);
    }

    #[test]
    fn illinois_finds_a_simple_root_fast_and_keeps_the_bracket() {
        let mut calls = 0;
        let root = 0.3141592653589793;
        let located = illinois(1.0, -root, (1.0 - root) * 2.0, 1e-12, 60, |s| {
            calls += 1;
            // Curved, so plain regula falsi would stall on one side.
            Ok(((s - root) * (1.0 + s * s), s))
        })
        .unwrap();
        assert!(
            (located.arclength - root).abs() < 1e-12,
            "{}",
            located.arclength
        );
        assert!(located.uncertainty < 1e-12);
        assert!(calls < 15, "{calls} trials");
    }
}
