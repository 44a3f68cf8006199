"""Bad input raises ValueError/TypeError with the command line's one-line message (compared
with what `nnm` itself prints for the same model in a job file); numerical failures raise
nnm.ContinuationError with the points computed so far."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import nnm
from conftest import cli_error

TWO = np.eye(2)
CHAIN = np.array([[2.0, -1.0], [-1.0, 2.0]])


def toml_rows(a) -> str:
    return "[" + ", ".join("[" + ", ".join(str(v) for v in row) + "]" for row in np.asarray(a)) + "]"


@pytest.mark.parametrize(
    "mass, stiffness",
    [
        (TWO, np.eye(3)),  # wrong size
        (TWO, [[2.0, -1.0], [-1.0, np.nan]]),  # NaN
        (TWO, [[2.0, -1.0], [-0.5, 2.0]]),  # not symmetric
        ([[1.0, 0.0], [0.0, -1.0]], CHAIN),  # mass not positive definite
        ([[1.0, 2.0], [2.0, 1.0]], CHAIN),  # mass indefinite (not diagonal)
    ],
)
def test_bad_matrices_have_the_command_lines_message(mass, stiffness, write_job, cli) -> None:
    with pytest.raises(ValueError) as raised:
        nnm.Model(np.array(mass), np.array(stiffness))
    job = write_job(f"[model]\nmass = {toml_rows(mass)}\nstiffness = {toml_rows(stiffness)}\n")
    assert cli_error(cli, "modes", job) == f"{job}: {raised.value}"


@pytest.mark.parametrize(
    "element, toml",
    [
        (nnm.Polynomial([0], 1.0, 40), 'type = "polynomial"\ndofs = [0]\ncoefficient = 1.0\nexponent = 40'),
        (nnm.Cubic([1, 1], 1.0), 'type = "cubic"\ndofs = [1, 1]\ncoefficient = 1.0'),
        (nnm.Cubic([0, 5], 1.0), 'type = "cubic"\ndofs = [0, 5]\ncoefficient = 1.0'),
        (nnm.Cubic([0], np.inf), 'type = "cubic"\ndofs = [0]\ncoefficient = inf'),
    ],
)
def test_bad_elements_have_the_command_lines_message(element, toml, write_job, cli) -> None:
    with pytest.raises(ValueError) as raised:
        nnm.Model(TWO, CHAIN, [element])
    job = write_job(
        f"[model]\nmass = {toml_rows(TWO)}\nstiffness = {toml_rows(CHAIN)}\n[[model.nonlinear]]\n{toml}\n"
    )
    assert cli_error(cli, "modes", job) == f"{job}: {raised.value}"


def test_bad_family_parameters_have_the_command_lines_message(write_job, cli) -> None:
    with pytest.raises(ValueError) as raised:
        nnm.bladed_disk(sectors=0)
    job = write_job('[model]\nfamily = "bladed-disk"\nsectors = 0\n')
    assert cli_error(cli, "modes", job) == f"{job}: {raised.value}"
    with pytest.raises(TypeError, match="invalid type"):
        nnm.bladed_disk(sectors=2.5)


@pytest.mark.parametrize(
    "model, mode, settings, toml",
    [
        ("duffing", 7, {"energy_max": 1.0}, "mode = 7\nenergy_max = 1.0"),
        ("bladed-disk", "9,9", {"energy_max": 1.0}, 'mode = "9,9"\nenergy_max = 1.0'),
        ("bladed-disk", "0,0", {"energy_max": 1.0}, 'mode = "0,0"\nenergy_max = 1.0'),  # rigid
        ("bladed-disk", "1,0", {"energy_max": 1.0, "pattern": "sin"}, 'mode = "1,0"\npattern = "sin"\nenergy_max = 1.0'),
        # A travelling wave of a single mode: refused before anything runs (issue 29).
        (
            "bladed-disk",
            "1,0",
            {"energy_max": 1.0, "pattern": "travelling"},
            'mode = "1,0"\npattern = "travelling"\nenergy_max = 1.0',
        ),
    ],
)
def test_unknown_modes_have_the_command_lines_message(model, mode, settings, toml, write_job, cli) -> None:
    with pytest.raises(ValueError) as raised:
        nnm.backbone(nnm.Model._family(model, {}), mode, **settings)
    job = write_job(f'[model]\nfamily = "{model}"\n[[branch]]\nname = "b"\n{toml}\n')
    assert cli_error(cli, "run", job, "--out", job.parent / "out") == f"branch `b`: {raised.value}"


@pytest.mark.parametrize(
    "settings, toml, exception",
    [
        ({"energy_max": 1.0, "tolrance": 1e-9}, "energy_max = 1.0\ntolrance = 1e-9", ValueError),  # misspelt
        ({"energy_max": 1.0, "tolerance": 0.5}, "energy_max = 1.0\ntolerance = 0.5", ValueError),  # out of range
        ({"energy_max": 1.0, "tolerance": "tight"}, 'energy_max = 1.0\ntolerance = "tight"', TypeError),
        ({"energy_max": 1.0, "events": 1}, "energy_max = 1.0\nevents = 1", TypeError),  # an int is not a bool
        ({"energy_max": float("nan")}, "energy_max = nan", ValueError),
        ({"tolerance": 1e-9}, "tolerance = 1e-9", ValueError),  # no stop limit
        ({"energy_max": 1.0, "phase": "sideways"}, 'energy_max = 1.0\nphase = "sideways"', ValueError),
        ({"energy_max": 1.0, "target_iterations": 0}, "energy_max = 1.0\ntarget_iterations = 0", ValueError),
        ({"energy_max": 1.0, "output_dofs": [0, 0]}, "energy_max = 1.0\noutput_dofs = [0, 0]", ValueError),
    ],
)
def test_bad_settings_have_the_command_lines_message(settings, toml, exception, write_job, cli) -> None:
    with pytest.raises(exception) as raised:
        nnm.backbone(nnm.duffing(), 0, **settings)
    assert "\n" not in str(raised.value)
    job = write_job(f'[model]\nfamily = "duffing"\n[[branch]]\nname = "b"\nmode = 0\n{toml}\n')
    assert cli_error(cli, "run", job, "--out", job.parent / "out") == f"{job}: branch 1: {raised.value}"


def test_shapes_and_types_are_checked_before_the_library() -> None:
    with pytest.raises(ValueError, match="mass matrix must be 2-D"):
        nnm.Model(np.ones(3), CHAIN)
    with pytest.raises(TypeError, match="stiffness matrix must be real numbers"):
        nnm.Model(TWO, [["a", "b"], ["c", "d"]])
    with pytest.raises(TypeError):
        nnm.Model(TWO, CHAIN, [nnm.Cubic([0.5], 1.0)])
    with pytest.raises(ValueError, match="0-based"):
        nnm.Model(TWO, CHAIN, [nnm.Cubic([-1], 1.0)])
    with pytest.raises(ValueError, match="^nonlinear element 1: exponent must be 2 to 31, got -3$"):
        nnm.Model(TWO, CHAIN, [nnm.Polynomial([0], 1.0, -3)])
    with pytest.raises(ValueError, match="^mass matrix is 2x3, not square$"):
        nnm.Model(sp.csr_array(np.ones((2, 3))), CHAIN)
    with pytest.raises(ValueError, match="^stiffness matrix is 3x3, expected 2x2$"):
        nnm.Model(TWO, sp.csr_array(np.eye(3)))
    with pytest.raises(TypeError, match="nonlinear element 1 must be"):
        nnm.Model(TWO, CHAIN, ["cubic"])
    with pytest.raises(ValueError, match=r"shape \(m, 4\)"):
        nnm.Model(TWO, CHAIN, [nnm.Tensor(cubic=(np.zeros((2, 3), dtype=int), [1.0, 1.0]))])
    with pytest.raises(TypeError, match="`tolerance`"):
        nnm.backbone(nnm.duffing(), 0, energy_max=1.0, tolerance=object())
    with pytest.raises(TypeError):
        nnm.backbone(nnm.duffing(), 0, energy_max=1.0, name="x")
    with pytest.raises(TypeError, match="needs `mode`"):
        nnm.backbone(nnm.duffing(), energy_max=1.0)
    with pytest.raises(TypeError, match="either `branch`"):
        nnm.backbone(nnm.duffing(), 0, branch="b", energy_max=1.0)  # a job branch has its settings
    with pytest.raises(ValueError, match="no branch `b`"):
        nnm.backbone(nnm.duffing(), branch="b")
    with pytest.raises(FileNotFoundError):
        nnm.Model.from_job("no/such/job.toml")
    branch = nnm.backbone(nnm.duffing(), 0, max_points=3)
    with pytest.raises(ValueError, match=r"^point 3 does not exist: the branch has 3 points \(0 to 2, or -3 to -1"):
        branch.motion(3)


def test_an_empty_tensor_file_is_refused_naming_it(write_job, cli) -> None:
    job = write_job(
        f"[model]\nmass = {toml_rows(TWO)}\nstiffness = {toml_rows(CHAIN)}\n"
        '[[model.nonlinear]]\ntype = "tensor"\nquadratic = { file = "f2.txt" }\n',
        **{"f2.txt": "% no terms\n\n"},
    )
    with pytest.raises(ValueError) as raised:
        nnm.Model.from_job(job)
    assert str(raised.value) == cli_error(cli, "modes", job)
    assert str(raised.value).startswith(f"{job.parent / 'f2.txt'}: no terms: ")


def test_a_tensor_that_is_not_a_gradient_is_refused_naming_its_terms() -> None:
    """f0 = x1^3 with no matching f1 term has no potential (eq. (59)); indices 0-based."""
    with pytest.raises(ValueError, match=r"^nonlinear element 1: .*cubic") as raised:
        nnm.Model(TWO, CHAIN, [nnm.Tensor(cubic=([[0, 1, 1, 1]], [1.0]))])
    assert "\n" not in str(raised.value)


def test_a_branch_that_fails_raises_with_its_points_so_far() -> None:
    """One Newton iteration per step and a large minimum step: the corrector soon fails at
    the smallest step allowed."""
    settings = {"energy_max": 100.0, "max_iterations": 1, "min_step": 0.05, "tolerance": 1e-10}
    with pytest.raises(nnm.ContinuationError) as raised:
        nnm.backbone(nnm.duffing(), 0, **settings)
    error = raised.value
    assert isinstance(error, nnm.NumericalError) and not isinstance(error, ValueError)
    assert str(error).startswith("no convergence at the minimum step")
    partial = error.branch
    assert partial.stop_kind == "step-too-small" and partial.stop == str(error)
    assert 0 < len(partial) and partial.energy[-1] < 100.0
    assert (partial.relative_residual < 1e-10).all()  # every point kept did converge
    kept = nnm.backbone(nnm.duffing(), 0, raise_on_failure=False, **settings)
    assert np.array_equal(kept.state0, partial.state0)


def test_a_first_point_that_fails_raises_with_no_points() -> None:
    with pytest.raises(nnm.ContinuationError, match="^the first point did not converge") as raised:
        nnm.backbone(nnm.duffing(), 0, energy_max=1e9, energy_start=1e6, max_iterations=1)
    assert len(raised.value.branch) == 0
    assert raised.value.branch.state0.shape == (0, 2)


def test_a_job_branch_switched_from_an_event_is_refused_by_name(write_job) -> None:
    job = write_job(
        '[model]\nfamily = "two-dof"\n[settings]\nenergy_max = 100.0\n'
        '[[branch]]\nname = "in-phase"\nmode = 0\n'
        '[[branch]]\nname = "switched"\nstart = { branch = "in-phase", event = 0 }\n'
    )
    model = nnm.Model.from_job(job)
    assert model.branches == ["in-phase", "switched"]
    with pytest.raises(ValueError, match="^branch `switched` starts from event 0 of branch `in-phase`"):
        nnm.backbone(model, branch="switched")


@pytest.fixture(scope="module")
def short_branch() -> nnm.Branch:
    return nnm.backbone(nnm.duffing(), 0, max_points=3, progress=False)


@pytest.mark.parametrize(
    "args, kwargs, exception, message",
    [
        ((999,), {}, ValueError, r"^point 999 does not exist: the branch has 3 points \(0 to 2, or -3 to -1 from the end\)$"),
        ((-4,), {}, ValueError, r"^point -4 does not exist: the branch has 3 points"),
        ((1.0,), {}, TypeError, r"^the point index must be an integer, got float$"),
        (("1",), {}, TypeError, r"^the point index must be an integer, got str$"),
        ((0,), {"samples": 0}, ValueError, r"^samples must be at least 1, got 0$"),
        ((0,), {"samples": -5}, ValueError, r"^samples must be at least 1, got -5$"),
        ((0,), {"samples": 2**70}, ValueError, r"^samples=1180591620717411303424 would need .* GB for a motion of 1 dofs, more than half of this machine's .* GB of memory: at most \d+ samples$"),
        ((0,), {"samples": 10**400}, ValueError, r"^samples=1e400 would need 1.04e393 GB for a motion of 1 dofs, more than half"),
        ((0,), {"samples": -(10**400)}, ValueError, r"^samples must be at least 1, got -1e400$"),
        ((10**400,), {}, ValueError, r"^point 1e400 does not exist: the branch has 3 points"),
        ((0,), {"samples": 10.0}, TypeError, r"^samples must be an integer, got float$"),
        ((0,), {"samples": True}, TypeError, r"^samples must be an integer, got bool$"),
        ((0,), {"tolerance": float("nan")}, ValueError, r"^tolerance must be positive and finite, got NaN$"),
        ((0,), {"tolerance": 0.0}, ValueError, r"^tolerance must be positive and finite, got 0$"),
        ((0,), {"tolerance": -1e-8}, ValueError, r"^tolerance must be positive and finite, got -1e-8$"),
        ((0,), {"tolerance": 0.5}, ValueError, r"^tolerance 0.5 is too loose \(use < 1e-2\)$"),
        ((0,), {"tolerance": 1e-20}, ValueError, r"^tolerance 1e-20 is below 1e-14"),
        ((0,), {"tolerance": "1e-8"}, TypeError, r"^tolerance must be a real number, got str$"),
    ],
)
def test_bad_motion_arguments_are_refused_before_anything_is_computed(
    short_branch, args, kwargs, exception, message
) -> None:
    """`motion(i, samples=10**12)` once aborted the interpreter allocating the samples;
    `motion(999)` raised IndexError and negative samples OverflowError; NaN, 0 and negative
    tolerances were accepted, a string through `float()` (issue 29)."""
    with pytest.raises(exception, match=message) as raised:
        short_branch.motion(*args, **kwargs)
    assert "\n" not in str(raised.value)


def test_motion_samples_are_bounded_by_the_machines_memory(short_branch, monkeypatch) -> None:
    """The bound is half the physical memory over 32 n + 72 bytes a sample (n = 1 here):
    with 1 MB of memory, 512 kB / 104 B = 5041 states, so 5040 samples fit and 5041 do not."""
    from nnm import _checks

    monkeypatch.setattr(_checks, "physical_memory", lambda: 2**20)
    assert len(short_branch.motion(0, samples=5040).t) == 5041
    with pytest.raises(ValueError, match=r"^samples=5041 would need 0.000524 GB .* 0.00105 GB of memory: at most 5040 samples$"):
        short_branch.motion(0, samples=5041)


def test_motion_takes_python_style_indices(short_branch) -> None:
    """`motion(-1)` is the last point, as `energy[-1]` is; the tolerance range's ends pass."""
    last = short_branch.motion(-1, samples=4, tolerance=1e-14)
    assert np.array_equal(last.x, short_branch.motion(2, samples=4, tolerance=1e-14).x)
    assert last.t[-1] == short_branch.period[-1]
    assert len(short_branch.motion(np.int64(0), samples=np.int32(3), tolerance=np.float32(1e-3)).t) == 4


