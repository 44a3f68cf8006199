//! The columns of a branch's points, each declared once in [`POINT_COLUMNS`]: its name, unit,
//! meaning, and how its value is computed from a point. The header and rows of `<name>.csv`
//! are derived from the list ([`csv_header`], [`csv_record`]), and so can any other table of a
//! branch's points (the Python binding's arrays: [`PointColumn::key`]). docs/output.md explains
//! each column at length.
//!
//! Adding a column is one entry here (and its row in docs/output.md). `<name>.json` is not a
//! table of these columns but a record of each point's own fields (`PointRecord` in
//! `output/mod.rs`): a column computed from them needs nothing there.

use nnm::BranchPoint;

use super::number;

/// The type of a column's values, for a reader that keeps one array per column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A number; an array holds NaN where a point has none ([`Value::Empty`]).
    Float,
    /// A count or an index, which every point has.
    Integer,
    /// A count or an index that a point may lack ([`Value::Empty`]): an empty field has no
    /// integer, so an array of the column needs a float type and NaN.
    OptionalInteger,
    Bool,
    /// A word; a point without one leaves it empty.
    Text,
}

/// One field of a point.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    Float(f64),
    Integer(usize),
    Bool(bool),
    Text(String),
    /// Nothing to say (no partner, no label): an empty CSV field.
    Empty,
}

impl Value {
    /// The field as the CSV writes it: floats by [`number`], booleans `true`/`false`, nothing
    /// for [`Value::Empty`].
    pub fn csv_field(&self) -> String {
        match self {
            Value::Float(x) => number(*x),
            Value::Integer(n) => n.to_string(),
            Value::Bool(b) => b.to_string(),
            Value::Text(s) => s.clone(),
            Value::Empty => String::new(),
        }
    }
}

/// What the columns of a branch need besides its points.
#[derive(Debug, Clone, Copy)]
pub struct BranchContext<'a> {
    /// `ω0`, the starting mode's linear frequency (rad/s): `frequency_ratio` is `ω / ω0`.
    pub linear_frequency_rad_s: f64,
    /// The dofs of a column with one field per output dof ([`Fields::PerOutputDof`]).
    pub output_dofs: &'a [usize],
}

