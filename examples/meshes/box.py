"""Writes the Gmsh meshes of the aluminium box 1 m x 0.1 m x 0.01 m that the examples and
tests read (`python3 box.py`, with the `gmsh` Python package):

- box-hex27.msh (ASCII) and box-hex27-binary.msh: a transfinite 10 x 1 x 1 mesh of 27-node
  hexahedra, the same discretisation as `family = "solid"` with its default `elements`;
- box-tet10.msh: an unstructured mesh of 10-node tetrahedra (mesh size 0.02 m).

Physical groups: the surfaces "root" (x = 0) and "tip" (x = 1 m), the volume "body"."""

import gmsh

EDGES = (1.0, 0.1, 0.01)


def write(path, hexahedra, binary=False, size=0.02, elements=(10, 1, 1)):
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add(path)
    volume = gmsh.model.occ.addBox(0, 0, 0, *EDGES)
    gmsh.model.occ.synchronize()
    faces = gmsh.model.getBoundary([(3, volume)], oriented=False)

    def face_at_x(x):
        return next(t for _, t in faces if abs(gmsh.model.occ.getCenterOfMass(2, t)[0] - x) < 1e-9)

    root, tip = face_at_x(0.0), face_at_x(EDGES[0])
    if hexahedra:
        for _, curve in gmsh.model.getEntities(1):
            a, b = (gmsh.model.getValue(0, p, []) for _, p in gmsh.model.getBoundary([(1, curve)], oriented=False))
            axis = max(range(3), key=lambda d: abs(a[d] - b[d]))
            gmsh.model.mesh.setTransfiniteCurve(curve, elements[axis] + 1)
        for _, surface in gmsh.model.getEntities(2):
            gmsh.model.mesh.setTransfiniteSurface(surface)
            gmsh.model.mesh.setRecombine(2, surface)
        gmsh.model.mesh.setTransfiniteVolume(volume)
        gmsh.option.setNumber("Mesh.SecondOrderIncomplete", 0)
    else:
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
    gmsh.model.addPhysicalGroup(2, [root], name="root")
    gmsh.model.addPhysicalGroup(2, [tip], name="tip")
    gmsh.model.addPhysicalGroup(3, [volume], name="body")
    gmsh.model.mesh.generate(3)
    gmsh.model.mesh.setOrder(2)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.option.setNumber("Mesh.Binary", 1 if binary else 0)
    gmsh.write(path)
    gmsh.finalize()


if __name__ == "__main__":
    write("box-hex27.msh", hexahedra=True)
    write("box-hex27-binary.msh", hexahedra=True, binary=True)
    write("box-tet10.msh", hexahedra=False)
