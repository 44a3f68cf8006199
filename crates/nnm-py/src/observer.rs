//! The observer bridge: the library's continuation reports its points and evaluations to an
//! `Observer`; this one hands them to Python (the callback, Ctrl-C).

use std::ops::ControlFlow;

use nnm::bifurcation::Event;
use nnm::shooting::EvaluationProgress;
use nnm::{BranchPoint, Observer};
use pyo3::prelude::*;
use pyo3::types::PyBool;

/// Hands every point to the Python callback and checks for Ctrl-C between points and between
/// the evaluations within one (a large model's point can take seconds). A Python error (the
/// `KeyboardInterrupt` of a Ctrl-C, or the callback's own) is kept and stops the branch at the
/// next point; the caller raises it.
///
/// Python runs signal handlers on its main thread only, so a branch computed on another thread
/// (a thread pool, a Dask worker) never takes the GIL to check for them: each acquisition
/// would wait for the thread holding it (up to the 5 ms switch interval), once per evaluation.
pub struct PyObserver<'a> {
    callback: Option<&'a Py<PyAny>>,
    /// Whether the branch runs on Python's main thread (where Ctrl-C can be checked).
    main_thread: bool,
    /// The Python error that stopped the branch, for the caller to raise.
    pub error: Option<PyErr>,
    /// The callback returned `False`.
    pub stopped: bool,
}

impl<'a> PyObserver<'a> {
    /// An observer for a branch about to be computed from the calling thread.
    pub fn new(py: Python<'_>, callback: Option<&'a Py<PyAny>>) -> PyResult<Self> {
        let threading = py.import("threading")?;
        let main_thread = threading
            .call_method0("current_thread")?
            .is(&threading.call_method0("main_thread")?);
        Ok(Self {
            callback,
            main_thread,
            error: None,
            stopped: false,
        })
    }
}

impl Observer for &mut PyObserver<'_> {
    fn point(&mut self, p: &BranchPoint) -> ControlFlow<()> {
        if self.error.is_some() {
            return ControlFlow::Break(());
        }
        if self.callback.is_none() && !self.main_thread {
            return ControlFlow::Continue(());
        }
        Python::attach(|py| {
            if let Err(e) = py.check_signals() {
                self.error = Some(e);
                return ControlFlow::Break(());
            }
            let Some(callback) = self.callback else {
                return ControlFlow::Continue(());
            };
            match callback.call1(py, (p.index, p.energy, p.frequency, p.floquet.stable)) {
                Err(e) => {
                    self.error = Some(e);
                    ControlFlow::Break(())
                }
                Ok(answer)
                    if answer.bind(py).is_instance_of::<PyBool>()
                        && !answer.extract::<bool>(py).unwrap_or(true) =>
                {
                    self.stopped = true;
                    ControlFlow::Break(())
                }
                Ok(_) => ControlFlow::Continue(()),
            }
        })
    }

    fn event(&mut self, _event: &Event) -> ControlFlow<()> {
        if self.error.is_some() {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    }

    fn evaluation(&mut self, _progress: &EvaluationProgress) {
        if self.error.is_none() && self.main_thread {
            Python::attach(|py| {
                if let Err(e) = py.check_signals() {
                    self.error = Some(e);
                }
            });
        }
    }
}
