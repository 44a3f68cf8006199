"""Forced, damped responses from Python (nnm.frequency_response, nnm.force_response): each
checked against something the shooting does not compute — the complex solve
``(K − Ω²M + iΩC)⁻¹F`` done here with numpy for linear models (with Rayleigh and modal damping
built here from M, K and scipy's eigenvectors), harmonic-balance fold frequencies of the
Duffing oscillator computed independently — and every bad input refused with the library's
one-line message before anything is computed."""

from __future__ import annotations

import csv
import subprocess

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse as sp

import nnm
from conftest import LINEAR_DISK, ROOT, check_declared_columns, cli_error
from nnm import sweeps

# A three-dof chain, fixed at one end, with a non-proportional damper between dofs 1 and 2.
M3 = np.diag([1.0, 2.0, 1.5])
K3 = np.array([[3.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])
C3 = np.array([[0.05, 0.0, 0.0], [0.0, 0.08, -0.06], [0.0, -0.06, 0.06]])
F3 = np.array([0.0, 1.0, 0.0])  # Force(dofs=[1], amplitude=1)


def complex_response(M, K, C, F, omega):
    """``X`` of ``x(t) = Re(X e^{iΩt})``, the steady response to ``F cos Ωt``."""
    return np.linalg.solve(K - omega**2 * M + 1j * omega * C, F)


def check_linear(response, M, K, C, F, rtol):
    """Every point's state at t = 0, peaks, first-harmonic amplitude and phase lag against
    the complex solve at its frequency and force amplitude."""
    assert len(response) > 5
    scale = 0.0
    for k in range(len(response)):
        omega, a = response.frequency[k], response.force_amplitude[k]
        X = complex_response(M, K, C, a * F, omega)
        scale = max(scale, np.abs(X).max())
        n = len(F)
        x0, v0 = response.state0[k, :n], response.state0[k, n:]
        np.testing.assert_allclose(x0, X.real, rtol=0, atol=rtol * np.abs(X).max())
        np.testing.assert_allclose(v0, -omega * X.imag, rtol=0, atol=rtol * omega * np.abs(X).max())
        np.testing.assert_allclose(response.peaks[k], np.abs(X[response.output_dofs]), rtol=rtol)
        d = response.phase_dof
        np.testing.assert_allclose(response.harmonic_amplitude[k], abs(X[d]), rtol=rtol)
        lag = (-np.angle(X[d]) + np.pi / 2) % (2 * np.pi) - np.pi / 2  # in (−π/2, 3π/2]
        assert abs(np.angle(np.exp(1j * (response.phase_lag[k] - lag)))) < rtol * 10
    # Linear: every point stable, no fold or bifurcation; the phase resonances (the phase dof
    # in quadrature with the force, eq. (113)) where the complex solve puts the lag at π/2,
    # one for each time the points' lag crosses it.
    assert response.stable.all()
    assert all(e.kind == "phase-resonance" for e in response.events)
    # (a lag that wraps from −π/2 to 3π/2 past an antiresonance crosses nothing).
    g = response.phase_lag - np.pi / 2
    crossings = np.sum((g[:-1] * g[1:] < 0) & (np.abs(np.diff(g)) < np.pi))
    assert len(response.events) == crossings
    for e in response.events:
        X = complex_response(M, K, C, e.force_amplitude * F, e.frequency)
        d = response.phase_dof
        # The event's own lag is the complex solve's at its frequency, and π/2 to the
        # location's accuracy (a bracket of 4e-9 of the segment, where the phase turns fast).
        lag = -np.angle(X[d])
        assert abs(e.phase_lag - lag) < rtol * 10, e
        assert abs(e.phase_lag - np.pi / 2) < 1e-7, e


def test_linear_response_equals_the_complex_solve():
    model = nnm.Model(M3, K3, C=C3)
    r = nnm.frequency_response(
        model, nnm.Force(dofs=[1], amplitude=0.3), (0.2, 2.0), output_dofs=[0, 1, 2], tolerance=1e-12
    )
    assert r.stop_kind == "end"
    assert r.frequency[0] == 0.2 and abs(r.frequency[-1] / 2.0 - 1) < 1e-9
    np.testing.assert_array_equal(r.force_amplitude, 0.3)
    check_linear(r, M3, K3, C3, F3, 1e-9)
    # The points cross the resonances: the peak of the driven dof exceeds its static value.
    assert r.peaks[:, 1].max() > 2 * abs(complex_response(M3, K3, C3, 0.3 * F3, 1e-9)[1])


def test_rayleigh_and_modal_damping_are_the_documented_matrices():
    alpha, beta = 0.02, 0.01
    rayleigh = nnm.Model(sp.csr_array(M3), K3, damping={"rayleigh": [alpha, beta]})
    r = nnm.frequency_response(rayleigh, {"dofs": [1], "amplitude": 1.0}, (0.3, 1.8), tolerance=1e-12)
    check_linear(r, M3, K3, alpha * M3 + beta * K3, F3, 1e-9)

    # Modal: C = M Φ diag(2 ζ_k ω_k) Φᵀ M over the lowest modes given, Φ mass-normalised.
    zeta = [0.02, 0.05]
    w2, phi = scipy.linalg.eigh(K3, M3)
    weights = np.zeros(3)
    weights[:2] = 2 * np.array(zeta) * np.sqrt(w2[:2])
    C = M3 @ phi @ np.diag(weights) @ phi.T @ M3
    modal = nnm.Model(M3, K3, damping={"modal": zeta})
    r = nnm.frequency_response(modal, nnm.Force(vector=[0.5, 0.0, -0.2]), (0.3, 1.2), tolerance=1e-12)
    check_linear(r, M3, K3, C, np.array([0.5, 0.0, -0.2]), 1e-9)
    assert r.output_dofs == [0, 2]  # the forced dofs by default


def test_force_amplitude_continuation_is_proportional_for_a_linear_model():
    model = nnm.Model(M3, K3, C=C3)
    omega = 0.9
    r = nnm.force_response(model, nnm.Force(dofs=1, amplitude=0.1), frequency=omega, amplitude_max=2.0,
                           tolerance=1e-12)
    assert r.parameter == "amplitude" and r.stop_kind == "end"
    np.testing.assert_array_equal(r.frequency, omega)
    assert r.force_amplitude[0] == 0.1 and abs(r.force_amplitude[-1] / 2.0 - 1) < 1e-9
    check_linear(r, M3, K3, C3, F3, 1e-9)


def test_the_response_defaults_are_the_settings_a_curve_gets():
    """``nnm.RESPONSE_DEFAULTS`` holds a value for every setting, and they are the ones a curve
    runs with: given explicitly, the same curve to the last digit; a different ``max_step``
    gives another."""
    assert set(nnm.RESPONSE_DEFAULTS) == set(nnm.RESPONSE_SETTINGS_KEYS)
    model = nnm.duffing(natural_frequency=1.0, cubic=1.0, damping=[[0.05]])
    force = nnm.Force(dofs=[0], amplitude=0.1)
    plain = nnm.frequency_response(model, force, (0.5, 2.5), progress=False)
    given = nnm.frequency_response(model, force, (0.5, 2.5), progress=False, **nnm.RESPONSE_DEFAULTS)
    halved = nnm.frequency_response(model, force, (0.5, 2.5), progress=False,
                                    max_step=nnm.RESPONSE_DEFAULTS["max_step"] / 2)
    np.testing.assert_array_equal(plain.frequency, given.frequency)
    assert len(halved) != len(plain)


# Duffing x'' + 0.02 x' + x + x³ = 0.1 cos Ωt: fold frequencies from an independent
# harmonic balance with enough harmonics to be converged far below 1e-6.
DUFFING_FOLDS = (2.2115438, 1.1701620)


@pytest.fixture(scope="module")
def duffing_response():
    model = nnm.duffing(natural_frequency=1.0, cubic=1.0, damping=[[0.02]])
    return nnm.frequency_response(model, nnm.Force(dofs=[0], amplitude=0.1), (0.5, 3.5), tolerance=1e-10)


def test_duffing_folds_and_the_unstable_middle_branch(duffing_response):
    r = duffing_response
    assert r.stop_kind == "end"
    folds = r.folds
    assert [e.kind for e in r.events if e.kind != "phase-resonance"] == ["fold", "fold"]
    for event, reference in zip(folds, DUFFING_FOLDS):
        assert abs(event.frequency - reference) < 1e-6, (event.frequency, reference)
        # A fold's critical multiplier is real and at +1.
        assert abs(event.critical_multiplier - 1) < 1e-4
    # The curve runs forward to the upper fold, back to the lower one, then forward again:
    # the points between the folds (the middle branch) are the unstable ones, and only they.
    first, second = folds[0].after_point, folds[1].after_point
    middle = (r.index > first) & (r.index <= second)
    assert middle.sum() > 3
    assert not r.stable[middle].any()
    assert r.stable[~middle].all()
    assert (r.max_floquet_modulus[middle] > 1).all()
    # The frequency decreases along the middle branch.
    assert (np.diff(r.frequency[middle]) < 0).all()


def test_motion_closes_the_orbit_and_starts_at_the_state(duffing_response):
    r = duffing_response
    i = int(np.argmax(r.peaks[:, 0]))
    motion = r.motion(i, samples=200)
    assert motion.x.shape == (201, 1)
    np.testing.assert_allclose(motion.t[-1], 2 * np.pi / r.frequency[i])
    np.testing.assert_allclose(motion.x[0, 0], r.state0[i, 0])
    np.testing.assert_allclose(motion.x[-1], motion.x[0], atol=1e-8 * r.peaks[i, 0])
    # The peak recorded is the motion's largest |x| (sampled: at most a little below it).
    assert np.abs(motion.x).max() <= r.peaks[i, 0] * (1 + 1e-9)
    assert np.abs(motion.x).max() > r.peaks[i, 0] * (1 - 1e-3)
    with pytest.raises(ValueError, match="point 9999 does not exist"):
        r.motion(9999)


def test_linear_motion_is_the_harmonic():
    model = nnm.Model(M3, K3, C=C3)
    r = nnm.frequency_response(model, nnm.Force(dofs=[1], amplitude=0.3), (0.5, 0.8), tolerance=1e-12)
    motion = r.motion(-1, samples=50)
    X = complex_response(M3, K3, C3, 0.3 * F3, r.frequency[-1])
    expected = (X[None, :] * np.exp(1j * r.frequency[-1] * motion.t[:, None])).real
    np.testing.assert_allclose(motion.x, expected, atol=1e-9 * np.abs(X).max())


def test_levels_to_pandas_and_plot(duffing_response):
    model = nnm.duffing(damping={"rayleigh": [0.02, 0.0]})
    levels = nnm.frequency_response(model, nnm.Force(dofs=[0], amplitude=1.0), (0.5, 2.5),
                                    amplitudes=[0.002, 0.1])
    assert isinstance(levels, nnm.Responses) and len(levels) == 2
    assert [r.force.amplitude for r in levels] == [0.002, 0.1]
    for r, a in zip(levels, [0.002, 0.1]):
        np.testing.assert_array_equal(r.force_amplitude, a)
    # Below the bistability threshold (a ≈ 0.004 for ζ = 0.01) no fold; above it two.
    assert len(levels[0].folds) == 0 and len(levels[1].folds) == 2
    table = levels.to_pandas()
    # The columns of `<name>.csv` (which test_response_columns_are_the_declared_ones holds to
    # the library's list); `curve` tells the levels apart.
    assert list(table.columns[:6]) == ["curve", "index", "frequency_rad_s", "frequency_hz", "force_amplitude",
                                       "peak_x0"]
    assert len(table) == len(levels[0]) + len(levels[1])
    assert list(table["curve"]) == [0] * len(levels[0]) + [1] * len(levels[1])
    ax = levels.plot()
    styles = {line.get_linestyle() for line in ax.get_lines()}
    assert "--" in styles and "-" in styles  # the unstable middle branch is dashed
    markers = [line for line in ax.get_lines() if line.get_marker() == "o"]
    assert len(markers) == 2  # the two folds
    ax = duffing_response.plot()
    assert ax.get_xlabel().startswith("frequency")


def test_callback_stops_and_an_interrupt_keeps_the_points():
    model = nnm.duffing(damping=[[0.02]])
    seen = []

    def stop_at_five(index, frequency, amplitude, stable):
        seen.append((index, frequency, amplitude, stable))
        return index < 4

    r = nnm.frequency_response(model, nnm.Force(dofs=[0], amplitude=0.1), (0.5, 3.5), callback=stop_at_five)
    assert r.stop_kind == "callback" and len(r) == 5 == len(seen)

    def interrupt(index, frequency, amplitude, stable):
        if index == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt) as caught:
        nnm.frequency_response(model, nnm.Force(dofs=[0], amplitude=0.1), (0.5, 3.5), callback=interrupt)
    partial = caught.value.response
    assert len(partial) == 4 and partial.stop_kind == "interrupted"
    assert any("computed so far" in note for note in getattr(caught.value, "__notes__", []))


