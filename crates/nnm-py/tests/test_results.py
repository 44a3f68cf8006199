"""What a Branch and Modes offer besides the columns: motions, DataFrames, figures."""

from __future__ import annotations

import csv
import subprocess

import numpy as np
import pytest

import nnm
from conftest import check_declared_columns


@pytest.fixture(scope="module")
def two_dof_branch() -> nnm.Branch:
    # The in-phase mode of the two-DOF system to E = 100 (examples/two-dof-bifurcation.toml):
    # past its branch point it is unstable.
    return nnm.backbone(nnm.two_dof(), 0, energy_max=100.0, progress=False)


def test_a_motion_is_periodic_and_keeps_its_energy(two_dof_branch) -> None:
    branch = two_dof_branch
    i = len(branch) // 2
    motion = branch.motion(i, samples=64)
    assert motion.t.shape == (65,) and motion.x.shape == (65, 2) == motion.v.shape
    assert motion.t[-1] == pytest.approx(branch.period[i], rel=1e-15)
    z0 = branch.state0[i]
    np.testing.assert_array_equal(np.r_[motion.x[0], motion.v[0]], z0)
    # Periodic: back at the start after one period (the branch is converged to 1e-8).
    scale = np.abs(z0).max()
    assert np.abs(np.r_[motion.x[-1], motion.v[-1]] - z0).max() < 1e-6 * scale
    # Conservative: E = v^2/2 + x' K x / 2 + c x1^4 / 4 at every sample.
    K, c = np.array([[2.0, -1.0], [-1.0, 2.0]]), 0.5
    energy = 0.5 * (motion.v**2).sum(1) + 0.5 * np.einsum("ti,ij,tj->t", motion.x, K, motion.x) + c * motion.x[:, 0] ** 4 / 4
    np.testing.assert_allclose(energy, branch.energy[i], rtol=1e-8)


def test_events_and_stability(two_dof_branch) -> None:
    branch = two_dof_branch
    assert not branch.stable.all() and branch.stable[0]
    assert branch.events, "the in-phase branch of the two-DOF system has a branch point"
    for e in branch.events:
        assert e.kind in ("fold", "branch-point", "period-doubling", "neimark-sacker")
        assert branch.energy[e.after_point] <= e.energy or e.kind == "fold"
        assert e.state0.shape == (4,)
        # An event's repr is one short line, without the state.
        assert "state0" not in repr(e) and e.kind in repr(e)
    # Unstable points have a multiplier off the unit circle, stable ones none.
    off_circle = (np.abs(branch.multipliers) > 1 + 1e-4).any(axis=1)
    assert np.array_equal(off_circle, ~branch.stable)


def test_to_pandas_has_the_columns_of_the_csv_file(two_dof_branch) -> None:
    pandas = pytest.importorskip("pandas")
    frame = two_dof_branch.to_pandas()
    assert isinstance(frame, pandas.DataFrame) and len(frame) == len(two_dof_branch)
    assert list(frame.columns) == [
        "index", "energy", "frequency_rad_s", "period_s", "stable", "max_floquet_modulus",
        "relative_residual", "iterations", "step", "full_period_residual", "unstable_pairs", "label",
        "frequency_hz", "frequency_ratio", "regime", "partner_mode", "partner_harmonic", "partner_share",
        "ratio", "peak_x0", "resonance_force", "resonance_phase",
    ]
    # The output dof defaults to the starting mode's largest entry: x1 of the in-phase mode (the
    # first of two equal ones). A synchronous motion's turning point is its start, so the peak
    # over the period is |x0| there.
    assert two_dof_branch.output_dofs == [0]
    np.testing.assert_allclose(frame["peak_x0"], np.abs(two_dof_branch.displacement0[:, 0]), rtol=1e-9)
    assert set(frame["regime"]) == {"backbone"}
    np.testing.assert_array_equal(frame["energy"], two_dof_branch.energy)
    b = two_dof_branch
    np.testing.assert_allclose(frame["frequency_hz"] * 2 * np.pi, b.frequency, rtol=1e-15)
    np.testing.assert_allclose(frame["frequency_ratio"] * b.linear_frequency, b.frequency, rtol=1e-15)
    assert abs(frame["frequency_ratio"][0] - 1) < 1e-3  # the first point is near the linear limit


def test_a_branchs_point_columns_are_the_declared_ones(two_dof_branch) -> None:
    """The Branch's per-point arrays and `to_pandas()` come from the library's one list of point
    columns (crates/nnm-io/src/output/columns.rs), not from a list of their own."""
    from nnm import _branch, _nnm

    csv = check_declared_columns(two_dof_branch, _nnm.POINT_COLUMNS, _branch._POINT_COLUMNS, _branch)
    declared = [c[0] for c in _nnm.POINT_COLUMNS]
    assert {"energy_slope", "reciprocity_defect"} <= set(declared) - {c.key for c in csv}


