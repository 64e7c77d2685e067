#!/usr/bin/python3
"""Independent check of nlmodes VTU/PVD output with meshio (not our own reader).

Usage: scripts/check_vtu.py FILE.vtu [FIELD ...]
       scripts/check_vtu.py --series FILE.pvd
       scripts/check_vtu.py --series FILE.xdmf
Checks of a VTU: the file opens; cells are tetra (VTK 10) or tetra10 (VTK 24); for tetra10, every
edge node sits at the midpoint of VTK's edge for that slot (VTK order: 4:(0,1) 5:(1,2) 6:(0,2)
7:(0,3) 8:(1,3) 9:(2,3)) up to the curvature of the mesh, i.e. is far closer to its own edge than
to the swapped one; the named point fields exist and are finite, except the contact fields
(radial_gap_m, contact_force_n), which must be finite exactly on the contact nodes (contact_node
= 1) and NaN elsewhere, with contact_force_n >= 0. Prints one summary line; exits non-zero on
failure.
With --series: every data set of the PVD collection, or every step of the XDMF time series (read
by meshio.xdmf.TimeSeriesReader, HDF5 through h5py), is checked as above (with the fields
displacement_m, radial_gap_m, contact_force_n), all on the same points and cells; the time values
must start at 0 and be equally spaced. Prints one JSON line: points, cells, frames, times, the
largest |displacement| of each frame, the number of contact nodes, the range of the gap and the
largest contact force over the frames.
"""
import json
import os
import sys
import xml.etree.ElementTree as ET

import meshio
import meshio.xdmf
import numpy as np

VTK_EDGES = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)]
CONTACT_FIELDS = ("radial_gap_m", "contact_force_n")


class CheckError(Exception):
    pass


def check_vtu(path, fields):
    return check_mesh(path, meshio.read(path), fields)


def check_mesh(path, mesh, fields):
    kinds = [c.type for c in mesh.cells]
    if kinds not in (["tetra"], ["tetra10"]):
        raise CheckError(f"{path}: unexpected cell types {kinds}")
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
            raise CheckError(f"{path}: {wrong} edge nodes of {6 * len(cells)} are not nearest their VTK edge")
    for f in fields:
        if f not in mesh.point_data:
            raise CheckError(f"{path}: missing point field {f} (have {sorted(mesh.point_data)})")
        data = np.asarray(mesh.point_data[f], dtype=float)
        if f in CONTACT_FIELDS:
            if "contact_node" not in mesh.point_data:
                raise CheckError(f"{path}: {f} without the contact_node field")
            on = np.asarray(mesh.point_data["contact_node"]) == 1
            if not on.any():
                raise CheckError(f"{path}: no contact node")
            if not np.all(np.isfinite(data[on])):
                raise CheckError(f"{path}: {f} is not finite on every contact node")
            if not np.all(np.isnan(data[~on])):
                raise CheckError(f"{path}: {f} is not NaN off the contact nodes")
            if f == "contact_force_n" and np.any(data[on] < 0):
                raise CheckError(f"{path}: negative contact force")
        elif not np.all(np.isfinite(data)):
            raise CheckError(f"{path}: field {f} has non-finite values")
    return mesh, kinds[0], cells


def pvd_frames(pvd):
    """(time, meshio mesh, name) of every data set of a PVD collection."""
    root = ET.parse(pvd).getroot()
    sets = root.findall("./Collection/DataSet")
    if not sets:
        raise CheckError(f"{pvd}: no DataSet")
    base = os.path.dirname(pvd)
    for s in sets:
        path = os.path.join(base, s.get("file"))
        yield float(s.get("timestep")), meshio.read(path), path


def xdmf_frames(xdmf):
    """(time, meshio mesh, name) of every step of an XDMF time series."""
    with meshio.xdmf.TimeSeriesReader(xdmf) as reader:
        points, cells = reader.read_points_cells()
        if reader.num_steps == 0:
            raise CheckError(f"{xdmf}: no time step")
        for k in range(reader.num_steps):
            t, point_data, _ = reader.read_data(k)
            yield t, meshio.Mesh(points, cells, point_data=point_data), f"{xdmf} step {k}"


def check_series(series):
    frames = list(xdmf_frames(series) if series.endswith((".xdmf", ".xmf")) else pvd_frames(series))
    times = [t for t, _, _ in frames]
    steps = np.diff(times)
    if times[0] != 0.0 or np.any(steps <= 0) or np.ptp(steps) > 1e-9 * max(times):
        raise CheckError(f"{series}: time values {times} do not start at 0 with a uniform step")
    fields = ["displacement_m", "radial_gap_m", "contact_force_n"]
    shape = None
    summary = {"times": times, "frames": len(frames), "max_displacement": []}
    gap_lo, gap_hi, force_hi = np.inf, -np.inf, 0.0
    for _, frame, name in frames:
        mesh, kind, cells = check_mesh(name, frame, fields)
        this = (len(mesh.points), len(cells), kind)
        if shape is not None and this != shape:
            raise CheckError(f"{series}: {name} has {this}, the first frame {shape}")
        shape = this
        u = np.asarray(mesh.point_data["displacement_m"], dtype=float)
        summary["max_displacement"].append(float(np.linalg.norm(u, axis=1).max()))
        on = np.asarray(mesh.point_data["contact_node"]) == 1
        gap = np.asarray(mesh.point_data["radial_gap_m"], dtype=float)[on]
        force = np.asarray(mesh.point_data["contact_force_n"], dtype=float)[on]
        gap_lo, gap_hi = min(gap_lo, gap.min()), max(gap_hi, gap.max())
        force_hi = max(force_hi, force.max())
        summary["contact_nodes"] = int(on.sum())
    summary.update(points=shape[0], cells=shape[1], cell_type=shape[2],
                   gap_min=float(gap_lo), gap_max=float(gap_hi), force_max=float(force_hi))
    return summary


def main() -> int:
    try:
        if sys.argv[1] == "--series":
            print(json.dumps(check_series(sys.argv[2])))
            return 0
        path, fields = sys.argv[1], sys.argv[2:]
        mesh, kind, cells = check_vtu(path, fields)
    except CheckError as e:
        print(e)
        return 1
    print(f"{path}: ok, {len(mesh.points)} points, {len(cells)} {kind} cells, fields {sorted(mesh.point_data)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