def grounded_disk(sectors=6):
    """The bladed disk's M and K with every disk grounded by a spring of 0.5 (the family's
    disk turns freely: a rigid-body mode, whose forced response is not unique), cyclic."""
    disk = nnm.bladed_disk(sectors=sectors)
    K = np.asarray(disk.K.todense() if hasattr(disk.K, "todense") else disk.K, dtype=float)
    M = np.asarray(disk.M.todense() if hasattr(disk.M, "todense") else disk.M, dtype=float)
    K[::2, ::2] += 0.5 * np.eye(sectors)
    return M, K


def test_engine_order_force_drives_a_travelling_wave():
    sectors, k = 6, 2
    M, K = grounded_disk(sectors)
    beta = 1e-2
    disk = nnm.Model(M, K, cyclic=(sectors, 2), damping={"rayleigh": [0.0, beta]})
    force = nnm.Force(engine_order=k, amplitude=0.5, sector_dof=1)
    r = nnm.frequency_response(disk, force, (0.6, 1.4), tolerance=1e-12)
    # Every blade is an output dof by default.
    assert r.output_dofs == [2 * s + 1 for s in range(sectors)]
    # Dof 1 of sector s driven by a cos(Ωt − 2πks/N): complex amplitude a e^{−2πiks/N}.
    F = np.zeros(2 * sectors, dtype=complex)
    F[1::2] = np.exp(-2j * np.pi * k * np.arange(sectors) / sectors)
    for i in range(len(r)):
        X = complex_response(M, K, beta * K, 0.5 * F, r.frequency[i])
        np.testing.assert_allclose(r.peaks[i], np.abs(X[1::2]), rtol=1e-9)
        np.testing.assert_allclose(r.state0[i, : 2 * sectors], X.real, atol=1e-9 * np.abs(X).max())
    # A travelling wave of a tuned disk: every blade's peak is the same.
    np.testing.assert_allclose(r.peaks, r.peaks[:, :1] * np.ones((1, sectors)), rtol=1e-9)


