#!/usr/bin/env python3
"""Opens every VTK file of a cleave output directory with VTK's own readers
and checks what ParaView will see: the .pvd collections name files that
exist, every .vtp/.vti reads without error, its point count is the one the
file declares, vectors (velocity) have 3 components and symmetric tensors
(stress, strain) 6 in VTK's order xx yy zz xy yz xz, with the out-of-plane
shear components yz and xz zero, and every array has a tuple per point.

Needs the `vtk` wheel (`pip install vtk`); not part of CI.

    python3 docs/scripts/check_vtk.py OUT_DIR

Exits 0 when every file passes, 1 with the failures listed otherwise.
"""

import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import vtk
from vtk.util.numpy_support import vtk_to_numpy

VECTORS = {"velocity": 3}
TENSORS = {"stress": 6, "strain": 6}


def check_arrays(path, data, failures):
    """Checks the point data of one data set read by VTK."""
    n = data.GetNumberOfPoints()
    if n == 0:
        failures.append(f"{path}: no points")
    pd = data.GetPointData()
    for k in range(pd.GetNumberOfArrays()):
        a = pd.GetArray(k) or pd.GetAbstractArray(k)
        name = a.GetName()
        comps = a.GetNumberOfComponents()
        if a.GetNumberOfTuples() != n:
            failures.append(f"{path}: {name} has {a.GetNumberOfTuples()} tuples for {n} points")
        want = VECTORS.get(name) or TENSORS.get(name) or 1
        if comps != want:
            failures.append(f"{path}: {name} has {comps} components, not {want}")
            continue
        if name in VECTORS:
            z = vtk_to_numpy(a)[:, 2]
            if (z != 0).any():
                failures.append(f"{path}: {name} has a non-zero z component in 2D")
        if name in TENSORS:
            t = vtk_to_numpy(a)
            if (t[:, 4] != 0).any() or (t[:, 5] != 0).any():
                failures.append(f"{path}: {name} has non-zero yz or xz in 2D")
    return n


def main(out):
    out = Path(out)
    failures = []
    checked = 0
    for pvd in sorted(out.glob("*.pvd")):
        for ds in ET.parse(pvd).getroot().iter("DataSet"):
            if not (out / ds.get("file")).is_file():
                failures.append(f"{pvd}: names {ds.get('file')}, which is missing")
    for path in sorted(out.glob("*.vtp")) + sorted(out.glob("*.vti")):
        reader = (
            vtk.vtkXMLPolyDataReader()
            if path.suffix == ".vtp"
            else vtk.vtkXMLImageDataReader()
        )
        errors = []
        # a reader reports a malformed file through events, not its result
        for event in ("ErrorEvent", "WarningEvent"):
            reader.AddObserver(event, lambda obj, ev: errors.append(ev))
        reader.SetFileName(str(path))
        reader.Update()
        if errors or reader.GetErrorCode() != 0:
            failures.append(f"{path}: VTK reported {errors or reader.GetErrorCode()} reading it")
            continue
        data = reader.GetOutput()
        n = check_arrays(path, data, failures)
        if path.suffix == ".vtp" and data.GetNumberOfVerts() != n:
            failures.append(f"{path}: {data.GetNumberOfVerts()} vertices for {n} points")
        checked += 1
    print(f"{checked} VTK files checked with VTK {vtk.vtkVersion.GetVTKVersion()}")
    for f in failures:
        print("FAIL", f)
    return 1 if failures or checked == 0 else 0


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    sys.exit(main(sys.argv[1]))