@pytest.mark.parametrize(
    "element, exception, message",
    [
        (nnm.Cubic([0], "0.5"), TypeError, r"^nonlinear element 1: coefficient must be a real number, got str$"),
        (nnm.Cubic([0], 1 + 2j), TypeError, r"^nonlinear element 1: coefficient must be a real number, got complex$"),
        (nnm.Cubic([0], True), TypeError, r"^nonlinear element 1: coefficient must be a real number, got bool$"),
        (nnm.Cubic([0], float("nan")), ValueError, r"^nonlinear element 1: coefficient must be finite, got NaN$"),
        (nnm.Cubic(["0"], 1.0), TypeError, r"^nonlinear element 1: dofs must be an integer, got str$"),
        (nnm.Polynomial([0], "1", 3), TypeError, r"^nonlinear element 1: coefficient must be a real number, got str$"),
        (nnm.Polynomial([0], 1.0, 3.0), TypeError, r"^nonlinear element 1: exponent must be an integer, got float$"),
        (nnm.Polynomial([0], 1.0, 10**30), ValueError, r"^nonlinear element 1: `exponent` = 1e30 is out of range$"),
        (nnm.Tensor(cubic=([[0, 0, 0, 0]], ["1.0"])), TypeError, r"^nonlinear element 1: cubic term values must be real numbers, got dtype <U3$"),
        (nnm.Tensor(quadratic=([[0, 0, 0]], [1j])), TypeError, r"^nonlinear element 1: quadratic term values must be real numbers, got dtype complex128$"),
    ],
)
def test_element_numbers_are_real_numbers_and_integers(element, exception, message) -> None:
    """A string coefficient was accepted through `float()` (issue 29): a str where a number is
    expected is a TypeError, in every element."""
    with pytest.raises(exception, match=message):
        nnm.Model(TWO, CHAIN, [element])


