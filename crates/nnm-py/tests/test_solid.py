"""The solid family from Python: ``nnm.solid`` with the job file's keys, and a model's
``internal_force`` and ``tangent_stiffness`` checked against an independent numpy
implementation of the St. Venant–Kirchhoff hexahedron written from the continuum formulas
(``P = F S`` over the whole displacement, not the library's linear/nonlinear split)."""

import itertools

import numpy as np
import pytest

import nnm


def _svk_hex27_force(coordinates: np.ndarray, u: np.ndarray, E: float, nu: float) -> np.ndarray:
    """Internal force of one 27-node hexahedron, 3x3x3 Gauss: f_a = ∫ F S ∇N_a dV."""
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    mu = E / (2 * (1 + nu))
    g, w = np.polynomial.legendre.leggauss(3)
    nodes_1d = np.array([-1.0, 0.0, 1.0])

    def lagrange(x: float) -> tuple[np.ndarray, np.ndarray]:
        values, slopes = np.empty(3), np.empty(3)
        for i in range(3):
            others = [nodes_1d[j] for j in range(3) if j != i]
            denominator = np.prod([nodes_1d[i] - o for o in others])
            values[i] = np.prod([x - o for o in others]) / denominator
            slopes[i] = sum(x - o for o in others) / denominator
        return values, slopes

    force = np.zeros_like(u)
    for (a, xa), (b, xb), (c, xc) in itertools.product(enumerate(g), repeat=3):
        (lx, dx), (ly, dy), (lz, dz) = lagrange(xa), lagrange(xb), lagrange(xc)
        reference_gradient = np.array([
            [dx[i] * ly[j] * lz[k], lx[i] * dy[j] * lz[k], lx[i] * ly[j] * dz[k]]
            for k in range(3) for j in range(3) for i in range(3)
        ])  # local node i + 3 (j + 3 k)
        jacobian = coordinates.T @ reference_gradient
        gradient = reference_gradient @ np.linalg.inv(jacobian)
        H = u.T @ gradient
        F = np.eye(3) + H
        strain = 0.5 * (F.T @ F - np.eye(3))
        S = lam * np.trace(strain) * np.eye(3) + 2 * mu * strain
        force += w[a] * w[b] * w[c] * np.linalg.det(jacobian) * gradient @ (F @ S).T
    return force


def test_solid_force_and_tangent_match_an_independent_implementation() -> None:
    size = (0.2, 0.1, 0.05)
    model = nnm.solid(box=size, elements=(1, 1, 1), clamped="x0")
    assert model.dofs == 3 * (27 - 9)
    nodes = np.array([[i * size[0] / 2, j * size[1] / 2, k * size[2] / 2]
                      for k in range(3) for j in range(3) for i in range(3)])
    free = [n for n in range(27) if n % 3 != 0]  # node i + 3 (j + 3 k), face x = 0 clamped
    rng = np.random.default_rng(7)
    x = 2e-3 * rng.standard_normal(model.dofs)
    u = np.zeros((27, 3))
    u[free] = x.reshape(-1, 3)
    expected = _svk_hex27_force(nodes, u, 70e9, 0.33)[free].ravel()
    f = model.internal_force(x)
    assert np.abs(f - expected).max() < 1e-10 * np.abs(expected).max()
    assert np.abs(f - model.K @ x).max() > 1e-3 * np.abs(f).max()  # far from linear

    tangent = model.tangent_stiffness(x)
    assert tangent.shape == (model.dofs, model.dofs)
    h = 1e-7
    for j in range(0, model.dofs, 7):
        step = np.zeros(model.dofs)
        step[j] = h
        column = (model.internal_force(x + step) - model.internal_force(x - step)) / (2 * h)
        assert np.abs(tangent[:, [j]].toarray().ravel() - column).max() < 1e-6 * np.abs(column).max()


def test_solid_takes_the_job_files_keys_and_refuses_bad_ones() -> None:
    model = nnm.solid(elements=[2, 1, 1], clamped=["x0", "x1"])
    assert model.dofs == 3 * (45 - 18)
    assert model.family == "solid"
    with pytest.raises(ValueError, match="poisson_ratio"):
        nnm.solid(poisson_ratio=0.5)
    with pytest.raises(ValueError, match="not a face of the box"):
        nnm.solid(clamped="w0")
    with pytest.raises(ValueError, match="has 3 entries, the model has"):
        model.internal_force(np.zeros(3))
    with pytest.raises(ValueError, match="not finite"):
        model.tangent_stiffness(np.full(model.dofs, np.nan))
