//! Where a branch is: on its backbone, in an internal-resonance tongue, or on another family
//! (docs/method.md §18, eqs. (84)–(86)).
//!
//! The motion's displacements over one period are projected on the linear modes and
//! decomposed into harmonics; each (mode, harmonic) component carries the time-averaged linear
//! energy of that part of the motion. A branch's *home* is the set of modes that hold its
//! energy at its first point; a point where another mode holds a sizeable share at some
//! harmonic is in a tongue (an `m:n` internal resonance), and one where another mode holds
//! the most energy has left its family.

use std::f64::consts::PI;

/// One (mode, harmonic) component of a motion (eq. (84)).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ModalComponent {
    /// Index of the linear mode (ascending frequency, as `nnm modes` lists them).
    pub mode: usize,
    /// Harmonic `k` of the motion's fundamental `ω` (0: the static part).
    pub harmonic: usize,
    /// The mode's linear angular frequency `ω_c` (rad/s).
    pub linear_frequency: f64,
    /// Share of the motion's time-averaged linear energy held by this component.
    pub share: f64,
}

/// What a point of a branch is, relative to the branch's start (eq. (86)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum RegimeKind {
    /// The home modes hold the motion, no other mode holds [`TONGUE_SHARE`] of it.
    Backbone,
    /// The home modes still hold the most energy, but another mode holds at least
    /// [`TONGUE_SHARE`] at one harmonic: an internal resonance.
    Tongue,
    /// Another mode holds the most energy: the branch has left its starting family.
    OtherFamily,
}

impl RegimeKind {
    /// The name written in the output (`backbone`, `tongue`, `other-family`).
    pub fn name(self) -> &'static str {
        match self {
            RegimeKind::Backbone => "backbone",
            RegimeKind::Tongue => "tongue",
            RegimeKind::OtherFamily => "other-family",
        }
    }
}

/// The regime of one point, with the mode that makes it so.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Regime {
    /// Backbone, tongue or another family.
    pub kind: RegimeKind,
    /// The largest component outside the home modes that can be resonant (eq. (86b)), if
    /// any.
    pub partner: Option<ModalComponent>,
    /// `(m, n)`: the partner's harmonic to the home's, reduced — `(5, 1)` for a 1:5
    /// internal resonance whose partner mode vibrates at five times the fundamental.
    pub ratio: Option<(usize, usize)>,
}

/// A resonant partner holding at least this share makes a tongue (eq. (86)).
///
/// Away from internal resonance, the partners at other harmonics hold under 1% of the energy
/// on the bladed disk's backbones to +25% (0.9% at most, on (0,6)); inside a tongue the partner
/// takes tens of per cent (the (0,6) tongue: 10% where it is first labelled, 36% where the
/// branch turns into the (1,12) family). A tenth separates the two with a margin.
pub const TONGUE_SHARE: f64 = 0.1;

/// Modes holding at least this share at a branch's first point are its home (eq. (85)): the
/// starting mode alone for a start near the linear limit, both members of a degenerate pair
/// for a travelling wave (half each).
pub const HOME_SHARE: f64 = 0.2;

/// The modal harmonic content of one period (eq. (84)): `samples` displacement states
/// `x(t_j)`, `t_j = jT/N`, projected on the modes by `modal(x, c)` (the modal coordinate of
/// column `c`, whose mode index is `modes[c]` and natural frequency `frequencies[c]`), at
/// harmonics `0..=harmonics` of `omega`. Components are returned by decreasing share; only
/// modes that can resonate with one of those harmonics (`ω_c ≤ (harmonics + ½) ω`) are
/// analysed — a stiffer mode's response is quasi-static, never a resonance.
pub fn modal_content(
    samples: &[Vec<f64>],
    modal: impl Fn(&[f64], usize) -> f64,
    modes: &[usize],
    frequencies: &[f64],
    omega: f64,
    harmonics: usize,
) -> Vec<ModalComponent> {
    let count = samples.len();
    // cos and sin of 2π m/N, m = k j mod N: one table instead of a trigonometric call per
    // sample, mode and harmonic (that was most of the cost).
    let table: Vec<(f64, f64)> = (0..count)
        .map(|m| (2.0 * PI * m as f64 / count as f64).sin_cos())
        .map(|(sin, cos)| (cos, sin))
        .collect();
    let mut energies = Vec::new();
    for (c, (&mode, &omega_c)) in modes.iter().zip(frequencies).enumerate() {
        if omega_c > (harmonics as f64 + 0.5) * omega {
            continue;
        }
        let q: Vec<f64> = samples.iter().map(|x| modal(x, c)).collect();
        for k in 0..=harmonics {
            let (mut re, mut im) = (0.0, 0.0);
            for (j, qj) in q.iter().enumerate() {
                let (cos, sin) = table[(k * j) % count];
                re += qj * cos;
                im -= qj * sin;
            }
            // q = A cos(kωt + φ) has |DFT| = A N/2 (A N for the mean, k = 0).
            let scale = if k == 0 { 1.0 } else { 2.0 } / count as f64;
            let amplitude2 = (re * re + im * im) * scale * scale;
            // Time average of ½q'² + ½ω_c²q² for that harmonic (eq. (84)).
            let energy = if k == 0 {
                0.5 * omega_c * omega_c * amplitude2
            } else {
                0.25 * (omega_c * omega_c + (k as f64 * omega).powi(2)) * amplitude2
            };
            energies.push((mode, k, omega_c, energy));
        }
    }
    let total: f64 = energies.iter().map(|e| e.3).sum();
    let mut components: Vec<ModalComponent> = energies
        .into_iter()
        .map(|(mode, harmonic, linear_frequency, e)| ModalComponent {
            mode,
            harmonic,
            linear_frequency,
            share: if total > 0.0 { e / total } else { 0.0 },
        })
        .collect();
    components.sort_by(|a, b| b.share.total_cmp(&a.share));
    components
}