def test_model_integers_are_checked() -> None:
    with pytest.raises(TypeError, match=r"^cyclic must be \(sectors, dofs_per_sector\), got 2$"):
        nnm.Model(TWO, CHAIN, cyclic=2)
    with pytest.raises(ValueError, match=r"^cyclic=\(sectors, dofs_per_sector\) must be positive, got \(-2, -1\)$"):
        nnm.Model(TWO, CHAIN, cyclic=(-2, -1))
    with pytest.raises(TypeError, match=r"^cyclic sectors must be an integer, got float$"):
        nnm.Model(TWO, CHAIN, cyclic=(2.0, 1))


@pytest.mark.parametrize(
    "tolerance, message",
    [
        (float("nan"), "tolerance must be positive and finite, got NaN"),
        (0.0, "tolerance must be positive and finite, got 0"),
        (-1e-8, "tolerance must be positive and finite, got -1e-8"),
    ],
)
def test_nan_zero_and_negative_tolerances_are_refused_as_by_the_command_line(tolerance, message, write_job, cli) -> None:
    """Keyword settings are the job file's: the same range, the same message, in both."""
    with pytest.raises(ValueError, match=f"^invalid setting: {message}$") as raised:
        nnm.backbone(nnm.duffing(), 0, energy_max=1.0, tolerance=tolerance)
    toml = "nan" if tolerance != tolerance else repr(tolerance)
    job = write_job(f'[model]\nfamily = "duffing"\n[[branch]]\nname = "b"\nmode = 0\nenergy_max = 1.0\ntolerance = {toml}\n')
    assert cli_error(cli, "run", job, "--out", job.parent / "out") == f"{job}: branch 1: {raised.value}"