/// How many fields a column has, and how each is computed.
#[derive(Clone, Copy)]
pub enum Fields {
    /// One field, from the point and its branch.
    One(fn(&BranchPoint, &BranchContext<'_>) -> Value),
    /// One field per output dof, in the order of `output_dofs`, named by the column's name
    /// with `<d>` replaced by the dof; the function is given the dof's position in
    /// `output_dofs`.
    PerOutputDof(fn(&BranchPoint, usize) -> Value),
}

/// One column of a table of points — a branch's ([`PointColumn`]) or a response's
/// (`super::response::ResponseColumn`) — whose fields `F` says how to compute.
#[derive(Clone, Copy)]
pub struct Column<F> {
    /// The CSV header (`peak_x<d>` for one field per output dof: `peak_x3`, ...).
    pub name: &'static str,
    /// The unit, as docs/output.md gives it (`—` for a pure number or a word).
    pub unit: &'static str,
    /// What the value is, in a line.
    pub doc: &'static str,
    /// The name of the column's array in the Python binding (`Branch`, `Response`; points ×
    /// output dofs for a column with a field per output dof).
    pub key: &'static str,
    pub kind: Kind,
    /// Whether the CSV file has the column; one it leaves out is in the Python binding's
    /// arrays (and, as a field of the point, in the JSON's record).
    pub csv: bool,
    pub fields: F,
}

/// Whether a column's fields are one per output dof (else one).
pub trait ColumnFields {
    fn per_output_dof(&self) -> bool;
}

impl<F: ColumnFields> Column<F> {
    /// Whether the column has one field per output dof.
    pub fn per_output_dof(&self) -> bool {
        self.fields.per_output_dof()
    }

    /// The column's header fields for these output dofs: its name, or one per output dof
    /// with `<d>` replaced by the dof.
    pub fn header_names(&self, output_dofs: &[usize]) -> Vec<String> {
        if self.per_output_dof() {
            output_dofs
                .iter()
                .map(|d| self.name.replace("<d>", &d.to_string()))
                .collect()
        } else {
            vec![self.name.to_string()]
        }
    }
}

impl ColumnFields for Fields {
    fn per_output_dof(&self) -> bool {
        matches!(self, Fields::PerOutputDof(_))
    }
}

/// One column of a branch's points.
pub type PointColumn = Column<Fields>;

impl PointColumn {
    /// The column's header fields for a branch with these output dofs.
    pub fn headers(&self, context: &BranchContext<'_>) -> Vec<String> {
        self.header_names(context.output_dofs)
    }

    /// The column's fields at point `p`, one per header.
    pub fn values(&self, p: &BranchPoint, context: &BranchContext<'_>) -> Vec<Value> {
        match self.fields {
            Fields::One(value) => vec![value(p, context)],
            Fields::PerOutputDof(value) => (0..context.output_dofs.len())
                .map(|k| value(p, k))
                .collect(),
        }
    }
}

fn float(x: f64) -> Value {
    Value::Float(x)
}

fn text(s: Option<impl Into<String>>) -> Value {
    s.map_or(Value::Empty, |s| Value::Text(s.into()))
}

/// The columns of a branch's points; `<name>.csv` has those marked [`PointColumn::csv`], in
/// this order.
pub const POINT_COLUMNS: &[PointColumn] = &[
    PointColumn {
        name: "index",
        unit: "—",
        doc: "position on the branch (0 first); a point placed on a requested value carries the index of the step before it",
        key: "index",
        kind: Kind::Integer,
        csv: true,
        fields: Fields::One(|p, _| Value::Integer(p.index)),
    },
    PointColumn {
        name: "energy",
        unit: "energy",
        doc: "total energy of the motion, kinetic plus potential",
        key: "energy",
        kind: Kind::Float,
        csv: true,
        fields: Fields::One(|p, _| float(p.energy)),
    },
    PointColumn {
        name: "frequency_rad_s",
        unit: "rad/s",
        doc: "ω = 2π / T",
        key: "frequency",
        kind: Kind::Float,
        csv: true,
        fields: Fields::One(|p, _| float(p.frequency)),
    },
    PointColumn {
        name: "period_s",
        unit: "s",
        doc: "period T",
        key: "period",
        kind: Kind::Float,
        csv: true,
        fields: Fields::One(|p, _| float(p.period)),
    },
    PointColumn {
        name: "stable",
        unit: "—",
        doc: "Floquet verdict: no multiplier off the unit circle beyond the stability tolerance",
        key: "stable",
        kind: Kind::Bool,
        csv: true,
        fields: Fields::One(|p, _| Value::Bool(p.floquet.stable)),
    },
    PointColumn {
        name: "max_floquet_modulus",
        unit: "—",
        doc: "largest modulus of the non-trivial Floquet multipliers",
        key: "max_floquet_modulus",
        kind: Kind::Float,
        csv: true,
        fields: Fields::One(|p, _| float(p.floquet.max_modulus)),
    },
    PointColumn {
        name: "relative_residual",
        unit: "—",
        doc: "‖W H‖/‖W z0‖ at convergence, of the problem solved (docs/method.md eq. (19))",
        key: "relative_residual",
        kind: Kind::Float,
        csv: true,
        fields: Fields::One(|p, _| float(p.relative_residual)),
    },
    PointColumn {
        name: "iterations",
        unit: "—",
        doc: "Newton iterations of the accepted corrector",
        key: "iterations",
        kind: Kind::Integer,
        csv: true,
        fields: Fields::One(|p, _| Value::Integer(p.iterations)),
    },
    PointColumn {
        name: "step",
        unit: "—",
        doc: "arclength step that led to the point (0 for the first)",
        key: "step",
        kind: Kind::Float,
        csv: true,
        fields: Fields::One(|p, _| float(p.step)),
    },
    PointColumn {
        name: "full_period_residual",
        unit: "—",
        doc: "‖W(z(T) − z0)‖/‖W z0‖ over the whole period",
        key: "full_period_residual",
        kind: Kind::Float,
        csv: true,
        fields: Fields::One(|p, _| float(p.full_period_residual)),
    },
    PointColumn {
        name: "unstable_pairs",
        unit: "—",
        doc: "multiplier pairs (μ, 1/μ) off the unit circle",
        key: "unstable_pairs",
        kind: Kind::Integer,
        csv: true,
        fields: Fields::One(|p, _| Value::Integer(p.floquet.unstable_pairs)),
    },
    PointColumn {
        name: "label",
        unit: "—",
        doc: "why the point is where it is: at_energy, at_frequency, energy_max, frequency_shift_max; empty for a continuation step",
        key: "label",
        kind: Kind::Text,
        csv: true,
        fields: Fields::One(|p, _| text(p.label.map(|l| l.name()))),
    },
    PointColumn {
        name: "frequency_hz",
        unit: "Hz",
        doc: "ω / 2π",
        key: "frequency_hz",
        kind: Kind::Float,
        csv: true,
        fields: Fields::One(|p, _| float(p.frequency / std::f64::consts::TAU)),
    },
    PointColumn {
        name: "frequency_ratio",
        unit: "—",
        doc: "ω / ω0, with ω0 the starting mode's linear frequency",
        key: "frequency_ratio",
        kind: Kind::Float,
        csv: true,
        fields: Fields::One(|p, b| float(p.frequency / b.linear_frequency_rad_s)),
    },
    PointColumn {
        name: "regime",
        unit: "—",
        doc: "backbone, tongue or other-family (docs/method.md eq. (86))",
        key: "regime",
        kind: Kind::Text,
        csv: true,
        fields: Fields::One(|p, _| text(p.regime.map(|r| r.kind.name()))),
    },
    PointColumn {
        name: "partner_mode",
        unit: "—",
        doc: "index of the resonant partner mode (the largest), empty if none",
        key: "partner_mode",
        kind: Kind::OptionalInteger,
        csv: true,
        fields: Fields::One(|p, _| partner(p).map_or(Value::Empty, |c| Value::Integer(c.mode))),
    },
    PointColumn {
        name: "partner_harmonic",
        unit: "—",
        doc: "harmonic k of ω at which the partner moves",
        key: "partner_harmonic",
        kind: Kind::OptionalInteger,
        csv: true,
        fields: Fields::One(|p, _| partner(p).map_or(Value::Empty, |c| Value::Integer(c.harmonic))),
    },
    PointColumn {
        name: "partner_share",
        unit: "—",
        doc: "share of the motion's energy the partner holds at that harmonic (0 to 1)",
        key: "partner_share",
        kind: Kind::Float,
        csv: true,
        fields: Fields::One(|p, _| partner(p).map_or(Value::Empty, |c| float(c.share))),
    },
    PointColumn {
        name: "ratio",
        unit: "—",
        doc: "m:n, the partner's harmonic to the home's",
        key: "ratio",
        kind: Kind::Text,
        csv: true,
        fields: Fields::One(|p, _| {
            text(
                p.regime
                    .and_then(|r| r.ratio)
                    .map(|(m, n)| format!("{m}:{n}")),
            )
        }),
    },
    PointColumn {
        name: "peak_x<d>",
        unit: "length (or angle)",
        doc: "max_t |x_d(t)| over the period, for each output dof d",
        key: "peak_displacement",
        kind: Kind::Float,
        csv: true,
        // A point without a measured motion (none today) leaves the peaks empty.
        fields: Fields::PerOutputDof(|p, k| {
            p.peak_displacements
                .get(k)
                .map_or(Value::Empty, |a| float(*a))
        }),
    },
    PointColumn {
        name: "resonance_force",
        unit: "force",
        doc: "the force amplitude whose resonance peak this motion is, by energy balance with the model's damping (`resonance_force` setting; docs/method.md eq. (111)); empty if not asked, inf if the force does no work on the motion",
        key: "resonance_force",
        kind: Kind::Float,
        csv: true,
        fields: Fields::One(|p, _| p.resonance.map_or(Value::Empty, |r| float(r.amplitude))),
    },
    PointColumn {
        name: "resonance_phase",
        unit: "rad",
        doc: "that force's phase φ: a (F_c cos(ωt + φ) + F_s sin(ωt + φ)), t from the point's z0",
        key: "resonance_phase",
        kind: Kind::Float,
        csv: true,
        fields: Fields::One(|p, _| p.resonance.map_or(Value::Empty, |r| float(r.phase))),
    },
    PointColumn {
        name: "energy_slope",
        unit: "energy / arclength",
        doc: "dE/ds along the branch (changes sign at a fold)",
        key: "energy_slope",
        kind: Kind::Float,
        csv: false,
        fields: Fields::One(|p, _| float(p.energy_slope)),
    },
    PointColumn {
        name: "reciprocity_defect",
        unit: "—",
        doc: "largest |μ ν − 1| over the pairs (μ, ν) of non-trivial multipliers: their accuracy",
        key: "reciprocity_defect",
        kind: Kind::Float,
        csv: false,
        fields: Fields::One(|p, _| float(p.floquet.reciprocity_defect)),
    },
];

/// The resonant partner of a point's regime, if any.
fn partner(p: &BranchPoint) -> Option<nnm::analysis::ModalComponent> {
    p.regime.and_then(|r| r.partner)
}

/// The columns `<name>.csv` has, in order.
pub fn csv_columns() -> impl Iterator<Item = &'static PointColumn> {
    POINT_COLUMNS.iter().filter(|c| c.csv)
}

/// The header of `<name>.csv` for a branch.
pub fn csv_header(context: &BranchContext<'_>) -> Vec<String> {
    csv_columns().flat_map(|c| c.headers(context)).collect()
}

/// The row of `<name>.csv` for point `p`.
pub fn csv_record(p: &BranchPoint, context: &BranchContext<'_>) -> Vec<String> {
    csv_columns()
        .flat_map(|c| c.values(p, context))
        .map(|v| v.csv_field())
        .collect()
}

#[cfg(test)]
mod tests {
    use nnm::analysis::{ModalComponent, Regime, RegimeKind};
    use nnm::floquet::Floquet;
    use nnm::shooting::PointLabel;

