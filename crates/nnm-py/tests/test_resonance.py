"""Resonance forces of a backbone by energy balance (``resonance_force``, docs/method.md §21)
from Python, against the balance evaluated here with numpy on each point's motion sampled
independently (``Branch.motion``: 400 samples, DOP853 to 1e-12; the branch samples its own
motion at its integration tolerance, so the two agree to ~1e-9) and ``C`` built here from
``M`` and ``K``; and the bad input refused before anything is computed. The comparison with
forced response curves is in crates/nnm/tests/resonance.rs."""

from __future__ import annotations

import numpy as np
import pytest

import nnm


def balance(branch, i, C, F):
    """Eq. (111) on point ``i``'s motion sampled here: (amplitude, phase)."""
    motion = branch.motion(i, samples=400, tolerance=1e-12)
    t, v = motion.t[:-1], motion.v[:-1]
    period = motion.t[-1]
    omega = 2 * np.pi / period
    dissipated = period * np.mean(np.einsum("ki,ij,kj->k", v, C, v))
    in_phase = 2 * np.mean(v * np.cos(omega * t)[:, None], axis=0)
    quadrature = 2 * np.mean(v * np.sin(omega * t)[:, None], axis=0)
    p, q = F @ in_phase, -F @ quadrature
    return dissipated / (0.5 * period * np.hypot(p, q)), np.arctan2(q, p)


def test_the_resonance_force_of_every_point_is_the_energy_balance_of_its_motion():
    alpha, beta = 0.02, 0.005
    model = nnm.two_dof(cubic=0.5, damping={"rayleigh": [alpha, beta]})
    branch = nnm.backbone(model, 0, frequency_shift_max=0.2, resonance_force={"dofs": [1]})
    C = alpha * np.asarray(model.M) + beta * np.asarray(model.K)
    F = np.array([0.0, 1.0])
    assert len(branch) > 5
    for i in range(len(branch)):
        amplitude, phase = balance(branch, i, C, F)
        assert branch.resonance_force[i] == pytest.approx(amplitude, rel=1e-7)
        assert branch.resonance_phase[i] == pytest.approx(phase, abs=1e-7)
    frame = branch.to_pandas()
    assert list(frame.columns[-2:]) == ["resonance_force", "resonance_phase"]
    # An nnm.Force is taken as its shape: its amplitude does not scale the answer.
    again = nnm.backbone(model, 0, frequency_shift_max=0.2, resonance_force=nnm.Force(dofs=[1], amplitude=7.0))
    assert np.array_equal(again.resonance_force, branch.resonance_force)
    # Without resonance_force the columns are NaN.
    plain = nnm.backbone(model, 0, max_points=2)
    assert np.isnan(plain.resonance_force).all()


@pytest.mark.parametrize(
    ("model", "force", "message"),
    [
        (nnm.duffing(), {"dofs": [0]}, "resonance_force needs the model's damping"),
        (nnm.duffing(damping={"modal": [0.01]}), {"dofs": [3]}, "resonance_force: forced dof 3 is out of range (the model has 1 dofs)"),
        (nnm.duffing(damping={"modal": [0.01]}), {"vector": [0.0]}, "resonance_force: the resonance force's shape is zero"),
        (nnm.duffing(damping={"modal": [0.01]}), {"engine_order": 1, "sector_dof": 0}, "resonance_force: engine-order excitation needs a cyclic model"),
    ],
)
def test_bad_resonance_forces_are_refused_before_anything_runs(model, force, message):
    with pytest.raises(ValueError, match="^" + message.replace("(", r"\(").replace(")", r"\)")):
        nnm.backbone(model, 0, max_points=2, resonance_force=force)