def test_plot_dofs_are_checked_before_anything_is_drawn(short_branch) -> None:
    from nnm import plot

    with pytest.raises(ValueError, match=r"^dof 5 does not exist: the motion has 1 dofs$"):
        plot.time_series(short_branch.motion(0, samples=4), dofs=[5])
    with pytest.raises(TypeError, match=r"^dofs must be an integer, got float$"):
        plot.time_series(short_branch.motion(0, samples=4), dofs=[0.0])
    with pytest.raises(ValueError, match=r"^dof 1 is not one of the branch's 1 output_dofs$"):
        plot.amplitude([short_branch], dof=1)


BIG = 2**64  # beyond 64 bits: was an OverflowError from the conversion to the library's integers


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda: nnm.Force(dofs=[BIG], amplitude=1.0), rf"^`forced dof` = {BIG} is out of range$"),
        (lambda: nnm.Force(dofs=BIG, amplitude=1.0), rf"^`forced dof` = {BIG} is out of range$"),
        (lambda: nnm.Force(engine_order=BIG, sector_dof=0, amplitude=1.0), rf"^`engine_order` = {BIG} is out of range$"),
        (lambda: nnm.Model(TWO, CHAIN, fixed_dofs=[BIG]), rf"^`dofs` = {BIG} is out of range$"),
        (lambda: nnm.Model(TWO, CHAIN, [nnm.Cubic([0, BIG], 1.0)]), rf"^nonlinear element 1: `dofs` = {BIG} is out of range$"),
        (lambda: nnm.Model(TWO, CHAIN, cyclic=(BIG, 1)), rf"^`cyclic sectors` = {BIG} is out of range$"),
        (
            lambda: nnm.Model(TWO, CHAIN, [nnm.Tensor(quadratic=([[BIG, 0, 0]], [1.0]))]),
            rf"^nonlinear element 1: quadratic term index {BIG} is out of range$",
        ),
        (
            lambda: nnm.Model(TWO, CHAIN, [nnm.Tensor(quadratic=(np.array([[2**63, 0, 0]], dtype=np.uint64), [1.0]))]),
            rf"^nonlinear element 1: quadratic term index {2**63} is out of range$",
        ),
        (
            lambda: nnm.frequency_response(
                nnm.duffing(damping={"rayleigh": [0.02, 0.0]}), nnm.Force(dofs=[0], amplitude=0.1), (0.5, 1.5), output_dofs=[BIG]
            ),
            rf"^`output dof` = {BIG} is out of range$",
        ),
        (lambda: nnm.backbone(nnm.duffing(), 0, max_points=BIG), rf"^`max_points` = {BIG} is out of range$"),
    ],
)
def test_integers_beyond_64_bits_are_value_errors(make, message) -> None:
    """A dof, an index or a count of 2**64 raised OverflowError (issue 29): it is a ValueError
    with the message of a keyword setting out of range, and a uint64 tensor index from 2**63
    no longer wraps to a negative one."""
    with pytest.raises(ValueError, match=message):
        make()


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda: nnm.Model([[True, False], [False, True]], CHAIN), r"^mass matrix must be real numbers, got dtype bool$"),
        (lambda: nnm.Model(np.eye(2, dtype=bool), CHAIN), r"^mass matrix must be real numbers, got dtype bool$"),
        (lambda: nnm.Model(TWO, [[2.0, True], [True, 2.0]]), r"^stiffness matrix must be real numbers, got bool$"),
        (lambda: nnm.Model(TWO, sp.csr_matrix(np.eye(2, dtype=bool))), r"^stiffness matrix must be real numbers, got dtype bool$"),
        (lambda: nnm.Model(TWO, CHAIN, C=[[np.True_, 0.0], [0.0, 0.1]]), r"^damping matrix must be real numbers, got bool$"),
        (lambda: nnm.Model(TWO, CHAIN, damping={"rayleigh": [True, 0.0]}), r"^damping rayleigh must be a real number, got bool$"),
        (lambda: nnm.Force(vector=[True, 0.0]), r"^the force vector must be a 1-D sequence of real numbers, got bool$"),
        (lambda: nnm.Force(vector=np.array([True, False])), r"^the force vector must be a 1-D sequence of real numbers, got bool$"),
        (
            lambda: nnm.bladed_disk(sectors=2, blade_stiffness_mistuning=[0.0, True]),
            r"^blade_stiffness_mistuning must be a real number, got bool$",
        ),
    ],
)
def test_booleans_are_not_numbers(make, message) -> None:
    """Matrices of booleans were read as 0 and 1 (issue 29): a boolean where numbers are
    expected is a TypeError naming the argument, as a string is — a job file's `true` is not 1."""
    with pytest.raises(TypeError, match=message):
        make()