    use super::*;

    fn point() -> BranchPoint {
        BranchPoint {
            index: 4,
            energy: 2.5,
            energy_slope: 1.0,
            period: 0.5,
            frequency: 4.0 * std::f64::consts::PI,
            z0: vec![0.1, 0.0],
            floquet: Floquet::empty(),
            relative_residual: 3e-11,
            full_period_residual: 1e-10,
            iterations: 2,
            step: 0.25,
            unknowns: Vec::new(),
            tangent: Vec::new(),
            label: Some(PointLabel::AtEnergy),
            peak_displacements: vec![0.125],
            content: Vec::new(),
            regime: Some(Regime {
                kind: RegimeKind::Tongue,
                partner: Some(ModalComponent {
                    mode: 3,
                    harmonic: 3,
                    linear_frequency: 12.0,
                    share: 0.25,
                }),
                ratio: Some((3, 1)),
            }),
            resonance: None,
        }
    }

    #[test]
    fn the_csv_header_is_the_declared_columns_then_a_peak_per_output_dof() {
        let context = BranchContext {
            linear_frequency_rad_s: 1.0,
            output_dofs: &[3, 7],
        };
        assert_eq!(
            csv_header(&context).join(","),
            "index,energy,frequency_rad_s,period_s,stable,max_floquet_modulus,relative_residual,iterations,step,full_period_residual,unstable_pairs,label,frequency_hz,frequency_ratio,regime,partner_mode,partner_harmonic,partner_share,ratio,peak_x3,peak_x7,resonance_force,resonance_phase"
        );
    }

