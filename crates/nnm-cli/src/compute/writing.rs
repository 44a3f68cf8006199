//! The observer of a branch's continuation: each point and event written to the branch's files
//! as it is found, a progress line each, Ctrl-C and the caller's own stop heard between them.
//! Each write is whole even when a second signal quits at once ([`interrupt::writing`]).

use std::ops::ControlFlow;
use std::sync::Mutex;
use std::time::Instant;

use nnm::bifurcation::Event;
use nnm::shooting::EvaluationProgress;
use nnm::{BranchPoint, Observer};
use nnm_io::output::{BranchInfo, BranchWriter, OutputError};

use crate::interrupt;

/// Writes points and events as the continuation finds them, with a progress line each.
pub(super) struct Writing<'a, F> {
    pub(super) writer: &'a mut BranchWriter,
    pub(super) error: Option<OutputError>,
    /// When the last point (or the branch) was done, and how many points there are: a point
    /// that takes longer than [`SLOW_POINT`] shows its evaluations.
    pub(super) since_point: Instant,
    pub(super) points: usize,
    pub(super) info: &'a BranchInfo,
    pub(super) quiet: bool,
    pub(super) log: &'a Mutex<()>,
    pub(super) extra: F,
    /// The stop reason `extra` gave when it stopped the branch.
    pub(super) stopped_by_extra: Option<&'static str>,
}

impl<F> Writing<'_, F> {
    /// Keeps a write error (the continuation then stops) or prints the progress line.
    fn after_write(
        &mut self,
        written: Result<(), OutputError>,
        line: impl FnOnce() -> String,
    ) -> ControlFlow<()> {
        if let Err(e) = written {
            self.error = Some(e);
            return ControlFlow::Break(());
        }
        if !self.quiet {
            let _guard = self.log.lock();
            crate::progress::line(format_args!("[{}] {}", self.info.name, line()));
        }
        if interrupt::requested() {
            return ControlFlow::Break(());
        }
        ControlFlow::Continue(())
    }
}

/// A point taking longer than this shows its progress (each evaluation of the shooting
/// equations: Newton iterations, and trial points while an event is located).
const SLOW_POINT: std::time::Duration = std::time::Duration::from_secs(1);

impl<F: FnMut(&BranchPoint) -> ControlFlow<&'static str>> Observer for &mut Writing<'_, F> {
    fn evaluation(&mut self, e: &EvaluationProgress) {
        let elapsed = self.since_point.elapsed();
        if !self.quiet && elapsed > SLOW_POINT {
            let _guard = self.log.lock();
            crate::progress::line(format_args!(
                "[{}] point {:>3} in progress: evaluation {}, relative residual {:.2e}, T = {:.6e} s ({:.1} s)",
                self.info.name,
                self.points,
                e.evaluations,
                e.relative_residual,
                e.period,
                elapsed.as_secs_f64()
            ));
        }
    }

    fn point(&mut self, p: &BranchPoint) -> ControlFlow<()> {
        self.since_point = Instant::now();
        self.points += 1;
        let written = interrupt::writing(|| self.writer.write_point(p));
        let linear = self.info.linear_frequency_rad_s;
        self.after_write(written, || {
            format!(
                "point {:>3}  E = {:<11.4e} f = {:.6} rad/s ({:+.3}%)  {}  |mu|max = {:.6}{}",
                p.index,
                p.energy,
                p.frequency,
                100.0 * (p.frequency / linear - 1.0),
                if p.floquet.stable {
                    "stable  "
                } else {
                    "unstable"
                },
                p.floquet.max_modulus,
                p.label
                    .map_or(String::new(), |l| format!("  ({})", l.name()))
            )
        })?;
        match (self.extra)(p) {
            ControlFlow::Break(reason) => {
                self.stopped_by_extra = Some(reason);
                ControlFlow::Break(())
            }
            ControlFlow::Continue(()) => ControlFlow::Continue(()),
        }
    }

    fn event(&mut self, e: &Event) -> ControlFlow<()> {
        let written = interrupt::writing(|| self.writer.write_event(e));
        self.after_write(written, || {
            format!(
                "event: {} at E = {:.10e}, f = {:.9} rad/s, multiplier ({:.6}, {:.6}){}",
                e.kind.name(),
                e.point.energy,
                e.point.frequency,
                e.multiplier.0,
                e.multiplier.1,
                if e.converged {
                    ""
                } else {
                    " (location not converged)"
                }
            )
        })
    }
}