/// Components below this share are neither kept with a point nor named as partners.
pub const REPORTED_SHARE: f64 = 1e-4;

/// A component at the home's own harmonic resonates 1:1 only with a mode whose linear
/// frequency is within this relative distance of a home mode's (a near-degenerate partner, as
/// in a mistuned pair): otherwise another mode at the same frequency is the NNM's shape
/// changing (a nonsimilar NNM), which is no internal resonance (eq. (86b)).
pub const NEAR_DEGENERATE: f64 = 0.1;

/// A component at harmonic `k` can be resonant when `kω` lies within this factor of the
/// mode's linear frequency `ω_c` (eq. (86b)): the partner's own backbone must reach `kω`, and
/// backbones rarely shift by more than half their frequency before they meet another family
/// (the bladed disk's (1,12) at the (0,6) tongue: `3ω/ω_c = 1.22`). Far from its own
/// frequency, a mode's response at `kω` is forced, however large the motion makes it.
pub const RESONANCE_WINDOW: f64 = 1.5;

/// The modes a branch calls home, and their dominant harmonic (eq. (85)).
#[derive(Debug, Clone, PartialEq)]
pub struct Home {
    /// Modes holding at least [`HOME_SHARE`] of the first point's energy.
    pub modes: Vec<usize>,
    /// Their linear frequencies.
    pub frequencies: Vec<f64>,
    /// The harmonic of the home modes' largest component (1 unless the branch started on a
    /// motion at a multiple of its period).
    pub harmonic: usize,
}

impl Home {
    /// The home of a branch whose first point has `content`; `None` without content.
    pub fn from_first_point(content: &[ModalComponent]) -> Option<Self> {
        let shares = mode_shares(content);
        let dominant = content.first()?;
        let mut modes: Vec<usize> = shares
            .iter()
            .filter(|&&(_, s)| s >= HOME_SHARE)
            .map(|&(m, _)| m)
            .collect();
        if modes.is_empty() {
            modes.push(dominant.mode);
        }
        let frequency_of = |m: usize| {
            content
                .iter()
                .find(|c| c.mode == m)
                .map_or(f64::NAN, |c| c.linear_frequency)
        };
        let frequencies = modes.iter().map(|&m| frequency_of(m)).collect();
        let harmonic = content
            .iter()
            .find(|c| modes.contains(&c.mode) && c.harmonic > 0)
            .map_or(1, |c| c.harmonic);
        Some(Self {
            modes,
            frequencies,
            harmonic,
        })
    }

    /// Whether a component can be in internal resonance with the home motion of fundamental
    /// `omega` (eq. (86b)).
    pub fn resonant(&self, c: &ModalComponent, omega: f64) -> bool {
        if c.harmonic == 0 || c.share < REPORTED_SHARE || self.modes.contains(&c.mode) {
            return false;
        }
        if c.harmonic == self.harmonic {
            self.near_degenerate(c)
        } else {
            let ratio = c.harmonic as f64 * omega / c.linear_frequency;
            (1.0 / RESONANCE_WINDOW..=RESONANCE_WINDOW).contains(&ratio)
        }
    }

