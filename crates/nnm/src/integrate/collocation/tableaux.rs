//! The collocation methods' coefficients: Gauss–Legendre of two and three stages and Radau IIA
//! of three and five (docs/method.md §6).

// Coefficients are quoted with all their digits.
#![allow(clippy::excessive_precision)]

/// A Gauss–Legendre collocation method: nodes `c`, coefficients `A` (row-major) and weights
/// `b` of `s` stages.
#[derive(Debug)]
pub struct Collocation {
    /// Name in settings and reports.
    pub name: &'static str,
    /// Order `2s`.
    pub order: u32,
    /// Nodes `c_i`.
    pub c: &'static [f64],
    /// Row `i` holds `a_{i,0..s}`.
    pub a: &'static [&'static [f64]],
    /// Weights `b_i`.
    pub b: &'static [f64],
}

/// Two-stage Gauss–Legendre, order 4 (`c = ½ ∓ √3/6`).
pub static GAUSS4: Collocation = Collocation {
    name: "gauss4",
    order: 4,
    c: &[0.2113248654051871, 0.7886751345948129],
    a: &[&[0.25, -0.03867513459481288], &[0.5386751345948129, 0.25]],
    b: &[0.5, 0.5],
};

/// Three-stage Gauss–Legendre, order 6 (`c = ½ ∓ √15/10, ½`).
pub static GAUSS6: Collocation = Collocation {
    name: "gauss6",
    order: 6,
    c: &[0.11270166537925831, 0.5, 0.8872983346207417],
    a: &[
        &[
            0.1388888888888889,
            -0.0359766675249389,
            0.009789444015308325,
        ],
        &[
            0.30026319498086457,
            0.2222222222222222,
            -0.022485417203086815,
        ],
        &[0.26798833376246944, 0.48042111196938336, 0.1388888888888889],
    ],
    b: &[0.2777777777777778, 0.4444444444444444, 0.2777777777777778],
};

/// Three-stage Radau IIA collocation, order 5 (`c = (4 ∓ √6)/10, 1`): L-stable, so the
/// unresolved stiff modes are damped (`R(∞) = 0`) instead of carried with an aliased phase.
/// Not symplectic: resolved modes lose energy at the order of the tolerance.
pub static RADAU5: Collocation = Collocation {
    name: "radau5",
    order: 5,
    c: &[0.15505102572168222, 0.6449489742783178, 1.0],
    a: &[
        &[
            0.19681547722366044,
            -0.06553542585019838,
            0.02377097434822015,
        ],
        &[
            0.3944243147390873,
            0.29207341166522843,
            -0.04154875212599792,
        ],
        &[0.37640306270046725, 0.5124858261884216, 0.1111111111111111],
    ],
    b: &[0.37640306270046725, 0.5124858261884216, 0.1111111111111111],
};

/// Five-stage Radau IIA collocation, order 9 (`c` the zeros of `d⁴/dc⁴ [c⁴ (c − 1)⁵]`):
/// L-stable as [`RADAU5`], for tolerances where order 5 needs many steps a period.
pub static RADAU9: Collocation = Collocation {
    name: "radau9",
    order: 9,
    c: &[
        0.05710419611451768,
        0.2768430136381238,
        0.5835904323689168,
        0.8602401356562195,
        1.0,
    ],
    a: &[
        &[
            0.07299886431790333,
            -0.02673533110794557,
            0.018676929763984353,
            -0.01287910609330644,
            0.005042839233882015,
        ],
        &[
            0.15377523147918246,
            0.14621486784749352,
            -0.03644456890512809,
            0.02123306311930472,
            -0.007935579902728777,
        ],
        &[
            0.14006304568480987,
            0.29896712949128346,
            0.16758507013524895,
            -0.03396910168661774,
            0.010944288744192253,
        ],
        &[
            0.14489430810953477,
            0.2765000687601592,
            0.32579792291042103,
            0.12875675325490976,
            -0.015708917378805327,
        ],
        &[
            0.14371356079122594,
            0.28135601514946207,
            0.31182652297574126,
            0.22310390108357075,
            0.04,
        ],
    ],
    b: &[
        0.14371356079122594,
        0.28135601514946207,
        0.31182652297574126,
        0.22310390108357075,
        0.04,
    ],
};

/// A collocation method's coefficients as the stage system uses them: `A` and `Ā = A²`, by
/// rows.
pub(in crate::integrate) struct StageMethod {
    pub(in crate::integrate) a: Vec<Vec<f64>>,
    pub(in crate::integrate) abar: Vec<Vec<f64>>,
}

impl StageMethod {
    pub(in crate::integrate) fn new(method: &Collocation) -> Self {
        let a: Vec<Vec<f64>> = method.a.iter().map(|row| row.to_vec()).collect();
        let s = a.len();
        let abar = (0..s)
            .map(|i| {
                (0..s)
                    .map(|j| (0..s).map(|l| a[i][l] * a[l][j]).sum())
                    .collect()
            })
            .collect();
        Self { a, abar }
    }
}
