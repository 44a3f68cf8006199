#!/usr/bin/env python3
"""Checks a `.vtu` file that nnm wrote against VTK itself (`pip install vtk`; not part of the
test suite, which does not install VTK): every cell's points lie where VTK's own parametric
coordinates of that cell type put them — on straight-sided elements, the map fitted to the
cell's vertices (affine for lines and tetrahedra, trilinear for hexahedra) — and the cells'
volumes (a beam's lengths), as VTK integrates them, sum to the expected volume (length).

    scripts/check-vtk.py out/vtk/mode-1-0/frame-000.vtu 0.001   # the default box: 1 x 0.1 x 0.01

A point order that differs from VTK's moves points off their parametric places by a fraction
of the cell (the check prints the worst offset relative to the cell's size and fails above
1e-9); the volumes catch inverted cells."""

import sys

import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy


def vertex_map(cell_type: int, x: np.ndarray):
    if cell_type == vtk.VTK_TRIQUADRATIC_HEXAHEDRON:
        def trilinear(p):
            r, s, t = p
            w = [(1 - r) * (1 - s) * (1 - t), r * (1 - s) * (1 - t), r * s * (1 - t), (1 - r) * s * (1 - t),
                 (1 - r) * (1 - s) * t, r * (1 - s) * t, r * s * t, (1 - r) * s * t]
            return sum(wi * x[i] for i, wi in enumerate(w))
        return trilinear
    if cell_type == vtk.VTK_QUADRATIC_TETRA:
        return lambda p: (1 - p[0] - p[1] - p[2]) * x[0] + p[0] * x[1] + p[1] * x[2] + p[2] * x[3]
    if cell_type == vtk.VTK_LINE:
        return lambda p: (1 - p[0]) * x[0] + p[0] * x[1]
    raise SystemExit(f"unexpected cell type {cell_type}")


def main() -> None:
    path, expected_volume = sys.argv[1], float(sys.argv[2])
    reader = vtk.vtkXMLUnstructuredGridReader()
    reader.SetFileName(path)
    reader.Update()
    grid = reader.GetOutput()
    worst = 0.0
    for c in range(grid.GetNumberOfCells()):
        cell = grid.GetCell(c)
        n = cell.GetNumberOfPoints()
        parametric = cell.GetParametricCoords()
        x = np.array([cell.GetPoints().GetPoint(i) for i in range(n)])
        place = vertex_map(cell.GetCellType(), x)
        size = np.ptp(x, axis=0).max()
        for i in range(n):
            worst = max(worst, np.abs(place(parametric[3 * i:3 * i + 3]) - x[i]).max() / size)
    sizes = vtk.vtkCellSizeFilter()
    sizes.SetInputData(grid)
    sizes.Update()
    lines = grid.GetNumberOfCells() and grid.GetCellType(0) == vtk.VTK_LINE
    volume = vtk_to_numpy(sizes.GetOutput().GetCellData().GetArray("Length" if lines else "Volume")).sum()
    displacement = grid.GetPointData().GetArray("displacement")
    print(f"{grid.GetNumberOfCells()} cells, worst point offset {worst:.1e} of a cell, "
          f"volume {volume:.6e} (expected {expected_volume:.6e}), "
          f"displacement: {displacement.GetNumberOfComponents() if displacement else 'missing'} components")
    if worst > 1e-9 or abs(volume / expected_volume - 1) > 1e-9 or displacement is None:
        raise SystemExit("check failed")


if __name__ == "__main__":
    main()