# Bad input: one line, ValueError, the library's words, before anything is computed.


@pytest.mark.parametrize(
    "damping, message",
    [
        ({"rayleigh": [-0.1, 0.0]}, "damping rayleigh α must be non-negative and finite, got -0.1"),
        ({"rayleigh": [0.0, float("nan")]}, "damping rayleigh β must be non-negative and finite"),
        ({"modal": [0.01, -0.02]}, "damping modal ratio 2 must be non-negative"),
        ({"modal": [0.01] * 4}, "4 modal damping ratios given, the model has 3 elastic modes"),
        ([[0.1, 0.0, 0.0], [0.0, -0.2, 0.0], [0.0, 0.0, 0.1]], r"not positive semi-definite \(eigenvalue -0.2"),
        ([[0.1, 0.05, 0.0], [0.0, 0.1, 0.0], [0.0, 0.0, 0.1]], "damping matrix is not symmetric"),
        (np.eye(2), "the damping matrix is 2x2, the model has 3 dofs"),
        ({"viscous": [1.0]}, "unknown variant `viscous`"),
    ],
)
def test_bad_damping(damping, message):
    with pytest.raises(ValueError, match=message):
        nnm.Model(M3, K3, damping=damping)


def test_a_bad_damping_has_the_job_files_message(cli, write_job):
    """Python's damping forms are the job file's, read and built by the same functions: the
    same refusal, word for word (the job's names the file and the key)."""
    rows = "[[3.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]]"
    model = f"[model]\nmass = [[1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 1.5]]\nstiffness = {rows}\n"
    for toml, damping in [
        ("{ rayleigh = [-0.1, 0.0] }", {"rayleigh": [-0.1, 0.0]}),
        ("{ modal = [0.01, 0.01, 0.01, 0.01] }", {"modal": [0.01] * 4}),
        ("{ matrix = [[0.1, 0.0], [0.0, 0.1]] }", {"matrix": np.eye(2) * 0.1}),
        ("{ matrix = [[0.1, 0.0, 0.0], [0.0, -0.2, 0.0], [0.0, 0.0, 0.1]] }",
         {"matrix": [[0.1, 0.0, 0.0], [0.0, -0.2, 0.0], [0.0, 0.0, 0.1]]}),
    ]:
        job = write_job(model + f"damping = {toml}\n")
        expected = cli_error(cli, "modes", job)
        with pytest.raises(ValueError) as caught:
            nnm.Model(M3, K3, damping=damping)
        assert expected == f"{job}: [model] damping: {caught.value}"


