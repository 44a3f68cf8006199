"""The solid family from Python: ``nnm.solid`` with the job file's keys, and a model's
``internal_force`` and ``tangent_stiffness`` checked against an independent numpy
implementation of the St. Venant–Kirchhoff hexahedron written from the continuum formulas
(``P = F S`` over the whole displacement, not the library's linear/nonlinear split)."""

import itertools

import numpy as np
import pytest

import nnm


def _svk_integrand(gradient: np.ndarray, u: np.ndarray, E: float, nu: float) -> np.ndarray:
    """``∇N_a · (F S)ᵀ`` for every node ``a`` at one point: the St. Venant–Kirchhoff force
    density, ``F = I + uᵀ ∇N``, ``S = λ tr(E) I + 2μ E``, ``E = ½ (FᵀF − I)``."""
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    mu = E / (2 * (1 + nu))
    F = np.eye(3) + u.T @ gradient
    strain = 0.5 * (F.T @ F - np.eye(3))
    S = lam * np.trace(strain) * np.eye(3) + 2 * mu * strain
    return gradient @ (F @ S).T


def _svk_hex27_force(coordinates: np.ndarray, u: np.ndarray, E: float, nu: float) -> np.ndarray:
    """Internal force of one 27-node hexahedron, 3x3x3 Gauss: f_a = ∫ F S ∇N_a dV."""
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
        force += w[a] * w[b] * w[c] * np.linalg.det(jacobian) * _svk_integrand(gradient, u, E, nu)
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


MESHES = __import__("pathlib").Path(__file__).resolve().parents[3] / "examples" / "meshes"


def _one_tet10_msh(path, vertices: np.ndarray) -> np.ndarray:
    """Writes one straight-sided 10-node tetrahedron as a Gmsh MSH 4.1 ASCII file, its face
    through vertices 0, 2, 3 in the physical group "root"; returns its nodes in file order
    (Gmsh's: vertices, then the midpoints of the edges 0-1, 1-2, 0-2, 0-3, 2-3, 1-3)."""
    edges = [(0, 1), (1, 2), (0, 2), (0, 3), (2, 3), (1, 3)]
    nodes = np.vstack([vertices] + [0.5 * (vertices[i] + vertices[j]) for i, j in edges])
    lines = ["$MeshFormat", "4.1 0 8", "$EndMeshFormat", "$PhysicalNames", "2",
             '2 1 "root"', '3 2 "body"', "$EndPhysicalNames", "$Entities", "0 0 1 1",
             "1 0 0 0 1 1 1 1 1 0", "1 0 0 0 1 1 1 1 2 0", "$EndEntities",
             "$Nodes", "1 10 1 10", "3 1 0 10", *[str(t) for t in range(1, 11)],
             *[" ".join(repr(float(c)) for c in p) for p in nodes], "$EndNodes",
             "$Elements", "2 2 1 2", "2 1 9 1", "1 1 3 4 7 9 8",
             "3 1 11 1", "2 " + " ".join(str(t) for t in range(1, 11)), "$EndElements"]
    path.write_text("\n".join(lines) + "\n")
    return nodes


def _svk_tet10_force(nodes: np.ndarray, u: np.ndarray, E: float, nu: float) -> np.ndarray:
    """Internal force of one straight-sided 10-node tetrahedron, f_a = ∫ F S ∇N_a dV, by a
    conical product of 4-point Gauss rules (the collapsed cube: exact to degree 7, the
    integrand's degree is 4). Each mid-edge node's function is found from the geometry: the
    node at the midpoint of vertices i and j has 4 L_i L_j."""
    vertices = nodes[:4]
    edge_of = []
    for p in nodes[4:]:
        edge_of.append(next((i, j) for i in range(4) for j in range(i + 1, 4)
                            if np.allclose(p, 0.5 * (vertices[i] + vertices[j]))))
    jacobian = (vertices[1:] - vertices[0]).T  # X = X0 + J ξ
    inverse = np.linalg.inv(jacobian)
    dL = np.vstack([-np.ones(3), np.eye(3)]) @ inverse  # ∇L_i, rows
    g, w = np.polynomial.legendre.leggauss(4)
    g, w = 0.5 * (g + 1), 0.5 * w
    force = np.zeros_like(u)
    for (a, r), (b, s), (c, t) in itertools.product(enumerate(g), repeat=3):
        xi = np.array([r, s * (1 - r), t * (1 - r) * (1 - s)])  # the collapsed cube
        weight = w[a] * w[b] * w[c] * (1 - r) ** 2 * (1 - s) * np.linalg.det(jacobian)
        L = np.array([1 - xi.sum(), *xi])
        gradient = np.array([(4 * L[i] - 1) * dL[i] for i in range(4)]
                            + [4 * (L[i] * dL[j] + L[j] * dL[i]) for i, j in edge_of])
        force += weight * _svk_integrand(gradient, u, E, nu)
    return force


