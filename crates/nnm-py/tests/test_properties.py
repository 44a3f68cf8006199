"""Property tests of bad input (issue 29): nnm.Model, nnm.Force and the settings keywords of
nnm.backbone / nnm.frequency_response given generated values — valid, at an edge (zero,
negative, NaN, infinite, huge, out of range) or of a wrong type — either work or raise
ValueError/TypeError: never another exception (IndexError, OverflowError, a Rust panic) and
never an abort of the interpreter. Bounded by `max_examples` to stay in the regular test run."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import nnm

# No example database: CI runs from a clean tree, and the tests write nothing.
BOUNDED = settings(max_examples=50, deadline=None, database=None, suppress_health_check=[HealthCheck.too_slow])

# Scalars that break arithmetic or types: the edges a new user types.
EDGES = st.sampled_from(
    [0, 1, 2, -1, 10**12, 2**63, -(2**63), 10**400, 0.0, -0.0, 0.5, -1.0, 1e-300, 5e-324, 1e308,
     math.nan, math.inf, -math.inf, True, False, None, "", "1.0", "nan", "x", "0,1", b"1",
     [], [0], [1, 1], [-1], [math.nan], (0, 1), {}, {"rayleigh": [0.1, 0.0]}, 1 + 2j,
     np.float64(math.nan), np.int64(-1), np.array([1.0, 2.0])]
)
SCALARS = st.one_of(EDGES, st.integers(), st.floats(), st.text(max_size=5))

MATRICES = st.one_of(
    st.sampled_from(
        [np.eye(2), np.array([[2.0, -1.0], [-1.0, 2.0]]), np.eye(3), np.zeros((2, 2)),
         np.array([[1.0, math.nan], [math.nan, 1.0]]), np.array([[1e308, 0.0], [0.0, 1e308]]),
         np.array([[1.0, 2.0], [0.0, 1.0]]), np.ones((2, 3)), np.ones((2, 2, 2)), np.array([]),
         np.array([["a", "b"], ["c", "d"]]), [[1.0, 0.0], [0.0, 1.0]], [[1.0]], [], "M", None, 1.0,
         np.array([[1 + 1j, 0], [0, 1]])]
    ),
    st.lists(st.lists(SCALARS, min_size=1, max_size=3), min_size=1, max_size=3),
)


def element(kind: str, dofs, coefficient, exponent):
    if kind == "cubic":
        return nnm.Cubic(dofs, coefficient)
    return nnm.Polynomial(dofs, coefficient, exponent)


ELEMENTS = st.lists(
    st.tuples(st.sampled_from(["cubic", "polynomial"]), st.one_of(st.sampled_from([[0], [0, 1], [1], [5], [0, 0], []]), SCALARS),
              st.one_of(st.sampled_from([0.5, 1.0]), SCALARS), st.one_of(st.sampled_from([3, 5]), SCALARS)),
    max_size=2,
)


@BOUNDED
@given(
    M=MATRICES,
    K=MATRICES,
    elements=ELEMENTS,
    fixed_dofs=st.one_of(st.none(), SCALARS, st.lists(SCALARS, max_size=3)),
    cyclic=st.one_of(st.none(), SCALARS, st.tuples(SCALARS, SCALARS)),
    damping=st.one_of(
        st.none(),
        st.fixed_dictionaries({"rayleigh": st.lists(SCALARS, max_size=3)}),
        st.fixed_dictionaries({"modal": st.lists(SCALARS, max_size=3)}),
        st.fixed_dictionaries({"matrix": MATRICES}),
        SCALARS,
    ),
)
def test_model_is_built_or_refused(M, K, elements, fixed_dofs, cyclic, damping) -> None:
    try:
        nonlinear = [element(*e) for e in elements]
        model = nnm.Model(M, K, nonlinear, fixed_dofs=fixed_dofs, cyclic=cyclic, damping=damping)
    except (ValueError, TypeError):
        return
    assert model.dofs >= 1


@BOUNDED
@given(
    form=st.sampled_from(["dofs", "vector", "engine_order"]),
    dofs=st.one_of(st.sampled_from([0, [0], [0, 1], [7]]), SCALARS, st.lists(SCALARS, max_size=3)),
    amplitude=st.one_of(st.sampled_from([0.1, 1.0]), SCALARS),
    vector=st.one_of(st.sampled_from([[1.0, 0.0], [0.0, 0.0]]), st.lists(SCALARS, max_size=3), SCALARS),
    engine_order=st.one_of(st.sampled_from([0, 1, 99]), SCALARS),
    sector_dof=st.one_of(st.sampled_from([0, 1]), SCALARS),
    frequency=st.one_of(st.sampled_from([(1.2, 1.3)]), st.tuples(SCALARS, SCALARS), SCALARS),
)
def test_force_and_response_arguments_work_or_are_refused(
    form, dofs, amplitude, vector, engine_order, sector_dof, frequency
) -> None:
    kwargs = {
        "dofs": {"dofs": dofs, "amplitude": amplitude},
        "vector": {"vector": vector},
        "engine_order": {"engine_order": engine_order, "amplitude": amplitude, "sector_dof": sector_dof},
    }[form]
    model = nnm.two_dof(damping={"rayleigh": [0.02, 0.0]})
    try:
        force = nnm.Force(**kwargs)
        nnm.frequency_response(model, force, frequency, max_points=3, raise_on_failure=False)
    except (ValueError, TypeError):
        pass


def setting_values(key: str):
    typed = {
        "max_points": [1, 2, 0, -1, 10**12], "max_iterations": [1, 8, 0, -1], "target_iterations": [1, 3, 0, -1],
        "samples": [8, 32, 7, 0, 10**12], "at_energies": [[0.5], [], [math.nan], [-1.0]],
        "at_frequencies": [[1.5], [], [math.inf]], "output_dofs": [[0], [1, 1], [99], [-1]],
        "phase": ["zero-velocity", "flow-orthogonal", "none"], "jacobian": ["sensitivity", "finite-difference", "x"],
        "formulation": ["auto", "dense", "matrix-free"], "integrator": ["auto", "dop853", "gauss6", "radau5", "euler"],
        "symmetry": [True, False], "half_period": [True, False], "events": [True, False],
    }.get(key, [0.5, 1e-8, 0.0, -1.0, 1e-300, 1e308, math.nan, math.inf])
    return st.one_of(st.sampled_from(typed), SCALARS)


@BOUNDED
@given(data=st.data())
def test_backbone_settings_work_or_are_refused(data) -> None:
    keys = data.draw(st.lists(st.sampled_from(sorted(nnm.SETTINGS_KEYS)), max_size=2, unique=True))
    kwargs = {k: data.draw(setting_values(k), label=k) for k in keys}
    kwargs.setdefault("max_points", 3)
    kwargs.setdefault("energy_max", 1.0)
    try:
        nnm.backbone(nnm.duffing(), mode=0, raise_on_failure=False, **kwargs)
    except (ValueError, TypeError):
        pass


@BOUNDED
@given(data=st.data())
def test_response_settings_work_or_are_refused(data) -> None:
    keys = data.draw(st.lists(st.sampled_from(sorted(nnm.RESPONSE_SETTINGS_KEYS)), max_size=2, unique=True))
    kwargs = {k: data.draw(setting_values(k), label=k) for k in keys}
    kwargs.setdefault("max_points", 3)
    model = nnm.duffing(damping={"rayleigh": [0.02, 0.0]})
    try:
        nnm.frequency_response(model, nnm.Force(0, 0.1), (1.2, 1.3), raise_on_failure=False, **kwargs)
    except (ValueError, TypeError):
        pass


def test_integers_beyond_the_doubles_are_a_value_error() -> None:
    """What the properties found: an int too large for a float (10**400) raised OverflowError
    from ``float()`` (a force's amplitude, a damping ratio)."""
    import pytest

    with pytest.raises(ValueError, match="^amplitude must be a finite real number, got an integer beyond the float range$"):
        nnm.Force(0, 10**400)
    for form, damping in (("modal", {"modal": [10**400]}), ("rayleigh", {"rayleigh": [10**400, 0.0]})):
        message = f"^damping {form} must be a finite real number, got an integer beyond the float range$"
        with pytest.raises(ValueError, match=message):
            nnm.duffing(damping=damping)