def test_a_job_files_damping_drives_its_response(tmp_path, write_job):
    """`Model.from_job` builds `[model] damping` (here a matrix file in the full numbering,
    reduced with `fixed_dofs`): the response of the job's model is the complex solve with
    that C."""
    C = scipy.linalg.block_diag([[1.0]], C3)
    lines = [f"{i + 1} {j + 1} {float(C[i, j])!r}" for i in range(4) for j in range(i + 1) if C[i, j] != 0]
    market = "%%MatrixMarket matrix coordinate real symmetric\n" + f"4 4 {len(lines)}\n" + "\n".join(lines) + "\n"
    mass = np.diag([1.0, *np.diag(M3)]).tolist()
    stiffness = scipy.linalg.block_diag([[5.0]], K3).tolist()
    job = write_job(f'[model]\nmass = {mass}\nstiffness = {stiffness}\nfixed_dofs = [0]\n'
                    'damping = { file = "C.mtx" }\n', **{"C.mtx": market})
    model = nnm.Model.from_job(job)
    assert model.damping == {"file": "C.mtx"} and "damped" in repr(model)
    # Forced dof 2 of the full numbering (before `fixed_dofs`, as the job file's): dof 1 of C3's.
    r = nnm.frequency_response(model, nnm.Force(dofs=[2], amplitude=1.0), (0.5, 0.7), tolerance=1e-12)
    check_linear(r, M3, K3, C3, F3, 1e-9)
    # The same file from Python (a path relative to the working directory, here absolute).
    same = nnm.Model(np.diag([1.0, *np.diag(M3)]), scipy.linalg.block_diag([[5.0]], K3), fixed_dofs=[0],
                     damping={"file": tmp_path / "C.mtx"})
    r = nnm.frequency_response(same, nnm.Force(dofs=[2], amplitude=1.0), (0.5, 0.7), tolerance=1e-12)
    check_linear(r, M3, K3, C3, F3, 1e-9)
    # Another damping replaces the job's; none leaves the model undamped.
    assert model.with_damping({"rayleigh": [0.0, 0.1]}).damping == {"rayleigh": [0.0, 0.1]}
    assert model.with_damping(None).damping is None


