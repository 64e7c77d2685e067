"""Opens XDMF series with every reader ParaView offers for them and says what each read.

Usage: pvpython tests/paraview_readers.py SERIES.xdmf [...]   (absolute paths)

For each series, the readers are those ParaView's reader factory lists for the file (the
choice the GUI's "Open With" dialog offers) whose name says XDMF: in ParaView 5.11
XdmfReader, Xdmf3ReaderS and Xdmf3ReaderT. Each reader is asked for every time step it
announces (proxy.UpdatePipeline(t), as the GUI does with the animation time) and its output
is compared with the HDF5 arrays the XML names for that frame, read with h5py: the points,
the first cell, and every point field (NaN where the file has NaN, equal values elsewhere).
Prints one line `RESULT <json>`: {series: {"readers": [...], "xml_times": [...],
"read": {reader: {"times": [...], "frames": [{...}, ...]}}}}.
"""
import json
import os
import sys
import xml.etree.ElementTree as ET

import h5py
import numpy as np
import paraview.simple  # noqa: F401  (opens the built-in connection)
from paraview import servermanager as sm
from vtk.numpy_interface import dataset_adapter as dsa


def offered_readers(path):
    """(group, name) of the XDMF readers ParaView's reader factory offers for `path`."""
    factory = sm.vtkSMProxyManager.GetProxyManager().GetReaderFactory()
    if factory.GetNumberOfRegisteredPrototypes() == 0:
        factory.UpdateAvailableReaders()
    found = factory.GetPossibleReaders(path, sm.ActiveConnection.Session)
    triples = [(found.GetString(i), found.GetString(i + 1))
               for i in range(0, found.GetLength(), 3)]
    return [(g, n) for g, n in triples if "xdmf" in n.lower()]


def heavy(path, item):
    """The array a DataItem `file.h5:/dataset` names, read with h5py."""
    name, dataset = item.text.strip().split(":", 1)
    with h5py.File(os.path.join(os.path.dirname(path), name), "r") as f:
        return np.array(f[dataset])


def frames_of(path):
    """Per frame of the XML: time, and the arrays of its geometry, topology and attributes."""
    grids = ET.parse(path).getroot().iter("Grid")
    out = []
    for g in grids:
        if g.get("GridType") != "Uniform":
            continue
        out.append({
            "time": float(g.find("Time").get("Value")),
            "points": heavy(path, g.find("Geometry/DataItem")),
            "cells": heavy(path, g.find("Topology/DataItem")),
            "fields": {a.get("Name"): heavy(path, a.find("DataItem"))
                       for a in g.findall("Attribute")},
        })
    return out


def same(read, stored):
    """Equal values, NaN at the same places."""
    read = np.asarray(read, dtype=np.float64).reshape(stored.shape)
    stored = stored.astype(np.float64)
    nan = np.isnan(stored)
    return bool((np.isnan(read) == nan).all() and (read[~nan] == stored[~nan]).all())


def read_frame(proxy, t, frame):
    proxy.UpdatePipeline(t)
    grid = sm.Fetch(proxy)
    d = dsa.WrapDataObject(grid)
    n = int(grid.GetNumberOfPoints())
    report = {"points": n, "cells": int(grid.GetNumberOfCells())}
    if n == 0:
        return report
    ids = grid.GetCell(0).GetPointIds()
    names = list(d.PointData.keys())
    report.update({
        "cell_type": int(grid.GetCellType(0)),
        "first_cell_as_stored":
            [ids.GetId(i) for i in range(ids.GetNumberOfIds())] == frame["cells"][0].tolist(),
        "points_as_stored": same(np.array(d.Points), frame["points"]),
        "fields": sorted(names),
        "fields_as_stored": sorted(k for k, v in frame["fields"].items()
                                   if k in names and same(np.array(d.PointData[k]), v)),
    })
    if "contact_node" in names:
        on = np.array(d.PointData["contact_node"]) == 1
        f = np.array(d.PointData["contact_force_n"])
        g = np.array(d.PointData["radial_gap_m"])
        u = np.array(d.PointData["displacement_m"])
        report.update({
            "contact": int(on.sum()),
            "nan_off_contact": bool(np.isnan(f[~on]).all() and np.isnan(g[~on]).all()),
            "finite_on_contact": bool(np.isfinite(f[on]).all() and np.isfinite(g[on]).all()),
            "max_u": float(np.linalg.norm(u, axis=1).max()),
        })
    return report


def main(paths):
    result = {}
    for path in paths:
        frames = frames_of(path)
        by_time = {f["time"]: f for f in frames}
        readers = offered_readers(path)
        entry = {"readers": [n for _, n in readers],
                 "xml_times": [f["time"] for f in frames], "read": {}}
        for group, name in readers:
            proxy = sm._getPyProxy(sm.ProxyManager().SMProxyManager.NewProxy(group, name))
            if "FileNames" in proxy.ListProperties():
                proxy.FileNames = [path]
            else:
                proxy.FileName = path
            proxy.UpdatePipelineInformation()
            times = [float(t) for t in proxy.TimestepValues]
            entry["read"][name] = {
                "times": times,
                "frames": [read_frame(proxy, t, by_time[t]) if t in by_time else {"points": -1}
                           for t in times],
            }
        result[path] = entry
    print("RESULT " + json.dumps(result))


if __name__ == "__main__":
    main(sys.argv[1:])
