#!/usr/bin/python3
"""Independent check of nlmodes VTU output with meshio (not our own reader).

Usage: scripts/check_vtu.py FILE.vtu [FIELD ...]
Checks: the file opens; cells are tetra (VTK 10) or tetra10 (VTK 24); for tetra10, every edge node
sits at the midpoint of VTK's edge for that slot (VTK order: 4:(0,1) 5:(1,2) 6:(0,2) 7:(0,3) 8:(1,3)
9:(2,3)) up to the curvature of the mesh, i.e. is far closer to its own edge than to the swapped one;
the named point fields exist and are finite. Prints one summary line; exits non-zero on failure.
"""
import sys

import meshio
import numpy as np

VTK_EDGES = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)]


def main() -> int:
    path, fields = sys.argv[1], sys.argv[2:]
    mesh = meshio.read(path)
    kinds = [c.type for c in mesh.cells]
    if kinds not in (["tetra"], ["tetra10"]):
        print(f"{path}: unexpected cell types {kinds}")
        return 1
    cells = mesh.cells[0].data
    pts = mesh.points
    if kinds == ["tetra10"]:
        mids = np.stack([0.5 * (pts[cells[:, a]] + pts[cells[:, b]]) for a, b in VTK_EDGES], axis=1)
        nodes = pts[cells[:, 4:10]]
        # dist[e, i, j]: distance from the node in slot 4+i to the midpoint of VTK edge j
        dist = np.linalg.norm(nodes[:, :, None, :] - mids[:, None, :, :], axis=3)
        nearest = dist.argmin(axis=2)
        wrong = np.count_nonzero(nearest != np.arange(6)[None, :])
        # Each edge node must be nearest the midpoint of its own VTK edge (gmsh curves edge nodes
        # onto the surfaces, but never by as much as half an edge); with nodes 8 and 9 swapped,
        # every element fails this.
        if wrong:
            print(f"{path}: {wrong} edge nodes of {6 * len(cells)} are not nearest their VTK edge")
            return 1
    for f in fields:
        if f not in mesh.point_data:
            print(f"{path}: missing point field {f} (have {sorted(mesh.point_data)})")
            return 1
        if not np.all(np.isfinite(mesh.point_data[f])):
            print(f"{path}: field {f} has non-finite values")
            return 1
    print(f"{path}: ok, {len(pts)} points, {len(cells)} {kinds[0]} cells, fields {sorted(mesh.point_data)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
