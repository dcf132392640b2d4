#!/usr/bin/env python3
"""Cost per step of a 3D DPD suspension at the thesis's φ = N_C/(N_C + N_S) = 0.2 against the
solvent alone with the same number of particles (issue #44; docs/performance.md "Suspended
colloids: the bodies' overhead").

Three variants of cases/dpd_suspension_viscosity_3d.toml (the thesis's T4 fluid, 8³ box,
Lees–Edwards γ̇ = 1, Δt = 0.005), run interleaved rigid, free, solvent, rigid, …, REPS runs
each, one rank × one thread, references off:

  rigid    85 octahedra (φ = 0.2: 2 048 solvent + 510 constituents = 2 558 particles), H = 1600
  free     the same particles with the ties cut (H = 1e-9): the bodies' table, sums and exact
           reduction still run, the constituents are a plain denser fluid
  solvent  no [fluid.colloids]: 2 558 particles at density 2558/512 (random start), the same
           number of particles and the same total number density as the suspension

Prints, per run and as medians, the loop's wall time per step (the summary's loop_seconds /
steps), the process's CPU time per step (user + system, set-up included), and the phase timers
(summary phase_seconds): forces, the engine's rigid-bodies pass (spring and lever sums, exact
reduction, body update, site placement), neighbour lists, diagnostics.

Usage: tools/suspension_bench.py [STEPS] [REPS]   (MESORHEO_BIN, default target/release/mesorheo)
"""
import json
import os
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
steps = int(sys.argv[1]) if len(sys.argv) > 1 else 2000
reps = int(sys.argv[2]) if len(sys.argv) > 2 else 3
binary = os.environ.get("MESORHEO_BIN", os.path.join(ROOT, "target", "release", "mesorheo"))
case = os.path.join(ROOT, "cases", "dpd_suspension_viscosity_3d.toml")
text = open(case).read()
# The solvent alone: the stock case without its [fluid.colloids] section.
solvent = text.split("\n[fluid.colloids]\n")[0] + "\n[integrator]\n" + text.split("\n[integrator]\n")[1]
common = [f"run.equilibration={steps // 10}", "reference=[]",
          'diagnostics.observables=["viscosity", "temperature"]']
variants = {
    "rigid": (case, ["fluid.colloids.count=85"]),
    "free": (case, ["fluid.colloids.count=85", "fluid.colloids.spring_stiffness=1e-9"]),
    "solvent": (None, ['particles.lattice="random"', f"particles.density={2558 / 512}"]),
}
wall, cpu, share = {}, {}, {}
with tempfile.TemporaryDirectory() as work:
    solvent_file = os.path.join(work, "solvent.toml")
    with open(solvent_file, "w") as f:
        f.write(solvent)
    for rep in range(reps):
        for name, (file, sets) in variants.items():
            out = os.path.join(work, f"{name}.{rep}")
            cmd = [binary, "run", file or solvent_file, "--out", out, "-q", "-t", "1", "--no-plots",
                   "--steps", str(steps)]
            for s in common + sets:
                cmd += ["--set", s]
            before = os.times()
            subprocess.run(cmd, check=True, stderr=subprocess.DEVNULL)
            after = os.times()
            with open(os.path.join(out, "summary.json")) as f:
                s = json.load(f)
            w = s["loop_seconds"] / s["steps"]
            c = ((after.children_user + after.children_system)
                 - (before.children_user + before.children_system)) / s["steps"]
            wall.setdefault(name, []).append(w)
            cpu.setdefault(name, []).append(c)
            ph = s["phase_seconds"]
            bodies = sum(q["seconds"] for q in ph.get("passes", []) if q["pass"] == "rigid bodies")
            share.setdefault(name, []).append(bodies / s["loop_seconds"])
            print(f"{name} run {rep + 1}: {s['particles']} particles, loop {1e3 * w:.2f} ms/step (wall), "
                  f"process {1e3 * c:.2f} ms/step (CPU); phases per step: forces {1e3 * ph['forces'] / s['steps']:.2f} ms "
                  f"(of which the rigid-bodies pass {1e3 * bodies / s['steps']:.3f} ms, {100 * bodies / s['loop_seconds']:.2f} % "
                  f"of the loop), neighbour {1e3 * ph['neighbour'] / s['steps']:.2f} ms, diagnostics "
                  f"{1e3 * ph['diagnostics'] / s['steps']:.3f} ms, rebuilds {ph['rebuilds']}", flush=True)
for label, d in (("loop wall", wall), ("process CPU", cpu)):
    med = {k: statistics.median(v) for k, v in d.items()}
    for k, v in d.items():
        print(f"{label} {k}: median {1e3 * med[k]:.2f} ms/step ({', '.join(f'{1e3 * x:.2f}' for x in v)}); "
              f"/ solvent {med[k] / med['solvent']:.3f}")
for k, v in share.items():
    print(f"rigid-bodies pass {k}: median {100 * statistics.median(v):.2f} % of the loop")