def test_to_pandas_is_the_csv_file_of_nnm_run(cli, write_job, tmp_path) -> None:
    """Same header, and the same values to the last digit (the CSV writes floats exactly)."""
    pytest.importorskip("pandas")
    job = write_job('[model]\nfamily = "two-dof"\n[settings]\nenergy_max = 1.0\n'
                    '[[branch]]\nname = "b"\nmode = 0\n')
    subprocess.run([str(cli), "run", str(job), "--out", str(tmp_path / "out"), "--quiet"], check=True)
    with (tmp_path / "out" / "b.csv").open(newline="") as f:
        header, *rows = list(csv.reader(f))
    frame = nnm.backbone(nnm.two_dof(), 0, energy_max=1.0, progress=False).to_pandas()
    assert header == list(frame.columns) and len(rows) == len(frame)
    for j, name in enumerate(header):
        fields = [row[j] for row in rows]
        values = frame[name].to_numpy()
        if values.dtype.kind in "fi":
            np.testing.assert_array_equal([float(v) if v else np.nan for v in fields], values.astype(float))
        else:
            assert fields == [str(v).lower() if values.dtype.kind == "b" else v for v in values], name


def test_the_frequency_energy_plot_dashes_unstable_parts(two_dof_branch) -> None:
    pytest.importorskip("matplotlib")
    import matplotlib.pyplot as plt

    from nnm import plot

    ax = two_dof_branch.plot()
    styles = {line.get_linestyle() for line in ax.get_lines()}
    assert {"-", "--"} <= styles
    assert ax.get_xscale() == "log"
    assert len(ax.texts) == len(two_dof_branch.events)
    plot.mode_shape(nnm.modes(nnm.two_dof()).shapes[:, 0])
    plot.time_series(two_dof_branch.motion(0, samples=16))
    # The amplitude backbone draws the peaks against the frequency, point for point.
    ax = plot.amplitude([two_dof_branch])
    xs = np.concatenate([line.get_xdata() for line in ax.get_lines()])
    ys = np.concatenate([line.get_ydata() for line in ax.get_lines()])
    assert set(xs) == set(two_dof_branch.frequency)
    assert set(ys) == set(two_dof_branch.peak_displacement[:, 0])
    plt.close("all")


def test_modes_labels_and_lookup() -> None:
    modes = nnm.modes(nnm.bladed_disk())
    k = modes.index((1, 5), "sin")
    assert modes.labels[k] == (1, 5) and modes.patterns[k] == "sin"
    shapes = modes.shapes
    mass = nnm.bladed_disk().M
    np.testing.assert_allclose(shapes.T @ mass @ shapes, np.eye(60), atol=1e-10)
    branch = nnm.backbone(nnm.bladed_disk(), "1,5", pattern="sin", max_points=2, progress=False)
    assert branch.mode == k and branch.mode_label == (1, 5) and branch.pattern == "sin"
    assert nnm.bladed_disk().cyclic == (30, 2) and nnm.duffing().cyclic is None


def test_the_package_docstring_example_runs() -> None:
    import doctest

    failures, tried = doctest.testmod(nnm)
    assert tried > 0 and failures == 0


def test_branches_and_failures_pickle_for_other_processes(two_dof_branch) -> None:
    """Process pools and Dask send results and exceptions between processes: the arrays and
    events travel, the model (held by the library) does not."""
    import pickle

    copy = pickle.loads(pickle.dumps(two_dof_branch))
    for name in ("energy", "frequency", "state0", "multipliers", "stable"):
        assert np.array_equal(getattr(copy, name), getattr(two_dof_branch, name))
    assert [e.energy for e in copy.events] == [e.energy for e in two_dof_branch.events]
    np.testing.assert_array_equal(copy.displacement0, two_dof_branch.displacement0)
    with pytest.raises(ValueError, match="without its model"):
        copy.motion(0)
    with pytest.raises(ValueError, match="without its model"):
        copy.switch(0, energy_max=100.0)
    with pytest.raises(nnm.ContinuationError) as raised:
        nnm.backbone(nnm.duffing(), 0, energy_max=100.0, max_iterations=1, min_step=0.05, tolerance=1e-10)
    error = pickle.loads(pickle.dumps(raised.value))
    assert type(error) is nnm.ContinuationError and str(error) == str(raised.value)
    assert np.array_equal(error.branch.energy, raised.value.branch.energy)


def test_regimes_of_the_fixed_free_chain_are_marked_on_the_plot() -> None:
    """The chain of crates/nnm/tests/regimes.rs: its first backbone enters a 3:1 tongue with
    mode 1, then turns into mode 3's family at 7:1; `plot.fep` rings both entries."""
    pytest.importorskip("matplotlib")
    import matplotlib.pyplot as plt

    from nnm import plot

    k = 2 * np.eye(5) - np.eye(5, k=1) - np.eye(5, k=-1)
    k[4, 4] = 1.0
    chain = nnm.Model(np.eye(5), k, nonlinear=[nnm.Cubic(dofs=[0], coefficient=0.5)])
    branch = nnm.backbone(chain, 0, max_points=60, energy_max=1e4)
    kinds = list(branch.regime)
    tongue, other = kinds.index("tongue"), kinds.index("other-family")
    assert kinds[0] == "backbone" and tongue < other
    assert (branch.partner_mode[tongue], branch.ratio[tongue]) == (1, "3:1")
    assert (branch.partner_mode[other], branch.ratio[other]) == (3, "7:1")
    assert 0.1 <= branch.partner_share[tongue] < 0.5
    ax = plot.fep([branch])
    texts = [t.get_text() for t in ax.texts]
    assert "3:1" in texts and "→7:1" in texts
    plt.close("all")
