"""The same model given as numpy arrays, as scipy.sparse matrices, in a job file read by the
bindings and in a job file run by `nnm run` gives the same branch bit for bit.

The library keeps a matrix in the storage it is given (a dense consistent mass is factorised
by dense Cholesky, a sparse one by sparse Cholesky: the round-off differs in the last bits),
so dense input is compared with a job file's rows (dense too) and sparse input with Matrix
Market coordinate files (sparse too); with a diagonal mass both storages take the same path,
and dense and sparse input agree bit for bit as well.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

import nnm

# A clamped-free chain of 4 masses with a consistent (non-diagonal) mass matrix, a cubic
# spring to ground, a cubic spring between two masses and a quintic one.
M = np.array(
    [[2.0, 0.5, 0.0, 0.0], [0.5, 2.0, 0.5, 0.0], [0.0, 0.5, 2.0, 0.5], [0.0, 0.0, 0.5, 1.0]]
) / 3.0
K = np.array([[2.0, -1.0, 0.0, 0.0], [-1.0, 2.0, -1.0, 0.0], [0.0, -1.0, 2.0, -1.0], [0.0, 0.0, -1.0, 1.0]])
ELEMENTS = [nnm.Cubic([3], 0.5), nnm.Cubic([1, 2], 0.25), nnm.Polynomial([0], 0.1, 5)]
ELEMENTS_TOML = """
[[model.nonlinear]]
type = "cubic"
dofs = [3]
coefficient = 0.5
[[model.nonlinear]]
type = "cubic"
dofs = [1, 2]
coefficient = 0.25
[[model.nonlinear]]
type = "polynomial"
dofs = [0]
coefficient = 0.1
exponent = 5
"""
# To E = 0.1: 50 points, an unstable stretch and two located events.
SETTINGS = {"energy_max": 0.1, "tolerance": 1e-9}
SETTINGS_TOML = "\n".join(f"{k} = {v!r}" for k, v in SETTINGS.items())


def rows(a: np.ndarray) -> str:
    return "[" + ", ".join("[" + ", ".join(repr(float(v)) for v in row) + "]" for row in a) + "]"


def matrix_market(a: np.ndarray) -> str:
    """Coordinate Matrix Market text of `a`, values in Python's shortest round-trip form (so
    the file holds exactly the doubles of `a`)."""
    i, j = np.nonzero(a)
    lines = ["%%MatrixMarket matrix coordinate real general", f"{a.shape[0]} {a.shape[1]} {len(i)}"]
    lines += [f"{r + 1} {c + 1} {float(a[r, c])!r}" for r, c in zip(i, j)]
    return "\n".join(lines) + "\n"


def job_text(mass: str, stiffness: str, mode: int = 0) -> str:
    return (
        f"[model]\nmass = {mass}\nstiffness = {stiffness}\n{ELEMENTS_TOML}\n"
        f'[[branch]]\nname = "b"\nmode = {mode}\n{SETTINGS_TOML}\n'
    )


def assert_identical(a: nnm.Branch, b: nnm.Branch) -> None:
    assert len(a) == len(b) > 3
    for name in ("energy", "frequency", "period", "state0", "stable", "multipliers", "iterations"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    assert a.stop == b.stop
    assert [(e.kind, e.energy, e.multiplier) for e in a.events] == [(e.kind, e.energy, e.multiplier) for e in b.events]


def run_cli(cli: Path, job: Path, out: Path) -> dict:
    subprocess.run([str(cli), "run", str(job), "--out", str(out), "--quiet"], check=True, capture_output=True)
    return json.loads((out / "b.json").read_text())


def assert_same_as_cli(branch: nnm.Branch, document: dict) -> None:
    points = document["points"]
    assert len(points) == len(branch)
    assert len(document["events"]) == len(branch.events) > 0
    assert np.array_equal(branch.energy, [p["energy"] for p in points])
    assert np.array_equal(branch.frequency, [p["frequency_rad_s"] for p in points])
    assert np.array_equal(branch.state0, [p["z0"] for p in points])
    multipliers = np.array([[complex(re, im) for re, im in p["multipliers"]] for p in points])
    assert np.array_equal(branch.multipliers, multipliers)
    assert [e.energy for e in branch.events] == [e["energy"] for e in document["events"]]
    # What the branch did: the same peaks of the same output dofs, the same regimes.
    assert branch.output_dofs == document["output_dofs"]
    assert np.array_equal(branch.peak_displacement, [p["peak_displacements"] for p in points])
    assert list(branch.regime) == [p["regime"]["kind"] for p in points]
    partner = [p["regime"]["partner"] for p in points]
    expected = [np.nan if c is None else c["share"] for c in partner]
    np.testing.assert_array_equal(branch.partner_share, expected)


def test_numpy_arrays_match_job_file_rows_and_the_command_line(write_job, cli, tmp_path) -> None:
    direct = nnm.backbone(nnm.Model(M, K, ELEMENTS), 0, **SETTINGS)
    job = write_job(job_text(rows(M), rows(K)))
    model = nnm.Model.from_job(job)
    assert model.branches == ["b"]
    assert_identical(direct, nnm.backbone(model, 0, **SETTINGS))
    assert_identical(direct, nnm.backbone(model, branch="b"))
    assert_same_as_cli(direct, run_cli(cli, job, tmp_path / "out"))


@pytest.mark.parametrize("kind", [sp.csr_array, sp.coo_matrix, sp.csc_array])
def test_scipy_sparse_matches_matrix_market_files_and_the_command_line(
    kind, write_job, cli, tmp_path
) -> None:
    model = nnm.Model(kind(M), kind(K), ELEMENTS)
    assert sp.issparse(model.M) and sp.issparse(model.K)  # kept sparse, never densified
    direct = nnm.backbone(model, 0, **SETTINGS)
    job = write_job(
        job_text('{ file = "M.mtx" }', '{ file = "K.mtx" }'), **{"M.mtx": matrix_market(M), "K.mtx": matrix_market(K)}
    )
    assert_identical(direct, nnm.backbone(nnm.Model.from_job(job), branch="b"))
    assert_same_as_cli(direct, run_cli(cli, job, tmp_path / "out"))


def test_dense_and_sparse_agree_with_a_diagonal_mass() -> None:
    mass = np.diag([1.0, 2.0, 0.5, 1.5])
    dense = nnm.backbone(nnm.Model(mass, K, ELEMENTS), 1, **SETTINGS)
    sparse = nnm.backbone(nnm.Model(sp.csr_array(mass), sp.csr_array(K), ELEMENTS), 1, **SETTINGS)
    assert_identical(dense, sparse)


def test_sparse_duplicates_are_summed_as_in_an_assembly() -> None:
    """Two element stiffnesses at the same position add up, as a finite-element assembly (and
    a Matrix Market file with repeated entries) expects."""
    i, j = np.nonzero(K)
    v = K[i, j]
    assembled = sp.coo_matrix((np.r_[v / 2, v / 2], (np.r_[i, i], np.r_[j, j])), shape=K.shape)
    a = nnm.backbone(nnm.Model(M, K, ELEMENTS), 0, max_points=5)
    b = nnm.backbone(nnm.Model(sp.csr_array(M), assembled, ELEMENTS), 0, max_points=5)
    np.testing.assert_allclose(a.frequency, b.frequency, rtol=1e-12)


def test_fixed_dofs_are_the_model_reduced_by_hand() -> None:
    """Fixing dofs removes their rows and columns; a spring to a fixed dof becomes a spring to
    ground, one between fixed dofs vanishes (docs/method.md eq. (61))."""
    full_m = np.diag([1.0, 1.0, 1.0, 1.0, 1.0])
    full_k = np.diag([2.0] * 5) - np.diag([1.0] * 4, 1) - np.diag([1.0] * 4, -1)
    fixed = nnm.Model(
        full_m, full_k, [nnm.Cubic([1, 0], 0.5), nnm.Cubic([0, 4], 9.0), nnm.Cubic([3], 0.2)], fixed_dofs=[0, 4]
    )
    free = [1, 2, 3]
    by_hand = nnm.Model(
        full_m[np.ix_(free, free)], full_k[np.ix_(free, free)], [nnm.Cubic([0], 0.5), nnm.Cubic([2], 0.2)]
    )
    assert fixed.dofs == 3
    assert_identical(nnm.backbone(fixed, 0, **SETTINGS), nnm.backbone(by_hand, 0, **SETTINGS))


def test_tensor_terms_give_the_force_of_the_equivalent_springs() -> None:
    """A cubic spring c (x0 - x1)^3 written as polynomial terms, in both index forms."""
    c = 0.25
    # f0 = c (x0 - x1)^3, f1 = -f0, expanded term by term: (x0 - x1)^3 = x0^3 - 3 x0^2 x1 + 3 x0 x1^2 - x1^3.
    terms = [((0, 0, 0), 1.0), ((0, 0, 1), -3.0), ((0, 1, 1), 3.0), ((1, 1, 1), -1.0)]
    subs = np.array([[i, *jkl] for i, sign in ((0, 1.0), (1, -1.0)) for jkl, _ in terms])
    values = np.array([sign * c * v for i, sign in ((0, 1.0), (1, -1.0)) for _, v in terms])
    mass, stiffness = np.eye(2), np.array([[2.0, -1.0], [-1.0, 2.0]])
    springs = nnm.backbone(nnm.Model(mass, stiffness, [nnm.Cubic([0, 1], c)]), 1, **SETTINGS)
    for cubic in [(subs, values), (tuple(subs.T), values)]:
        tensor = nnm.backbone(nnm.Model(mass, stiffness, [nnm.Tensor(cubic=cubic)]), 1, **SETTINGS)
        assert len(tensor) == len(springs)
        np.testing.assert_allclose(tensor.frequency, springs.frequency, rtol=1e-10)
        np.testing.assert_allclose(tensor.state0, springs.state0, rtol=1e-8, atol=1e-12)


@pytest.mark.parametrize("family", nnm._nnm.FAMILIES)
def test_family_defaults_are_the_job_files(family, write_job) -> None:
    """Every family the library declares has its constructor (`nnm.<family>`, in `nnm.__all__`)
    and its entry in docs/job-files.md; the constructor's keyword defaults are those a job file
    gets when it names only the family: same matrices, same modes."""
    function = getattr(nnm, family.replace("-", "_"))
    assert function.__name__ in nnm.__all__
    job_files = Path(__file__).resolve().parents[3] / "docs" / "job-files.md"
    assert f'"{family}"' in job_files.read_text(), f"{family} missing from docs/job-files.md"
    from_python = function()
    from_job = nnm.Model.from_job(write_job(f'[model]\nfamily = "{family}"\n'))
    assert from_python.family == from_job.family == family
    for name in ("M", "K"):
        a, b = getattr(from_python, name), getattr(from_job, name)
        a, b = (x.toarray() if sp.issparse(x) else x for x in (a, b))
        assert np.array_equal(a, b), name
    assert np.array_equal(nnm.modes(from_python).frequencies, nnm.modes(from_job).frequencies)


def test_a_cyclic_model_from_matrices_has_the_familys_labels_and_branches() -> None:
    """The bladed disk rebuilt from its matrices and springs (`cyclic=(30, 2)`): the same
    (n, d) labels and, from (1,5), the same backbone as the family (to round-off: the two may
    hold K in different storage)."""
    family = nnm.bladed_disk()
    K = family.K.toarray() if sp.issparse(family.K) else family.K
    M = family.M.toarray() if sp.issparse(family.M) else family.M
    springs = [nnm.Cubic([2 * i + 1, 2 * i], 0.1) for i in range(30)]  # blade on its disk
    rebuilt = nnm.Model(M, K, springs, cyclic=(30, 2))
    assert rebuilt.cyclic == (30, 2)
    a, b = nnm.modes(family), nnm.modes(rebuilt)
    assert a.labels == b.labels and a.patterns == b.patterns
    np.testing.assert_allclose(a.frequencies, b.frequencies, rtol=1e-12, atol=1e-14)
    settings = {"frequency_shift_max": 0.05, "events": False, "progress": False}
    x, y = nnm.backbone(family, (1, 5), **settings), nnm.backbone(rebuilt, (1, 5), **settings)
    assert len(x) == len(y) and x.mode == y.mode
    np.testing.assert_allclose(x.frequency, y.frequency, rtol=1e-10)
    np.testing.assert_allclose(x.energy, y.energy, rtol=1e-8)


def test_a_large_sparse_model_gets_its_lowest_modes_without_a_dense_matrix() -> None:
    """A chain of 3,000 unit masses fixed at both ends (K = tridiag(-1, 2, -1), M = I):
    above 2,000 dofs a sparse model gets its 20 lowest modes by shift-invert, with no n x n
    array, and they are the exact ``2 sin(k pi / (2 (n + 1)))``."""
    n = 3000
    K = sp.diags([-np.ones(n - 1), 2 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1], format="csr")
    model = nnm.Model(sp.identity(n, format="csr"), K, [nnm.Cubic([n - 1], 1.0)])
    assert sp.issparse(model.K) and model.K.nnz == 3 * n - 2
    modes = nnm.modes(model)
    assert len(modes) == 20 and modes.shapes.shape == (n, 20)
    exact = 2 * np.sin(np.arange(1, 21) * np.pi / (2 * (n + 1)))
    np.testing.assert_allclose(modes.frequencies, exact, rtol=1e-9)


def test_family_constructors_show_the_librarys_parameters_and_refuse_others() -> None:
    """A family's constructor takes exactly the parameters the library's family struct
    declares, in its order, keyword-only, with its defaults (help() shows them), then the
    `damping` every family takes (kept beside the model); an unknown or positional argument
    is a TypeError before anything is built, as with a plain def."""
    import inspect

    signature = inspect.signature(nnm.von_karman_beam)
    assert list(signature.parameters) == [
        "elements", "length", "width", "thickness", "youngs_modulus", "density", "damping"
    ]
    assert signature.parameters["damping"].default is None
    assert all(p.kind is inspect.Parameter.KEYWORD_ONLY for p in signature.parameters.values())
    assert signature.parameters["elements"].default == 20
    assert inspect.signature(nnm.bladed_disk).parameters["blade_stiffness_mistuning"].default == []
    with pytest.raises(TypeError, match="unexpected keyword argument 'element'"):
        nnm.von_karman_beam(element=10)
    with pytest.raises(TypeError):
        nnm.duffing(1.0)
    assert nnm.von_karman_beam(elements=4).dofs < nnm.von_karman_beam().dofs  # the value is used