    #[test]
    fn a_row_has_a_field_per_header_and_leaves_what_a_point_lacks_empty() {
        let context = BranchContext {
            linear_frequency_rad_s: std::f64::consts::PI,
            output_dofs: &[0, 1],
        };
        let p = point();
        let row = csv_record(&p, &context);
        assert_eq!(row.len(), csv_header(&context).len());
        assert_eq!(
            row.join(","),
            "4,2.5,12.566370614359172,0.5,false,NaN,3e-11,2,0.25,1e-10,0,at_energy,2,4,tongue,3,3,0.25,3:1,0.125,,,"
        );
        let bare = BranchPoint {
            label: None,
            regime: None,
            ..p
        };
        let row = csv_record(&bare, &context);
        assert!(row[11].is_empty() && row[14..19].iter().all(String::is_empty));
    }

    /// A reader that keeps one typed array per column (the Python binding) can rely on
    /// [`PointColumn::kind`]: every field is of that kind, and only a column whose kind has an
    /// empty value is ever empty.
    #[test]
    fn every_field_is_of_its_columns_kind() {
        let context = BranchContext {
            linear_frequency_rad_s: 1.0,
            output_dofs: &[0, 1],
        };
        let p = point();
        let bare = BranchPoint {
            label: None,
            regime: None,
            ..p.clone()
        };
        for point in [&p, &bare] {
            for c in POINT_COLUMNS {
                for v in c.values(point, &context) {
                    let fits = match (c.kind, &v) {
                        (Kind::Float, Value::Float(_) | Value::Empty) => true,
                        (Kind::Integer, Value::Integer(_)) => true,
                        (Kind::OptionalInteger, Value::Integer(_) | Value::Empty) => true,
                        (Kind::Bool, Value::Bool(_)) => true,
                        (Kind::Text, Value::Text(_) | Value::Empty) => true,
                        _ => false,
                    };
                    assert!(fits, "column {} is {:?} but has {v:?}", c.name, c.kind);
                }
            }
        }
    }

    /// docs/output.md's table of `<branch>.csv` has a row for every CSV column, with the
    /// unit declared here.
    #[test]
    fn docs_output_md_lists_every_csv_column_with_its_unit() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/output.md");
        let docs = std::fs::read_to_string(path).expect("docs/output.md");
        for c in csv_columns() {
            let row = format!("| `{}` | {} |", c.name, c.unit);
            assert!(docs.contains(&row), "docs/output.md has no row `{row}`");
        }
    }
}