def test_extreme_scales_give_the_models_own_modes_or_a_reason() -> None:
    """K of order 1e154 read both elastic modes as rigid (issue 29); entries double precision
    cannot hold in full are refused naming the entry, as by the command line."""
    k0 = np.array([[1.0, -0.5], [-0.5, 1.0]])
    reference = nnm.Model(TWO, k0).modes().frequencies
    modes = nnm.Model(TWO, 1e154 * k0).modes()
    assert not modes.rigid.any()
    np.testing.assert_allclose(modes.frequencies, 1e77 * reference, rtol=1e-12)
    with pytest.raises(ValueError, match=r"^mass matrix entry \(0, 0\) = 1.000e-310 is subnormal \(below 2.2e-308\) and has lost digits in double precision: rescale the model's units$"):
        nnm.Model(1e-310 * TWO, k0)
    with pytest.raises(ValueError, match=r"^stiffness matrix entry \(0, 0\) = 1.000e300 is beyond 1.3e154"):
        nnm.Model(TWO, 1e300 * k0)


@pytest.mark.parametrize(
    "value, shown",
    [
        (10**400, "1e400"),
        (-(10**400), "-1e400"),
        (123 * 10**398, "1.23e400"),
        pytest.param(10**5000, "1e5000", id="10**5000"),  # beyond Python's 4300 digits of int-to-str
        (2**64, "18446744073709551616"),  # every 64-bit integer in full, up to 24 digits
        (10**24 - 1, "999999999999999999999999"),
        (10**24, "1e24"),
        (np.int64(-7), "-7"),
        (1e300, "1e300"),
        (-2.5e-310, "-2.5e-310"),
        (9.5e15, "9500000000000000"),
        (1e16, "1e16"),
        (1e-4, "0.0001"),
        (9e-5, "9e-5"),
        (5.0, "5"),
        (0.25, "0.25"),
        (float("nan"), "NaN"),
        (float("-inf"), "-inf"),
    ],
)
def test_numbers_in_messages_are_short_as_the_library_s(value, shown) -> None:
    """`nnm._checks.number`, the one formatter of the Python layer: the Rust side's
    `nnm::number::Number` for floats (its test's table), integers in full up to 24 digits and
    in scientific notation beyond."""
    from nnm import _checks

    assert _checks.number(value) == shown


