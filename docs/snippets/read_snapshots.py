"""Read a mesorheo snapshot series with h5py (and check its XDMF sidecar).

    python docs/snippets/read_snapshots.py OUT/snapshots.h5

Prints the frames of the fluid group, the mean velocity of the last frame and the sampled viscosity, then checks
that every HDF5 dataset the XDMF sidecar (OUT/snapshots.xdmf) points to exists with the
declared dimensions. Exits non-zero on any mismatch (the test suite runs it).
"""
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import numpy as np

path = Path(sys.argv[1])
with h5py.File(path, "r") as f:
    print("H5MD version", f["h5md"].attrs["version"].tolist(), "by", f["h5md/creator"].attrs["name"])
    fluid = f["particles/fluid"]
    ids = fluid["id"][:]
    assert np.array_equal(ids, np.arange(len(ids))), "rows are in global-id order"
    pos = fluid["position"]
    steps = pos["step"][:]
    print(f"{len(ids)} particles, {len(steps)} frames at steps {steps.tolist()}")
    x = pos["value"][-1]  # [N, D] positions of the last frame
    v = fluid["velocity/value"][-1]
    print("box", fluid["box/edges"][:], "boundary", list(fluid["box"].attrs["boundary"]))
    print("Lees-Edwards offset of the last frame", fluid["box/lees_edwards_offset/value"][-1])
    print("mean velocity of the last frame", v.mean(axis=0))
    if "observables/viscosity" in f:
        eta = f["observables/viscosity/value"][:]
        print(f"viscosity: {eta.mean():.4f} over {len(eta)} samples")
    print("case:", f["parameters"].attrs["case"].splitlines()[0])

    # The XDMF sidecar must point at datasets that exist, with the declared dimensions.
    xdmf = path.with_suffix(".xdmf")
    root = ET.parse(xdmf).getroot()
    # One temporal collection per particle group (fluid, and wall or inclusion where present).
    groups = [g.get("Name") for g in root.findall("./Domain/Grid")]
    assert sorted(groups) == sorted(f["particles"].keys()), (groups, list(f["particles"].keys()))
    grids = root.findall("./Domain/Grid[@Name='fluid']/Grid")
    assert len(grids) == len(steps), f"{len(grids)} XDMF grids, {len(steps)} frames"
    checked = 0
    for item in root.iter("DataItem"):
        if item.get("Format") != "HDF":
            continue
        file_name, dataset = item.text.strip().split(":", 1)
        assert file_name == path.name, file_name
        dims = tuple(int(d) for d in item.get("Dimensions").split())
        assert dataset in f, f"XDMF points to missing {dataset}"
        assert f[dataset].shape == dims, f"{dataset}: XDMF says {dims}, file has {f[dataset].shape}"
        checked += 1
    for grid, step in zip(grids, steps):
        assert grid.get("Name") == f"fluid_step_{step}", grid.get("Name")
    print(f"XDMF sidecar OK ({len(grids)} frames, {checked} dataset references, groups {', '.join(groups)})")