def test_tet10_from_a_gmsh_file_matches_an_independent_implementation(tmp_path) -> None:
    vertices = np.array([[0.0, 0.0, 0.0], [0.11, 0.01, 0.0], [0.02, 0.09, 0.01], [0.01, 0.02, 0.08]])
    nodes = _one_tet10_msh(tmp_path / "tet.msh", vertices)
    model = nnm.solid(mesh=tmp_path / "tet.msh", clamped="root")
    held = [0, 2, 3, 6, 7, 8]  # on the face through vertices 0, 2, 3
    free = [a for a in range(10) if a not in held]
    assert model.dofs == 3 * len(free)
    rng = np.random.default_rng(11)
    x = 3e-3 * rng.standard_normal(model.dofs)
    u = np.zeros((10, 3))
    u[free] = x.reshape(-1, 3)
    expected = _svk_tet10_force(nodes, u, 70e9, 0.33)[free].ravel()
    f = model.internal_force(x)
    assert np.abs(f - expected).max() < 1e-10 * np.abs(expected).max()
    assert np.abs(f - model.K @ x).max() > 1e-3 * np.abs(f).max()  # far from linear


def test_a_gmsh_hex27_box_is_the_structured_box() -> None:
    structured = nnm.solid()
    for name in ("box-hex27.msh", "box-hex27-binary.msh"):
        meshed = nnm.solid(mesh=MESHES / name, clamped=["root", "tip"])
        assert meshed.dofs == structured.dofs
        w, w0 = meshed.modes().frequencies[:4], structured.modes().frequencies[:4]
        assert np.abs(w / w0 - 1).max() < 1e-8


def test_meshes_refuse_bad_input() -> None:
    mesh = MESHES / "box-tet10.msh"
    with pytest.raises(ValueError, match="describes a structured box"):
        nnm.solid(mesh=mesh, clamped="root", box=[1.0, 0.1, 0.01])
    with pytest.raises(ValueError, match="needs `clamped`"):
        nnm.solid(mesh=mesh)
    with pytest.raises(ValueError, match="not a physical group of the mesh .it has: body, root, tip."):
        nnm.solid(mesh=mesh, clamped="roots")
    with pytest.raises(ValueError, match="cannot read"):
        nnm.solid(mesh=MESHES / "missing.msh", clamped="root")


def test_to_vtk_writes_a_period_of_frames(tmp_path) -> None:
    import xml.etree.ElementTree as ElementTree

    model = nnm.solid(box=(0.2, 0.02, 0.01), elements=(2, 1, 1), clamped="x0")
    branch = nnm.backbone(model, 0, max_points=2)
    branch.to_vtk(-1, tmp_path / "motion.pvd", frames=8)
    collection = ElementTree.parse(tmp_path / "motion.pvd").getroot()
    steps = collection.findall("./Collection/DataSet")
    assert [float(s.get("timestep")) for s in steps] == pytest.approx(branch.period[-1] * np.arange(8) / 8)
    for step in steps:
        grid = ElementTree.parse(tmp_path / step.get("file")).getroot()
        piece = grid.find("./UnstructuredGrid/Piece")
        assert piece.get("NumberOfPoints") == str(5 * 3 * 3)
        assert piece.get("NumberOfCells") == "2"
        assert piece.find("./PointData/DataArray").get("Name") == "displacement"
    # The motion behind the frames closes on itself: the stiff model's sampled period.
    motion = branch.motion(-1, samples=8, tolerance=1e-8)
    assert np.abs(motion.x[-1] - motion.x[0]).max() < 1e-5 * np.abs(motion.x).max()
    with pytest.raises(ValueError, match="must end in .pvd"):
        branch.to_vtk(0, tmp_path / "motion.vtu")
    with pytest.raises(ValueError, match="frames must be at least 1"):
        branch.to_vtk(0, tmp_path / "m.pvd", frames=0)
    duffing = nnm.backbone(nnm.duffing(), 0, max_points=2)
    with pytest.raises(ValueError, match="draws on a model's nodes"):
        duffing.to_vtk(0, tmp_path / "d.pvd")
