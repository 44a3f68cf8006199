"""Results through the bindings against references computed independently here: the exact
period of the Duffing oscillator (complete elliptic integral, scipy), and Table 1 of the paper
(Vakakis-type bladed disk, printed to three decimals)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import ellipk

import nnm


def duffing_period(w0: float, alpha: float, amplitude: np.ndarray) -> np.ndarray:
    """Exact period of ``u'' + w0^2 u + alpha u^3 = 0`` released from rest at ``amplitude``:
    ``T = 4 K(m) / sqrt(w0^2 + alpha A^2)``, ``m = alpha A^2 / (2 (w0^2 + alpha A^2))``
    (scipy's ``ellipk`` takes the parameter ``m = k^2``)."""
    stiff = w0**2 + alpha * amplitude**2
    return 4.0 * ellipk(alpha * amplitude**2 / (2.0 * stiff)) / np.sqrt(stiff)


@pytest.mark.parametrize("w0, alpha", [(1.0, 1.0), (2.0, 0.5)])
def test_duffing_backbone_has_the_exact_elliptic_period(w0: float, alpha: float) -> None:
    branch = nnm.backbone(
        nnm.duffing(natural_frequency=w0, cubic=alpha), 0, frequency_shift_max=1.0, tolerance=1e-10
    )
    assert branch.stop_kind == "frequency-shift-max"
    assert len(branch) > 10
    amplitude = branch.state0[:, 0]
    assert np.all(branch.state0[:, 1] == 0.0)  # zero-velocity phase: released from rest
    exact = duffing_period(w0, alpha, amplitude)
    # Shooting tolerance 1e-10 with the integrator a thousand times tighter: the period is
    # right to ~1e-10; 1e-8 leaves room while a wrong model or period is off by far more.
    assert np.max(np.abs(branch.period / exact - 1.0)) < 1e-8
    np.testing.assert_allclose(branch.frequency, 2 * np.pi / branch.period, rtol=1e-14)
    # The energy of a motion released from rest is the potential at the amplitude.
    np.testing.assert_allclose(
        branch.energy, 0.5 * w0**2 * amplitude**2 + 0.25 * alpha * amplitude**4, rtol=1e-12
    )
    # The last point lies on the limit, twice the linear frequency (eq. (26a): to 1e-10).
    assert abs(branch.frequency[-1] / w0 - 2.0) < 1e-9
    # A conservative 1-dof motion is stable: both multipliers on the unit circle.
    assert branch.stable.all()
    np.testing.assert_allclose(np.abs(branch.multipliers), 1.0, atol=1e-6)


def test_requested_energies_and_frequencies_get_exact_points() -> None:
    """``at_energies`` / ``at_frequencies`` (docs/method.md eq. (26b)): a point on each value,
    labelled, with the exact elliptic period there; a value beyond the limit is reported."""
    w0, alpha = 1.0, 1.0
    branch = nnm.backbone(
        nnm.duffing(natural_frequency=w0, cubic=alpha),
        0,
        energy_max=5.0,
        tolerance=1e-10,
        at_energies=[0.5, 2.0, 50.0],
        at_frequencies=[1.3],
    )
    assert branch.stop_kind == "energy-max"
    for label, values, column in [("at_energy", [0.5, 2.0], branch.energy), ("at_frequency", [1.3], branch.frequency)]:
        on = branch.label == label
        np.testing.assert_allclose(column[on], values, rtol=1e-10)
    exact = duffing_period(w0, alpha, branch.state0[:, 0])
    assert np.max(np.abs(branch.period / exact - 1.0)) < 1e-8
    assert branch.label[-1] == "energy_max" and abs(branch.energy[-1] / 5.0 - 1.0) < 1e-10
    assert [(m["label"], m["value"]) for m in branch.missed_requests] == [("at_energy", 50.0)]
    assert list(branch.to_pandas()["label"][branch.label != ""]) == list(branch.label[branch.label != ""])


# Table 1 of the paper: natural frequencies (rad/s) of the 30-sector bladed disk by nodal
# circles n (rows) and nodal diameters d (columns 0..15), three decimals.
TABLE_1 = np.array(
    [
        [0.000, 0.183, 0.363, 0.536, 0.700, 0.850, 0.985, 1.103, 1.202, 1.282, 1.346, 1.394, 1.428, 1.452, 1.465, 1.470],
        [2.082, 2.084, 2.092, 2.104, 2.123, 2.147, 2.178, 2.215, 2.258, 2.304, 2.350, 2.394, 2.431, 2.460, 2.478, 2.485],
    ]
)


def test_bladed_disk_modes_are_table_1_of_the_paper() -> None:
    modes = nnm.modes(nnm.bladed_disk())
    assert len(modes) == 60 and modes.shapes.shape == (60, 60)
    assert np.all(np.diff(modes.frequencies) >= 0)
    seen = np.zeros_like(TABLE_1, dtype=int)
    for frequency, label, pattern in zip(modes.frequencies, modes.labels, modes.patterns):
        n, d = label
        assert abs(frequency - TABLE_1[n, d]) <= 5e-4 + 1e-12, (label, frequency)
        seen[n, d] += 1
        # Single modes at d = 0 and d = N/2; every other d is a cos/sin pair.
        assert (pattern is None) == (d in (0, 15)), (label, pattern)
    expected = np.where(np.isin(np.arange(16), [0, 15]), 1, 2)
    assert (seen == expected).all()
    assert modes.rigid.sum() == 1 and modes.labels[int(np.argmax(modes.rigid))] == (0, 0)


def test_bladed_disk_mode_1_0_is_the_duffing_oscillator_of_its_blades() -> None:
    """In mode (1,0) every sector moves alike with its centre of mass at rest, so the blade's
    stretch ``u = x - X`` obeys ``u'' + w0^2 u + alpha u^3 = 0`` with
    ``w0^2 = k (1/m + 1/M)``, ``alpha = knl (1/m + 1/M)`` (defaults: k = 1, knl = 0.1,
    m = 0.3, M = 1): its period is the elliptic one, and the energy ``N (k A^2/2 + knl A^4/4)``."""
    k, knl, m, M, sectors = 1.0, 0.1, 0.3, 1.0, 30
    model = nnm.bladed_disk(sectors=sectors, disk_mass=M, blade_mass=m, blade_stiffness=k, cubic=knl)
    branch = nnm.backbone(model, (1, 0), frequency_shift_max=0.2, tolerance=1e-9, events=False)
    inverse_mass = 1 / m + 1 / M
    w0, alpha = np.sqrt(k * inverse_mass), knl * inverse_mass
    assert abs(branch.linear_frequency - w0) < 1e-12 * w0
    x0 = branch.displacement0
    stretch = x0[:, 1::2] - x0[:, 0::2]  # blade minus disk, every sector
    np.testing.assert_allclose(stretch, stretch[:, :1] * np.ones(sectors), rtol=1e-8)
    amplitude = np.abs(stretch[:, 0])
    assert np.max(np.abs(branch.period / duffing_period(w0, alpha, amplitude) - 1.0)) < 1e-7
    np.testing.assert_allclose(
        branch.energy, sectors * (0.5 * k * amplitude**2 + 0.25 * knl * amplitude**4), rtol=1e-7
    )


def test_mode_1_0_of_a_large_disk_from_its_label_with_every_multiplier() -> None:
    """1,500 sectors (3,000 dofs): mode (1,0) lies beyond the lowest modes computed at that
    size and comes from the sector problem by its label; shot matrix-free in the full space
    (``symmetry=False``), every point is the Duffing oscillator of its blades and stable, with
    all ``2n`` Floquet multipliers from the sector harmonics (docs/method.md eqs. (53b), (76e))."""
    k, knl, m, M, sectors = 1.0, 0.1, 0.3, 1.0, 1500
    model = nnm.bladed_disk(sectors=sectors)
    branch = nnm.backbone(model, (1, 0), frequency_shift_max=0.2, symmetry=False, events=False)
    inverse_mass = 1 / m + 1 / M
    w0, alpha = np.sqrt(k * inverse_mass), knl * inverse_mass
    assert abs(branch.linear_frequency - w0) < 1e-12 * w0
    x0 = branch.displacement0
    amplitude = np.abs(x0[:, 1] - x0[:, 0])
    assert np.max(np.abs(branch.period / duffing_period(w0, alpha, amplitude) - 1.0)) < 1e-8
    assert branch.frequency[-1] > 1.199 * w0
    assert branch.stable.all()
    assert branch.multipliers.shape == (len(branch.energy), 2 * 2 * sectors)