def test_response_columns_are_the_declared_ones(duffing_response):
    """The Response's per-point arrays and `to_pandas()` come from the library's one list of
    response columns (crates/nnm-io/src/output/response.rs), as a Branch's from its point
    columns."""
    from nnm import _nnm, _response

    r = duffing_response
    csv = check_declared_columns(r, _nnm.RESPONSE_COLUMNS, _response._RESPONSE_COLUMNS, _response)
    assert {"step"} == {c[0] for c in _nnm.RESPONSE_COLUMNS} - {c.key for c in csv}
    # Independent of the columns' own code: Hz is rad/s over 2π, a single curve is curve 0.
    np.testing.assert_allclose(r.frequency_hz * 2 * np.pi, r.frequency, rtol=1e-15)
    assert (r.curve == 0).all() and list(r.index) == list(range(len(r)))


def test_to_pandas_is_the_csv_file_of_nnm_run(cli, write_job, tmp_path):
    """A job's `[[response]]` and the same curves from Python on the job's model: the same
    header, and the same values to the last digit (the CSV writes floats exactly) — but for
    each curve's last row: `nnm run` writes every point as the continuation hands it over,
    and the library then moves a last point past the end of the sweep onto the end
    (`land_on_end`), which the returned curve (Python's) has and the CSV does not."""
    pytest.importorskip("pandas")
    job = write_job('[model]\nfamily = "duffing"\ndamping = { rayleigh = [0.02, 0.0] }\n'
                    '[[response]]\nname = "frc"\nforce = { dofs = [0], amplitude = 1.0 }\n'
                    'frequency_start = 0.5\nfrequency_end = 2.5\namplitudes = [0.002, 0.1]\n')
    subprocess.run([str(cli), "run", str(job), "--out", str(tmp_path / "out"), "--quiet"], check=True)
    with (tmp_path / "out" / "frc.csv").open(newline="") as f:
        header, *rows = list(csv.reader(f))
    frame = nnm.frequency_response(nnm.Model.from_job(job), nnm.Force(dofs=[0], amplitude=1.0), (0.5, 2.5),
                                   amplitudes=[0.002, 0.1], progress=False).to_pandas()
    assert header == list(frame.columns) and len(rows) == len(frame)
    curve = frame["curve"].to_numpy()
    last = np.append(curve[1:] != curve[:-1], True)
    assert last.sum() == 2
    for j, name in enumerate(header):
        fields = [row[j] for row in rows]
        values = frame[name].to_numpy()
        if values.dtype.kind in "fi":
            written = np.array([float(v) for v in fields])
            np.testing.assert_array_equal(written[~last], values[~last].astype(float), err_msg=name)
        else:
            assert fields == [str(v).lower() for v in values], name
    np.testing.assert_array_equal(frame["frequency_rad_s"][last], 2.5)
    written = np.array([float(row[header.index("frequency_rad_s")]) for row in rows])
    np.testing.assert_allclose(written[last], 2.5, rtol=1e-6)


