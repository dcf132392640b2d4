#!/usr/bin/env python3
"""One run of cases/dpd_cylinder_array_2d.toml with `--set` overrides, and its drag against
Hasimoto's square array (issue #44, T6–T7; docs/validation.md "What moves the drag"): the mean
fluid velocity U, F/(ηU) with F = N_f m g and η = 100.06 ± 0.11 (the fluid's Lees–Edwards
viscosity, `./run validate cylinder_array`), the exclusion radius (g < 0.01, about the
constituents' mean and about the sites), Hasimoto's F/(ηU) at it, and a_H, the radius whose
Hasimoto drag is the measured one. Uses tools/validate.py's `exclusion_radius` and
`hasimoto_square_drag`; RDF frames after step 2 000.

Usage: tools/cylinder_drag_scan.py NAME STEPS [KEY=VALUE ...]
  CELL=20 tools/cylinder_drag_scan.py L20 14000 'box.lengths=[20.0, 20.0]' 'fluid.body_force=[0.15, 0.0]'
The run is kept in $MESORHEO_SCAN_DIR/cyl_NAME (default /tmp) and reused when it has finished;
MESORHEO_BIN names the binary (default target/release/mesorheo). CELL is the square cell's side
(default 10; the fluid count is 8 CELL², the case's density).
"""
import json
import math
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tools"))
import validate as v  # noqa: E402

name, steps, sets = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
out = os.path.join(os.environ.get("MESORHEO_SCAN_DIR", "/tmp"), f"cyl_{name}")
if not os.path.exists(os.path.join(out, "summary.json")):
    cmd = [os.environ.get("MESORHEO_BIN", os.path.join(ROOT, "target", "release", "mesorheo")), "run",
           os.path.join(ROOT, "cases", "dpd_cylinder_array_2d.toml"), "--out", out, "-q", "-t", "1",
           "--no-plots", "--steps", str(steps)]
    for s in sets:
        cmd += ["--set", s]
    subprocess.run(cmd, check=True)
with open(os.path.join(out, "summary.json")) as f:
    s = json.load(f)
o = s["observables"]
cell = float(os.environ.get("CELL", "10"))
n_fluid, mass = int(8 * cell * cell), 0.5
g = 0.6
for st in sets:
    if st.startswith("fluid.body_force="):
        g = float(st.split("[")[1].split(",")[0])
eta, eta_se = 100.06, 0.11
u = o["momentum_x"]["mean"] / (n_fluid * mass)
u_se = o["momentum_x"]["stderr"] / (n_fluid * mass)
k = n_fluid * mass * g / (eta * u)
k_se = k * math.hypot(u_se / u, eta_se / eta)
radii = {}
for about in (True, False):
    radii[about] = v.exclusion_radius(os.path.join(out, "snapshots.h5"), n_fluid, (cell / 2, cell / 2),
                                      cell, 2000, about_constituents=about)[:2]
r = radii[True][0]
ref = v.hasimoto_square_drag(r, cell)


def hydrodynamic_radius(drag):
    lo, hi = 0.01, 3.0
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if v.hasimoto_square_drag(mid, cell) < drag else (lo, mid)
    return 0.5 * (lo + hi)


a_h = hydrodynamic_radius(k)
a_h_se = 0.5 * (hydrodynamic_radius(k + k_se) - hydrodynamic_radius(k - k_se))
print(f"{name}: {sets} steps {s['steps']} wall {s['wall_seconds']:.0f} s, k_BT {o['temperature']['mean']:.4f}")
print(f"  U = {u:.4f} ± {u_se:.4f}, F/(ηU) = {k:.3f} ± {k_se:.3f}, exclusion radius {r:.2f} "
      f"(about the sites {radii[False][0]:.2f}), Hasimoto there {ref:.3f}, measured/Hasimoto − 1 = "
      f"{100 * (k / ref - 1):+.1f} ± {100 * k_se / ref:.1f} %, a_H = {a_h:.3f} ± {a_h_se:.3f}")
print("  g(r): " + ", ".join(f"{rr:.2f}: {gv:.3f}" for rr, gv in radii[True][1] if 0.1 < rr < 1.2))