    /// The regime of a point of fundamental `omega` with `content` (eq. (86)).
    pub fn classify(&self, content: &[ModalComponent], omega: f64) -> Regime {
        let home_share: f64 = content
            .iter()
            .filter(|c| self.modes.contains(&c.mode))
            .map(|c| c.share)
            .sum();
        // What each other mode holds beyond a change of the NNM's shape: its energy at other
        // harmonics than the home's, and at the home's own if it is near-degenerate (86a).
        let mut moved: Vec<(usize, f64)> = Vec::new();
        for c in content
            .iter()
            .filter(|c| !self.modes.contains(&c.mode) && c.harmonic > 0)
        {
            let counts = c.harmonic != self.harmonic || self.near_degenerate(c);
            if counts {
                match moved.iter_mut().find(|(m, _)| *m == c.mode) {
                    Some(entry) => entry.1 += c.share,
                    None => moved.push((c.mode, c.share)),
                }
            }
        }
        let leader = moved
            .iter()
            .copied()
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .filter(|&(_, share)| share > home_share);
        let (kind, partner) = match leader {
            Some((mode, _)) => (
                RegimeKind::OtherFamily,
                content
                    .iter()
                    .find(|c| c.mode == mode && c.harmonic > 0)
                    .copied(),
            ),
            None => {
                let partner = content.iter().find(|c| self.resonant(c, omega)).copied();
                match partner {
                    Some(p) if p.share >= TONGUE_SHARE => (RegimeKind::Tongue, partner),
                    _ => (RegimeKind::Backbone, partner),
                }
            }
        };
        let ratio = partner.map(|p| {
            let g = gcd(p.harmonic, self.harmonic);
            (p.harmonic / g, self.harmonic / g)
        });
        Regime {
            kind,
            partner,
            ratio,
        }
    }

    /// Whether a component's mode is within [`NEAR_DEGENERATE`] of a home mode's frequency.
    fn near_degenerate(&self, c: &ModalComponent) -> bool {
        self.frequencies
            .iter()
            .any(|w| (c.linear_frequency / w - 1.0).abs() <= NEAR_DEGENERATE)
    }
}

/// Where a branch's regime changes: the index of the first point of each stretch of equal
/// regime and partner mode, the opening backbone stretch left out (it is no change). Points
/// without a regime are skipped.
pub fn regime_changes<'a>(regimes: impl IntoIterator<Item = Option<&'a Regime>>) -> Vec<usize> {
    let mut changes = Vec::new();
    let mut previous = None;
    for (index, regime) in regimes.into_iter().enumerate() {
        let Some(regime) = regime else { continue };
        let partner = regime
            .partner
            .filter(|_| regime.kind != RegimeKind::Backbone)
            .map(|c| c.mode);
        let key = (regime.kind, partner);
        let opening = previous.is_none() && regime.kind == RegimeKind::Backbone;
        if previous != Some(key) && !opening {
            changes.push(index);
        }
        previous = Some(key);
    }
    changes
}

/// Each mode's total share, over its harmonics.
fn mode_shares(content: &[ModalComponent]) -> Vec<(usize, f64)> {
    let mut shares: Vec<(usize, f64)> = Vec::new();
    for c in content {
        match shares.iter_mut().find(|(m, _)| *m == c.mode) {
            Some(entry) => entry.1 += c.share,
            None => shares.push((c.mode, c.share)),
        }
    }
    shares
}