HUGE = 10**400  # an int beyond the doubles and any integer setting


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: nnm.backbone(nnm.duffing(), 0, energy_max=1.0, tolerance=HUGE), "`tolerance` = 1e400 is out of range"),
        (lambda: nnm.backbone(nnm.duffing(), 0, energy_max=1.0, tolerance=-HUGE), "`tolerance` = -1e400 is out of range"),
        (lambda: nnm.backbone(nnm.duffing(), 0, energy_max=1.0, tolerance=10**5000), "`tolerance` = 1e5000 is out of range"),
        (lambda: nnm.backbone(nnm.duffing(), 0, energy_max=HUGE), "`energy_max` = 1e400 is out of range"),
        (lambda: nnm.backbone(nnm.duffing(), 0, energy_max=1.0, at_energies=[0.5, HUGE]), "`at_energies` = 1e400 is out of range"),
        (lambda: nnm.backbone(nnm.duffing(), 0, max_points=HUGE), "`max_points` = 1e400 is out of range"),
        (lambda: nnm.backbone(nnm.duffing(), HUGE, energy_max=1.0), "`mode` = 1e400 is out of range"),
        (lambda: nnm.duffing(cubic=HUGE), "`cubic` = 1e400 is out of range"),
        (lambda: nnm.Model(TWO, CHAIN, fixed_dofs=[HUGE]), "`dofs` = 1e400 is out of range"),
        (
            lambda: nnm.frequency_response(
                nnm.duffing(damping={"rayleigh": [0.02, 0.0]}), nnm.Force(dofs=[0], amplitude=0.1), (0.5, 1.5), samples=HUGE
            ),
            "`samples` = 1e400 is out of range",
        ),
    ],
)
def test_a_huge_integer_setting_is_refused_in_one_short_line(call, message) -> None:
    """A refused number was printed with all its digits (issue 29, "Messages"): 10**400 as a
    keyword setting was a ValueError of 430 characters, 10**5000 beyond Python's int-to-str
    limit an "<unprintable int object>" and a warning on stderr. Now as `nnm run` prints a
    number, short."""
    with pytest.raises(ValueError) as raised:
        call()
    assert str(raised.value) == message