def test_damping_given_twice_or_on_a_family():
    with pytest.raises(TypeError, match="either"):
        nnm.Model(M3, K3, C=C3, damping={"rayleigh": [0.1, 0.0]})
    with pytest.raises(ValueError, match="non-negative"):
        nnm.duffing(damping={"rayleigh": [-1.0, 0.0]})
    # Fixed dofs: C in the full numbering is reduced as M and K are, as `C=` and as
    # `{"matrix": C}` alike (the job file's rule); the reduced size is refused.
    M4, K4 = np.diag([1.0, *np.diag(M3)]), scipy.linalg.block_diag([[5.0]], K3)
    C4 = scipy.linalg.block_diag([[1.0]], C3)
    for given in [{"C": C4}, {"C": sp.csr_array(C4)}, {"damping": {"matrix": C4}}]:
        model = nnm.Model(M4, K4, fixed_dofs=[0], **given)
        r = nnm.frequency_response(model, nnm.Force(dofs=[2], amplitude=1.0), (0.5, 0.7), tolerance=1e-12)
        check_linear(r, M3, K3, C3, F3, 1e-9)
    with pytest.raises(ValueError, match=r"the damping matrix is 3x3, the model has 4 dofs \(before `fixed_dofs`\)"):
        nnm.Model(M4, K4, fixed_dofs=[0], C=C3)


def chain_with_a_fixed_dof_inside():
    """The three-dof chain with a fourth dof inserted at index 1, fixed: coupled to dof 0 in
    K and C (couplings a support takes), so that only the reduction by `fixed_dofs` leaves
    M3, K3 and C3. Free dofs 0, 2, 3 of the full numbering are dofs 0, 1, 2 of the model."""
    free = [0, 2, 3]
    M, K, C = np.diag([M3[0, 0], 7.0, M3[1, 1], M3[2, 2]]), np.zeros((4, 4)), np.zeros((4, 4))
    K[np.ix_(free, free)], C[np.ix_(free, free)] = K3, C3
    K[1, 1], K[0, 1], K[1, 0] = 5.0, -0.5, -0.5
    C[1, 1], C[0, 1], C[1, 0] = 1.0, -0.1, -0.1
    return M, K, C


def test_forced_dofs_are_in_the_full_numbering_as_springs():
    """A force on a model with `fixed_dofs` names its dofs (and its vector's entries) in the
    numbering of M and K, before `fixed_dofs`, as springs and a job file's `force` do: full
    dof 3 is the model's dof 2 (in the reduced numbering dof 3 does not exist). The response
    is the complex solve on the reduced matrices with the force there, and the default output
    dof and the phase dof are the forced dof in the model's numbering, as `output_dofs` are."""
    M, K, C = chain_with_a_fixed_dof_inside()
    model = nnm.Model(M, K, C=C, fixed_dofs=[1])
    assert model.dofs == 3
    F = np.array([0.0, 0.0, 1.0])
    r = nnm.frequency_response(model, nnm.Force(dofs=[3], amplitude=0.3), (0.3, 1.8), tolerance=1e-12)
    assert r.stop_kind == "end" and r.output_dofs == [2] and r.phase_dof == 2
    check_linear(r, M3, K3, C3, F, 1e-9)
    # A vector has one entry per dof of M (a zero on the fixed one): full dofs 0 and 2.
    r = nnm.frequency_response(model, nnm.Force(vector=[0.5, 0.0, -1.0, 0.0]), (0.3, 1.8), tolerance=1e-12)
    assert r.output_dofs == [0, 1]
    check_linear(r, M3, K3, C3, np.array([0.5, -1.0, 0.0]), 1e-9)
    # motion() drives the model with the same force: the harmonic of the complex solve.
    k = len(r) // 2
    motion = r.motion(k, samples=40)
    X = complex_response(M3, K3, C3, r.force_amplitude[k] * np.array([0.5, -1.0, 0.0]), r.frequency[k])
    expected = (X[None, :] * np.exp(1j * r.frequency[k] * motion.t[:, None])).real
    np.testing.assert_allclose(motion.x, expected, atol=1e-9 * np.abs(X).max())