fn gcd(a: usize, b: usize) -> usize {
    if b == 0 { a.max(1) } else { gcd(b, a % b) }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two unit-mass modes, `x = q0 e0 + q1 e1`, sampled at 32 points.
    fn content_of(q0: impl Fn(f64) -> f64, q1: impl Fn(f64) -> f64) -> Vec<ModalComponent> {
        let samples: Vec<Vec<f64>> = (0..32)
            .map(|j| {
                let t = 2.0 * PI * j as f64 / 32.0;
                vec![q0(t), q1(t)]
            })
            .collect();
        modal_content(&samples, |x, c| x[c], &[0, 1], &[1.0, 5.2], 1.0, 8)
    }

    #[test]
    fn energy_shares_of_known_harmonics() {
        // q0 = cos t (energy ¼(1+1)·1 = 0.5), q1 = 0.2 cos 5t (¼(27.04+25)·0.04 = 0.5204).
        let content = content_of(|t| t.cos(), |t| 0.2 * (5.0 * t).cos());
        let total = 0.5 + 0.25 * (5.2f64.powi(2) + 25.0) * 0.04;
        assert_eq!((content[0].mode, content[0].harmonic), (1, 5));
        assert!((content[0].share - 0.5204 / total).abs() < 1e-12);
        assert_eq!((content[1].mode, content[1].harmonic), (0, 1));
        assert!((content[1].share - 0.5 / total).abs() < 1e-12);
        assert!(content[2].share < 1e-25);
    }

    #[test]
    fn regimes_from_backbone_to_tongue_to_other_family() {
        // Mode 1 (ω = 5.2) at the fifth harmonic of ω = 1: 5ω/ω_1 = 0.96, resonant.
        let home = Home::from_first_point(&content_of(|t| t.cos(), |_| 0.0)).unwrap();
        assert_eq!((home.modes.clone(), home.harmonic), (vec![0], 1));
        let backbone = home.classify(&content_of(|t| t.cos(), |t| 0.01 * (5.0 * t).cos()), 1.0);
        assert_eq!(backbone.kind, RegimeKind::Backbone);
        assert_eq!(backbone.ratio, Some((5, 1)));
        let tongue = home.classify(&content_of(|t| t.cos(), |t| 0.1 * (5.0 * t).cos()), 1.0);
        assert_eq!(tongue.kind, RegimeKind::Tongue);
        assert_eq!(tongue.partner.unwrap().mode, 1);
        let other = home.classify(
            &content_of(|t| 0.1 * t.cos(), |t| 0.5 * (5.0 * t).cos()),
            1.0,
        );
        assert_eq!(other.kind, RegimeKind::OtherFamily);
        assert_eq!(other.ratio, Some((5, 1)));
        // The same content read at a fundamental of 2: 5ω/ω_1 = 1.9, beyond the window, so
        // the partner's share is a forced response, not a tongue.
        let forced = home.classify(&content_of(|t| t.cos(), |t| 0.1 * (5.0 * t).cos()), 2.0);
        assert_eq!((forced.kind, forced.partner), (RegimeKind::Backbone, None));
        // At the home's own harmonic, a mode far from the home's frequency is a shape change.
        let shape = home.classify(&content_of(|t| t.cos(), |t| 0.5 * t.cos()), 1.0);
        assert_eq!((shape.kind, shape.partner), (RegimeKind::Backbone, None));
        // A home at the second harmonic (a period-doubled start): 3:2 partner.
        let doubled =
            Home::from_first_point(&content_of(|t| (2.0 * t).cos(), |t| 0.01 * (3.0 * t).cos()))
                .unwrap();
        assert_eq!(doubled.harmonic, 2);
        let content = content_of(|t| (2.0 * t).cos(), |t| 0.2 * (5.0 * t).cos());
        let r = doubled.classify(&content, 1.0);
        assert_eq!((r.kind, r.ratio), (RegimeKind::Tongue, Some((5, 2))));
    }

    #[test]
    fn a_near_degenerate_partner_resonates_one_to_one() {
        let content = |q1: f64| -> Vec<ModalComponent> {
            let samples: Vec<Vec<f64>> = (0..32)
                .map(|j| {
                    let t = 2.0 * PI * j as f64 / 32.0;
                    vec![t.cos(), q1 * t.cos()]
                })
                .collect();
            modal_content(&samples, |x, c| x[c], &[0, 1], &[1.0, 1.05], 1.0, 8)
        };
        let home = Home::from_first_point(&content(0.0)).unwrap();
        let r = home.classify(&content(0.5), 1.0);
        assert_eq!((r.kind, r.ratio), (RegimeKind::Tongue, Some((1, 1))));
    }

    #[test]
    fn regime_changes_are_the_first_points_of_each_stretch() {
        let at = |kind, mode| Regime {
            kind,
            partner: Some(ModalComponent {
                mode,
                harmonic: 3,
                linear_frequency: 1.0,
                share: 0.2,
            }),
            ratio: Some((3, 1)),
        };
        let (b, t, o) = (
            RegimeKind::Backbone,
            RegimeKind::Tongue,
            RegimeKind::OtherFamily,
        );
        // A backbone's partner may change without it being a change of regime.
        let regimes = [
            at(b, 1),
            at(b, 2),
            at(t, 1),
            at(t, 1),
            at(t, 2),
            at(o, 2),
            at(b, 1),
        ];
        let list: Vec<Option<&Regime>> = regimes.iter().map(Some).collect();
        assert_eq!(regime_changes(list), vec![2, 4, 5, 6]);
        assert_eq!(regime_changes([None, Some(&regimes[2])]), vec![1]);
    }

    #[test]
    fn stiff_modes_are_left_out() {
        // ω_c = 20 > (8 + ½)·1: its (quasi-static) response is not analysed.
        let samples = vec![vec![1.0, 1.0]; 32];
        let content = modal_content(&samples, |x, c| x[c], &[0, 1], &[1.0, 20.0], 1.0, 8);
        assert!(content.iter().all(|c| c.mode == 0));
    }
}
