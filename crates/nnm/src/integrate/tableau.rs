//! Butcher tableaux of the embedded explicit Runge–Kutta pairs.
//!
//! Coefficients are the published ones: Dormand & Prince (1980) for DOPRI5, and Hairer,
//! Nørsett & Wanner, *Solving ODEs I*, §II.10 / the `DOP853` code, for the 8(5,3) pair.

// The coefficients are quoted with all the digits they were published with.
#![allow(clippy::excessive_precision)]

/// How the local error of a step is estimated.
#[derive(Debug)]
pub enum ErrorEstimate {
    /// `err = h Σ e_i k_i` with `e = b - b̂` of an embedded lower-order method.
    Embedded(&'static [f64]),
    /// DOP853's blend of a 5th- and a 3rd-order estimate (`err5² / √(err5² + 0.01 err3²)`),
    /// which makes the estimate behave like an 8th-order one. `third` lists the
    /// `(stage, weight)` of the 3rd-order solution.
    Dop853 {
        /// Error weights `e = b - b̂` of the 5th-order estimate, one per stage.
        fifth: &'static [f64],
        /// The 3rd-order solution's non-zero weights; its error estimate is `b` minus them.
        third: [(usize, f64); 3],
    },
}

/// An explicit embedded Runge–Kutta pair.
#[derive(Debug)]
pub struct Tableau {
    /// Name in settings and job files (`dopri5`, `dop853`).
    pub name: &'static str,
    /// Order of the propagated solution.
    pub order: u32,
    /// Exponent `1/(q+1)` of the step-size controller, `q` the order of the error estimate.
    pub controller_exponent: f64,
    /// Nodes `c_i = Σ_j a_ij`: the stage times as fractions of the step.
    pub c: &'static [f64],
    /// Row `i` holds `a_{i,0..i}`.
    pub a: &'static [&'static [f64]],
    /// Weights `b_i` of the propagated solution (docs/method.md eq. (27)).
    pub b: &'static [f64],
    /// How the local error of a step is estimated (for the control of docs/method.md eq. (31)).
    pub error: ErrorEstimate,
    /// First-same-as-last: the last stage is evaluated at the new point, so it is the next
    /// step's first stage.
    pub fsal: bool,
}

/// Dormand–Prince 5(4), FSAL (7 stages, 6 evaluations a step).
pub static DOPRI5: Tableau = Tableau {
    name: "dopri5",
    order: 5,
    controller_exponent: 0.2,
    c: &[0.0, 0.2, 0.3, 0.8, 8.0 / 9.0, 1.0, 1.0],
    a: &[
        &[],
        &[0.2],
        &[3.0 / 40.0, 9.0 / 40.0],
        &[44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0],
        &[
            19372.0 / 6561.0,
            -25360.0 / 2187.0,
            64448.0 / 6561.0,
            -212.0 / 729.0,
        ],
        &[
            9017.0 / 3168.0,
            -355.0 / 33.0,
            46732.0 / 5247.0,
            49.0 / 176.0,
            -5103.0 / 18656.0,
        ],
        &[
            35.0 / 384.0,
            0.0,
            500.0 / 1113.0,
            125.0 / 192.0,
            -2187.0 / 6784.0,
            11.0 / 84.0,
        ],
    ],
    b: &[
        35.0 / 384.0,
        0.0,
        500.0 / 1113.0,
        125.0 / 192.0,
        -2187.0 / 6784.0,
        11.0 / 84.0,
        0.0,
    ],
    error: ErrorEstimate::Embedded(&[
        35.0 / 384.0 - 5179.0 / 57600.0,
        0.0,
        500.0 / 1113.0 - 7571.0 / 16695.0,
        125.0 / 192.0 - 393.0 / 640.0,
        -2187.0 / 6784.0 + 92097.0 / 339200.0,
        11.0 / 84.0 - 187.0 / 2100.0,
        -1.0 / 40.0,
    ]),
    fsal: true,
};