def test_a_forced_fixed_dof_has_the_job_files_message(cli, write_job):
    """Forcing a fixed dof, or a vector with a non-zero entry on one, is refused before anything
    is computed, with the job file's message (one function converts both)."""
    M, K, C = chain_with_a_fixed_dof_inside()
    model = nnm.Model(M, K, C=C, fixed_dofs=[1])
    for force, toml in [
        (nnm.Force(dofs=[0, 1], amplitude=1.0), "{ dofs = [0, 1], amplitude = 1.0 }"),
        (nnm.Force(vector=[0.0, 2.0, 1.0, 0.0]), "{ vector = [0.0, 2.0, 1.0, 0.0] }"),
    ]:
        job = write_job(f"[model]\nmass = {M.tolist()}\nstiffness = {K.tolist()}\nfixed_dofs = [1]\n"
                        f"damping = {{ matrix = {C.tolist()} }}\n"
                        f'[[response]]\nname = "frc"\nforce = {toml}\nfrequency_start = 0.3\nfrequency_end = 1.8\n')
        expected = cli_error(cli, "modes", job)
        with pytest.raises(ValueError) as caught:
            nnm.frequency_response(model, force, (0.3, 1.8))
        message = str(caught.value)
        assert "is fixed (`fixed_dofs`): a support takes the force" in message
        assert expected.endswith(f"response `frc`: {message}"), (expected, message)


@pytest.mark.parametrize(
    "force, frequency, message",
    [
        (nnm.Force(dofs=[0], amplitude=0.1), (2.0, 1.0), r"frequency_end must exceed frequency_start \(2\), got 1"),
        (nnm.Force(dofs=[0], amplitude=0.1), (1.0, 1.0), "frequency_end must exceed frequency_start"),
        (nnm.Force(dofs=[0], amplitude=0.1), (0.0, 1.0), "frequency_start must be positive, got 0"),
        (nnm.Force(dofs=[0], amplitude=0.0), (0.5, 1.0), "the force amplitude must be non-zero, got 0"),
        (nnm.Force(vector=[0.0, 0.0, 0.0]), (0.5, 1.0), "the force is zero"),
        (nnm.Force(vector=[1.0, 0.0]), (0.5, 1.0), "the force vector has 2 entries, the model 3 dofs"),
        (nnm.Force(dofs=[3], amplitude=1.0), (0.5, 1.0), r"forced dof 3 is out of range \(the model has 3 dofs\)"),
        (nnm.Force(engine_order=1, amplitude=1.0, sector_dof=0), (0.5, 1.0),
         "engine-order excitation needs a cyclic model"),
    ],
)
def test_bad_sweep_or_force(force, frequency, message):
    model = nnm.Model(M3, K3, C=C3)
    with pytest.raises(ValueError, match=message):
        nnm.frequency_response(model, force, frequency)


def test_bad_engine_order_settings_and_force_forms():
    M, K = grounded_disk(6)
    disk = nnm.Model(M, K, cyclic=(6, 2), damping={"rayleigh": [0.0, 1e-2]})
    sectors = 6
    with pytest.raises(ValueError, match=f"engine order {sectors} is beyond N/2"):
        nnm.frequency_response(disk, nnm.Force(engine_order=sectors, amplitude=1.0, sector_dof=1), (1.0, 2.0))
    model = nnm.Model(M3, K3, C=C3)
    force = nnm.Force(dofs=[0], amplitude=0.1)
    with pytest.raises(ValueError, match="unknown field `tolerence`, expected one of"):
        nnm.frequency_response(model, force, (0.5, 1.0), tolerence=1e-9)
    with pytest.raises(ValueError, match="tolerance 0.1 is too loose"):
        nnm.frequency_response(model, force, (0.5, 1.0), tolerance=0.1)
    with pytest.raises(ValueError, match=r"output dof 7 is out of range"):
        nnm.frequency_response(model, force, (0.5, 1.0), output_dofs=[7])
    with pytest.raises(ValueError, match="amplitude_max must exceed the starting amplitude"):
        nnm.force_response(model, force, frequency=1.0, amplitude_max=0.05)
    with pytest.raises(TypeError, match="frequency must be"):
        nnm.frequency_response(model, force, 1.0)
    with pytest.raises(TypeError, match="needs `amplitude`"):
        nnm.Force(dofs=[0])
    with pytest.raises(TypeError, match="takes nothing else"):
        nnm.Force(vector=[1.0], amplitude=2.0)
    with pytest.raises(TypeError, match="needs `amplitude` and `sector_dof`"):
        nnm.Force(engine_order=1, amplitude=1.0)
    with pytest.raises(TypeError):
        nnm.frequency_response(model, {"dofs": [0], "amplitude": 1.0, "phase": 0.0}, (0.5, 1.0))


