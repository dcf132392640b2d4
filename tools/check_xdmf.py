"""Reads a mesorheo snapshot series through its XDMF sidecar as a viewer does, and checks every
vector attribute of every frame against the H5MD datasets.

    python tools/check_xdmf.py OUT/snapshots.xdmf [--require-vtk]

Each vector attribute (velocity, force, image) must be declared `AttributeType="Vector"` with
N × 3 values in 2D as in 3D (ParaView and VTK read an N × 2 one as a single tuple of 2N
components). The XDMF is evaluated item by item (the HDF datasets through h5py, `HyperSlab`
selections, the `JOIN($0, $1, 0 * $0)` function that pads 2D vectors with a zero z) and compared
with the datasets, padded with zeros in 2D. When VTK is installed (`pip install vtk`), VTK's
vtkXdmfReader, the reader ParaView uses, reads every frame too and must give the same N × 3
arrays. Exits non-zero on any mismatch (the test suite runs it on a 2D and a 3D series).
"""
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import numpy as np

xdmf = Path(sys.argv[1])
root = ET.parse(xdmf).getroot()
files = {}


def dataset(item):
    name, path = item.text.strip().split(":", 1)
    f = files.setdefault(name, h5py.File(xdmf.parent / name, "r"))
    return f[path][()]


def evaluate(item):
    """The values of a DataItem of the subset mesorheo writes."""
    kind = item.get("ItemType", "Uniform")
    dims = tuple(int(d) for d in item.get("Dimensions").split())
    if kind == "HyperSlab":
        selection, source = list(item)
        start, stride, count = np.array(selection.text.split(), dtype=int).reshape(3, -1)
        data = evaluate(source)
        index = tuple(slice(a, a + s * c, s) for a, s, c in zip(start, stride, count))
        values = data[index].reshape(dims)
    elif kind == "Function":
        function = item.get("Function")
        assert function == "JOIN($0, $1, 0 * $0)", f"unexpected function {function}"
        x, y = (evaluate(c).reshape(-1) for c in item)
        values = np.stack([x, y, 0 * x], axis=1)
    else:
        assert item.get("Format") == "HDF", item.get("Format")
        values = dataset(item)
    assert values.shape == dims, f"{item.get('ItemType')}: declared {dims}, got {values.shape}"
    return values


grids = root.findall("./Domain/Grid/Grid")
assert grids, "no frames"
h5_name = grids[0].find("Geometry/DataItem/DataItem[@Format='HDF']").text.split(":")[0]
h5 = h5py.File(xdmf.parent / h5_name, "r")
fluid = h5["particles/fluid"]
n = len(fluid["id"])
dimension = fluid["position/value"].shape[2]
vectors = set()
for frame, grid in enumerate(grids):
    for attribute in grid.findall("Attribute"):
        name = attribute.get("Name")
        if name == "id":
            continue
        assert attribute.get("AttributeType") == "Vector", (name, attribute.get("AttributeType"))
        (item,) = list(attribute)
        assert item.get("Dimensions") == f"{n} 3", (name, item.get("Dimensions"))
        got = evaluate(item)
        stored = fluid[f"{name}/value"][frame]
        expected = np.zeros((n, 3), dtype=stored.dtype)
        expected[:, :dimension] = stored
        assert np.array_equal(got, expected), f"{name}, frame {frame}"
        vectors.add(name)
    positions = evaluate(grid.find("Geometry/DataItem"))
    assert np.array_equal(positions, fluid["position/value"][frame]), f"positions, frame {frame}"
print(f"XDMF OK: {len(grids)} frames of {n} particles ({dimension}D), vectors N × 3: "
      + ", ".join(sorted(vectors)))

try:
    from vtkmodules.vtkIOXdmf2 import vtkXdmfReader
    from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline
    from vtkmodules.util.numpy_support import vtk_to_numpy
except ImportError:
    if "--require-vtk" in sys.argv:
        sys.exit("VTK is not installed (pip install vtk; ./run test installs it into .venv)")
    print("VTK not installed: the XDMF was checked against its own description only")
    sys.exit(0)
reader = vtkXdmfReader()
reader.SetFileName(str(xdmf))
reader.UpdateInformation()
times = reader.GetOutputInformation(0).Get(vtkStreamingDemandDrivenPipeline.TIME_STEPS())
assert len(times) == len(grids), (len(times), len(grids))
for frame, t in enumerate(times):
    reader.UpdateTimeStep(t)
    grid = reader.GetOutputDataObject(0)
    assert grid.GetNumberOfPoints() == n
    for name in sorted(vectors):
        array = grid.GetPointData().GetArray(name)
        got = vtk_to_numpy(array)
        assert got.shape == (n, 3), f"VTK reads {name} as {got.shape}"
        expected = np.zeros((n, 3))
        expected[:, :dimension] = fluid[f"{name}/value"][frame]
        assert np.array_equal(got, expected), f"VTK: {name}, frame {frame}"
print(f"VTK's XdmfReader: {len(times)} frames, every vector N × 3 as in the file")