/// Dormand–Prince 8(5,3) ("DOP853"): 12 stages a step.
pub static DOP853: Tableau = Tableau {
    name: "dop853",
    order: 8,
    controller_exponent: 1.0 / 8.0,
    c: &[
        0.0,
        0.526001519587677318785587544488e-01,
        0.789002279381515978178381316732e-01,
        0.118350341907227396726757197510e+00,
        0.281649658092772603273242802490e+00,
        0.333333333333333333333333333333e+00,
        0.25e+00,
        0.307692307692307692307692307692e+00,
        0.651282051282051282051282051282e+00,
        0.6e+00,
        0.857142857142857142857142857142e+00,
        1.0,
    ],
    a: &[
        &[],
        &[5.26001519587677318785587544488e-2],
        &[
            1.97250569845378994544595329183e-2,
            5.91751709536136983633785987549e-2,
        ],
        &[
            2.95875854768068491816892993775e-2,
            0.0,
            8.87627564304205475450678981324e-2,
        ],
        &[
            2.41365134159266685502369798665e-1,
            0.0,
            -8.84549479328286085344864962717e-1,
            9.24834003261792003115737966543e-1,
        ],
        &[
            3.7037037037037037037037037037e-2,
            0.0,
            0.0,
            1.70828608729473871279604482173e-1,
            1.25467687566822425016691814123e-1,
        ],
        &[
            3.7109375e-2,
            0.0,
            0.0,
            1.70252211019544039314978060272e-1,
            6.02165389804559606850219397283e-2,
            -1.7578125e-2,
        ],
        &[
            3.70920001185047927108779319836e-2,
            0.0,
            0.0,
            1.70383925712239993810214054705e-1,
            1.07262030446373284651809199168e-1,
            -1.53194377486244017527936158236e-2,
            8.27378916381402288758473766002e-3,
        ],
        &[
            6.24110958716075717114429577812e-1,
            0.0,
            0.0,
            -3.36089262944694129406857109825e0,
            -8.68219346841726006818189891453e-1,
            2.75920996994467083049415600797e1,
            2.01540675504778934086186788979e1,
            -4.34898841810699588477366255144e1,
        ],
        &[
            4.77662536438264365890433908527e-1,
            0.0,
            0.0,
            -2.48811461997166764192642586468e0,
            -5.90290826836842996371446475743e-1,
            2.12300514481811942347288949897e1,
            1.52792336328824235832596922938e1,
            -3.32882109689848629194453265587e1,
            -2.03312017085086261358222928593e-2,
        ],
        &[
            -9.3714243008598732571704021658e-1,
            0.0,
            0.0,
            5.18637242884406370830023853209e0,
            1.09143734899672957818500254654e0,
            -8.14978701074692612513997267357e0,
            -1.85200656599969598641566180701e1,
            2.27394870993505042818970056734e1,
            2.49360555267965238987089396762e0,
            -3.0467644718982195003823669022e0,
        ],
        &[
            2.27331014751653820792359768449e0,
            0.0,
            0.0,
            -1.05344954667372501984066689879e1,
            -2.00087205822486249909675718444e0,
            -1.79589318631187989172765950534e1,
            2.79488845294199600508499808837e1,
            -2.85899827713502369474065508674e0,
            -8.87285693353062954433549289258e0,
            1.23605671757943030647266201528e1,
            6.43392746015763530355970484046e-1,
        ],
    ],
    b: &[
        5.42937341165687622380535766363e-2,
        0.0,
        0.0,
        0.0,
        0.0,
        4.45031289275240888144113950566e0,
        1.89151789931450038304281599044e0,
        -5.8012039600105847814672114227e0,
        3.1116436695781989440891606237e-1,
        -1.52160949662516078556178806805e-1,
        2.01365400804030348374776537501e-1,
        4.47106157277725905176885569043e-2,
    ],
    error: ErrorEstimate::Dop853 {
        fifth: &[
            0.1312004499419488073250102996e-01,
            0.0,
            0.0,
            0.0,
            0.0,
            -0.1225156446376204440720569753e+01,
            -0.4957589496572501915214079952e+00,
            0.1664377182454986536961530415e+01,
            -0.3503288487499736816886487290e+00,
            0.3341791187130174790297318841e+00,
            0.8192320648511571246570742613e-01,
            -0.2235530786388629525884427845e-01,
        ],
        third: [
            (0, 0.244094488188976377952755905512e+00),
            (8, 0.733846688281611857341361741547e+00),
            (11, 0.220588235294117647058823529412e-01),
        ],
    },
    fsal: false,
};

#[cfg(test)]
mod tests {
    use super::*;

    /// Consistency of the tableaux: rows of `a` sum to `c`, weights sum to 1, the error
    /// weights of an embedded pair sum to 0 (both solutions are consistent).
    #[test]
    fn tableaux_are_consistent() {
        for t in [&DOPRI5, &DOP853] {
            assert_eq!(t.a.len(), t.c.len());
            assert_eq!(t.b.len(), t.c.len());
            for (i, row) in t.a.iter().enumerate() {
                assert_eq!(row.len(), i);
                let sum: f64 = row.iter().sum();
                assert!((sum - t.c[i]).abs() < 1e-14, "{} row {i}", t.name);
            }
            assert!((t.b.iter().sum::<f64>() - 1.0).abs() < 1e-14, "{}", t.name);
            let (ErrorEstimate::Embedded(e) | ErrorEstimate::Dop853 { fifth: e, .. }) = &t.error;
            assert!(e.iter().sum::<f64>().abs() < 1e-14, "{}", t.name);
        }
        let ErrorEstimate::Dop853 { third, .. } = &DOP853.error else {
            unreachable!()
        };
        assert!((third.iter().map(|(_, w)| w).sum::<f64>() - 1.0).abs() < 1e-14);
    }
}