def test_ctrl_c_stops_between_points_and_keeps_them():
    """A real SIGINT (as Ctrl-C sends) during a long curve: the library checks for it between
    points, and the KeyboardInterrupt carries the points so far."""
    import _thread
    import threading

    model = nnm.duffing(damping=[[0.02]])
    timer = threading.Timer(0.3, _thread.interrupt_main)
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt) as caught:
            nnm.frequency_response(model, nnm.Force(dofs=[0], amplitude=0.1), (0.5, 3.5), max_step=1e-4,
                                   initial_step=1e-4, max_points=100000, progress=False)
    finally:
        timer.cancel()
    partial = caught.value.response
    assert partial.stop_kind == "interrupted"
    assert 0 < len(partial) < 100000
    assert partial.frequency[0] == 0.5


def test_a_jobs_response_runs_on_its_model_as_written():
    """``nnm.job_response`` is the job's ``[[response]]`` table handed to
    ``frequency_response``: the same curves, point for point, as the call written out; an
    unknown name lists the job's responses."""
    from pathlib import Path

    job = Path(__file__).resolve().parents[3] / "examples" / "forced-duffing.toml"
    model = nnm.Model.from_job(job)
    assert model.responses == ["frc"]
    from_job = nnm.job_response(model, "frc", progress=False)
    written = nnm.frequency_response(
        model, {"dofs": [0], "amplitude": 0.1}, (0.5, 3.5), amplitudes=[0.05, 0.1], progress=False
    )
    assert len(from_job) == len(written) == 2
    for a, b in zip(from_job, written):
        np.testing.assert_array_equal(a.frequency, b.frequency)
        np.testing.assert_array_equal(a.peaks, b.peaks)
        assert [e.kind for e in a.events] == [e.kind for e in b.events]
    with pytest.raises(ValueError, match=r"^the job has no response `nope` \(its responses: `frc`\)$"):
        nnm.job_response(model, "nope")


def test_a_mistuned_sample_spends_on_its_trials_what_its_points_cost() -> None:
    """The example sweep's first draw at σ = 0.02, whose curve once spent 209 s of 213 in one
    continuation step: its corrector ran off to |z0| ~ 1e5 and Ω ~ 0.004 while the residual,
    relative to the iterate, stayed bounded, and DOP853 took 1.6 million steps through those
    trial motions. Held within the corrector's reach (docs/method.md eq. (22a)), an integration
    costs what a converged point's period does (about 15 steps here), not forty times that."""
    draw = 0.02 * sweeps.mistuning_draw(0, 0, 30)
    model = nnm.Model.from_job(
        ROOT / "examples" / "forced-bladed-disk.toml",
        {"model.blade_stiffness_mistuning": [float(d) for d in draw]},
    )
    response = nnm.job_response(model, "eo5")
    assert response.stop_kind == "end", response.stop
    per_integration = response.stats["integration_steps"] / response.stats["integrations"]
    assert per_integration < 4 * np.max(response.integration_steps), (per_integration, response.stats)


def test_a_curve_that_closes_on_a_loop_stops_and_its_sample_is_computed_again() -> None:
    """Draw 877 of the example sweep at σ = 0.02: at the default largest step the curve jumps
    onto an isolated loop near 2.13 rad/s and used to circle it until its 2,000 points ran out
    (59 s, a peak 19% below the tuned disk's); it now stops as soon as it comes back onto
    itself, and the sweep's sample is computed again at half the step, which covers the whole
    sweep (docs/method.md §19)."""
    job = ROOT / "examples" / "forced-bladed-disk.toml"
    sample = next(s for s in sweeps.plan(["eo5"], samples=878, mistuning=[0.02]) if s.replicate == 877)
    draw = 0.02 * sweeps.mistuning_draw(0, 877, 30)
    model = nnm.Model.from_job(job, {"model.blade_stiffness_mistuning": [float(d) for d in draw]})
    closed = nnm.job_response(model, "eo5", progress=False, raise_on_failure=False)
    assert closed.stop_kind == "closed", closed.stop
    assert len(closed) < 100 and closed.stop.startswith("closed on itself at point")
    row = sweeps.run_response_sample(str(job), sample, 0)["row"]
    assert (row["status"], row["stop"]) == ("ok", "end"), row
    assert row["message"] == "closed on a loop at max_step 0.1; complete at 0.05"


def test_a_sweep_sample_short_of_its_sweeps_end_is_a_failed_row(write_job) -> None:
    """A curve cut at ``max_points`` has not seen the rest of its range, so its largest peak
    says nothing: the row is failed, with the curve's own reason, not a peak to average."""
    job = write_job(LINEAR_DISK + "max_points = 5\n")
    sample = sweeps.plan(["eo2"])[0]
    row = sweeps.run_response_sample(str(job), sample, 0)["row"]
    assert (row["status"], row["stop"], row["points"]) == ("failed", "max-points", 5), row
    assert row["message"] == "max_points (5) reached"
