"""Reads a mesorheo snapshot series through its XDMF sidecar as a viewer does, and checks every
attribute of every frame of every particle group against the H5MD datasets.

    python tools/check_xdmf.py OUT/snapshots.xdmf [--require-vtk]

The sidecar holds one temporal collection per particle group (`fluid`, and `wall`,
`inclusion` where the scene has them), each reading `/particles/<group>/...` of the H5MD file;
every group of the file must have its grid, with the group's particle count. Each vector
attribute (velocity, force, image, unwrapped_position) must be `AttributeType="Vector"` with
N × 3 values in 2D as in 3D (ParaView and VTK read an N × 2 one as a single tuple of 2N
components); each symmetric tensor (polymer_stress, conformation) `Tensor6` with N × 6 values
(xx, xy, xz, yy, yz, zz; a 2D tensor padded with zeros); each scalar (density, pressure,
species, id) `Scalar` with N values. The XDMF is evaluated item by item (the HDF datasets
through h5py, `HyperSlab` selections, the `JOIN` functions that pad 2D vectors and tensors with
zeros) and compared with the datasets. When VTK is installed (`pip install vtk`), VTK's
vtkXdmfReader, the reader ParaView uses, reads every frame too and must give the same arrays
(tensors expanded to 3 × 3). Exits non-zero on any mismatch (the test suite runs it on 2D and
3D series).
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
        assert function in (
            "JOIN($0, $1, 0 * $0)",
            "JOIN($0, $1, (0 * $0), $2, (0 * $0), (0 * $0))",
        ), f"unexpected function {function}"
        columns = [evaluate(c).reshape(-1) for c in item]
        parts = function[len("JOIN("):-1].split(", ")
        values = np.stack(
            [columns[int(p[1:])] if p.startswith("$") else 0 * columns[0] for p in parts], axis=1
        )
    else:
        assert item.get("Format") == "HDF", item.get("Format")
        values = dataset(item)
    assert values.shape == dims, f"{item.get('ItemType')}: declared {dims}, got {values.shape}"
    return values


def padded_tensor(stored, dimension):
    """N × 6 (xx, xy, xz, yy, yz, zz) of a packed upper triangle."""
    if dimension == 3:
        return stored
    out = np.zeros((stored.shape[0], 6), dtype=stored.dtype)
    out[:, [0, 1, 3]] = stored
    return out


h5 = None
collections = root.findall("./Domain/Grid")
assert collections, "no particle groups"
expected = {}  # (group, frame, name) -> (kind, values)
kinds = {"Vector": set(), "Tensor6": set(), "Scalar": set()}
groups = []
frames = None
for collection in collections:
    group = collection.get("Name")
    assert collection.get("CollectionType") == "Temporal", group
    grids = collection.findall("Grid")
    assert grids, f"{group}: no frames"
    frames = len(grids) if frames is None else frames
    assert len(grids) == frames, f"{group}: {len(grids)} frames, another group {frames}"
    if h5 is None:
        h5_name = grids[0].find("Geometry/DataItem/DataItem[@Format='HDF']").text.split(":")[0]
        h5 = h5py.File(xdmf.parent / h5_name, "r")
        dimension = h5["particles/fluid/position/value"].shape[2]
    g = h5[f"particles/{group}"]
    n = len(g["id"])
    groups.append((group, n))
    for frame, grid in enumerate(grids):
        assert int(grid.find("Topology").get("NumberOfElements")) == n, (group, frame)
        for attribute in grid.findall("Attribute"):
            name = attribute.get("Name")
            kind = attribute.get("AttributeType")
            (item,) = list(attribute)
            got = evaluate(item)
            if name in ("id", "species"):
                stored = g[name][()]
            else:
                stored = g[f"{name}/value"][frame]
            if kind == "Vector":
                assert item.get("Dimensions") == f"{n} 3", (group, name, item.get("Dimensions"))
                want = np.zeros((n, 3), dtype=stored.dtype)
                want[:, :dimension] = stored
            elif kind == "Tensor6":
                assert item.get("Dimensions") == f"{n} 6", (group, name, item.get("Dimensions"))
                assert stored.shape == (n, dimension * (dimension + 1) // 2), (name, stored.shape)
                want = padded_tensor(stored, dimension)
            else:
                assert kind == "Scalar", (group, name, kind)
                assert item.get("Dimensions") == f"{n}", (group, name, item.get("Dimensions"))
                want = stored
            assert np.array_equal(got, want), f"{group}: {name}, frame {frame}"
            expected[(group, frame, name)] = (kind, want)
            if name != "id":
                kinds[kind].add(name)
        positions = evaluate(grid.find("Geometry/DataItem"))
        assert np.array_equal(positions, g["position/value"][frame]), f"{group}: positions, frame {frame}"
in_file = sorted(k for k in h5["particles"].keys())
assert sorted(name for name, _ in groups) == in_file, f"groups: XDMF {groups}, file {in_file}"
total = sum(n for _, n in groups)
print(
    f"XDMF OK: {frames} frames of {total} particles ({dimension}D), vectors N × 3: "
    + ", ".join(sorted(kinds["Vector"]))
    + "; tensors N × 6: " + ", ".join(sorted(kinds["Tensor6"]))
    + "; scalars: " + ", ".join(sorted(kinds["Scalar"]))
    + "; groups: " + ", ".join(f"{name} ({n})" for name, n in groups)
)

try:
    from vtkmodules.vtkIOXdmf2 import vtkXdmfReader
    from vtkmodules.vtkCommonDataModel import vtkCompositeDataSet
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
assert len(times) == frames, (len(times), frames)


def blocks(data):
    """(group name, grid) of the reader's output: one grid, or a multiblock of one per group."""
    if data.IsA("vtkMultiBlockDataSet"):
        out = []
        for b in range(data.GetNumberOfBlocks()):
            name = data.GetMetaData(b).Get(vtkCompositeDataSet.NAME())
            out.append((name, data.GetBlock(b)))
        return out
    return [(groups[0][0], data)]


for frame, t in enumerate(times):
    reader.UpdateTimeStep(t)
    seen = blocks(reader.GetOutputDataObject(0))
    assert sorted(name for name, _ in seen) == sorted(name for name, _ in groups), seen
    for group, grid in seen:
        n = dict(groups)[group]
        assert grid.GetNumberOfPoints() == n, (group, grid.GetNumberOfPoints(), n)
        for (g, f, name), (kind, want) in expected.items():
            if g != group or f != frame:
                continue
            got = vtk_to_numpy(grid.GetPointData().GetArray(name))
            if kind == "Tensor6":
                # VTK expands a Tensor6 (xx, xy, xz, yy, yz, zz) to the full 3 × 3.
                want = want[:, [0, 1, 2, 1, 3, 4, 2, 4, 5]]
            assert got.shape == want.shape, f"VTK reads {group}: {name} as {got.shape}, not {want.shape}"
            assert np.array_equal(got, want), f"VTK: {group}: {name}, frame {frame}"
print(
    f"VTK's XdmfReader: {len(times)} frames, groups {', '.join(name for name, _ in groups)}, "
    "every vector N × 3, tensor N × 9 (Tensor6 expanded) and scalar N as in the file"
)
