#!/usr/bin/env python3
"""Long validations of mesorheo (`./run validate [NAME]`); prints Markdown for docs/validation.md
and writes plots to docs/ when matplotlib is available. Exits 1 when any recorded check misses
(`verdict`), naming each miss; every verdict goes to out/validate/results.json
(MESORHEO_VALIDATE_JSON). A target without verdicts prints tables only, and the summary says so.

  kt_vs_dt       k_BT and p of the Groot–Warren fluid vs Δt for λ = 0.5 and 0.65 (3D, ρ = 3)
  viscosity      η, N₁, N₂ of Lees–Edwards shear vs run length (stability of the estimate)
  stock          every stock case with a [[reference]] on 2 ranks: all checks must pass
                 (MESORHEO_STOCK_ONLY=a.toml,b.toml: only those)
  viscometric    Hookean dumbbells in steady shear at Wi = 0.1, 1, 10, 2D and 3D: η_p = Gλ,
                 Ψ₁ = 2Gλ², Ψ₂ = 0 within 3 standard errors, with 3σ ≤ 1 % (~15 min on 2 cores)
  sph            SPH start-up Couette: the error at each time for the thesis's scheme and its
                 repairs, and against the lattice spacing with the wall time of each run;
                 start-up Poiseuille to the steady state at supports 2.5Δ and 3Δ (~5 min)
  sph_convergence  SPH start-up Couette (t = 0.1) and Poiseuille (t = 0.4): the error against
                 Δt and against Δ for each integrator, with the observed orders and the wall
                 time of each run, and docs/sph_convergence.png (~20 min on 2 cores)
  maxwell        corotational Maxwell SPH: Lees–Edwards steady shear at the thesis's 12 De
                 (η and Ψ₁ against the corotational Jeffreys solution, docs/maxwell_shear.png),
                 and the channel relaxation of sin(πy), cases (a) and (b), linear variant and
                 full model, against the linearised solution (~1.5 h on 2 cores; MESORHEO_MAXWELL_RUNS=DIR
                 keeps each run in DIR/de_<De>/ and reuses a finished one of the same settings)
  inclusion      SPH rigid inclusions in Lees–Edwards shear: the Newtonian cell at R = 0.1, 0.15,
                 0.2 and Δ = 0.02, 0.01 (mean fluid stress against 1/(1 − πR²), composite
                 viscosity against dilute theory, torque against Stokes), and the Maxwell matrix
                 at De = 0.01, 0.1 against the thesis's linear-in-concentration fit (~35 min)
  maxwell_convergence  the Maxwell shear case at De = 1: the errors of η and N₁ against Δt and
                 against the resolution Δ, with the cost of each run (~15 min)
  maxwell_couette  Oldroyd-B start-up Couette at λ = 0.05, 0.2, 1 and β = 0.1, 0.5 against the
                 series: the max error over the listed times against Δ and Δt, the stock scheme
                 (Lucy 3Δ, Morris cap 6) beside the issue's (2.5Δ, cap 2) (~30 min on one thread)
  maxwell_couette_causes  the same flow at λ = 0.05, β = 0.1: the issue's setup and one change
                 at a time (Δt, Morris cap, gradient estimate, wall treatment, support, c₀, Δ)
                 (~3 min on one thread)
  maxwell_stability  the largest stable Δt of the Maxwell shear case against De, by bisection
                 (2000 steps survive = stable), beside the limit `check` predicts (~10 min)
  connffessit_shear  SPH particles carrying dumbbells in Lees–Edwards shear: Hookean at
                 Wi = 0.5, 1, 3 against Oldroyd-B beside the UCM SPH fluid; the error and cost
                 against N_d and the gradient estimate; FENE (b = 50) against the homogeneous-flow
                 ensembles at the same Wi (~15 min)
  msph_channel   the paper's channel (Murashima–Taniguchi): MSPH with mirror walls, pairwise SPH
                 and the paper's literal walls against the start-up series (Newtonian, UCM
                 λ = 10 and 1000), the UCM error against Δt, and CONNFFESSIT at N_d = 250, 1000,
                 4000, 10⁴ against the UCM run, with costs; the Newtonian channel in 3D
                 against 2D at t = 50 (~55 min on 2 cores)
  weak_order     the weak order of each dumbbell scheme measured on the scheme itself: Hookean
                 steady shear at Wi = 1 (exact η_p = Gλ, Ψ₁ = 2Gλ²), the bias of Ψ₁ against Δt
                 for Euler–Maruyama and Heun, log-log slopes with error bars (~10 min)
  fene_table     FENE dumbbells (semi-implicit) in steady shear at b = 10, 50, Wi = 1, 10, 2D and
                 3D: η_p, Ψ₁ and ⟨|Q|²⟩ against the Fokker–Planck solution of
                 tools/fene_fokker_planck.py, in standard errors; docs/fene_table.csv (~10 min)
  transverse_current  η(k) of Nguyen's ch. 4 solvent by transverse-current correlations against
                 the thesis, and a Lees–Edwards η of the same fluid; docs/transverse_current.png
                 (~1.5 h; MESORHEO_TCAF_OUT=DIR reuses a finished run of the case)
  kt_vs_dt_low_mass  Nguyen's Table 3.1 (m = 0.01 Couette): k_BT against Δt for velocity Verlet,
                 explicit and with the exponential thermostat (~4 min)
  dpd_stability  the DPD stability maps of docs/stability/dpd_maps.txt (`mesorheo stability`,
                 1000-step trials): CSV and PNG to docs/stability/, and the tables of
                 docs/validation.md "Stability maps against `check`" (~15 min on 2 cores)
  connffessit_channel_seeds  cases/connffessit_channel_2d.toml at seeds 1–4: the seed spread its
                 header and the README quote, each seed against its 7.5 % (~5 min)
  bddfs_t2       the thesis's T2, relative (Ellero Sec. 5.4): 2D FENE b = 50 in shear at
                 γ̇ = 5 and 0.01, BDDFS at n_c = 40, 80, 200, 1000 against Brownian dynamics with
                 the same N_d; the error against n_c and against Δt (the ΔQ²/Δt law), memory
                 per particle and CPU per dumbbell-step (~10 min on 2 cores)
  default_weissenberg  the default scene at Wi = 2 (p_t = 50) and Wi = 4 (p_t = 200, c₀ = 20,
                 Δt = 7.5·10⁻⁴), seeds 1–3: the momentum-flux η within 1 % and N₁ within 1.3 % of
                 Oldroyd-B on every seed (~10 min on 2 quiet cores)
  bddfs_memory   the issue's "at equal accuracy (η within 1 %), ≥ 50× less memory per particle,
                 ≤ +20 % CPU" at N_d = 10⁶: T2 with 4 particles × 10⁶ dumbbells, BD against
                 BDDFS at Δt = 0.04, 0.08 λ and n_c = 200–400 (~4 min CPU on 1 core)
  suspension_viscosity  rigid octahedral colloids in DPD Lees–Edwards shear at 19, 38, 85 bodies
                 beside their free twins (springs cut) and the solvent alone: η/η_S against
                 Einstein's 1 + 2.5φ for the particle fraction φ_p and for φ_h with the Stokes
                 radius from the drag on a fixed body (Hasimoto's cubic array), and what rigidity
                 adds over the free twin (~60 CPU-min; MESORHEO_SUSPENSION_RUNS=DIR,
                 MESORHEO_SUSPENSION_STEPS=N)
  cylinder_array  fixed cylinders in a driven 2D flow (cases/dpd_cylinder_array_2d.toml at
                 F_e = 0.3 and 0.1): F/(ηU) against Hasimoto's square array at the exclusion
                 radius from the RDF, η from Lees–Edwards shear, and a 20 × 20 cell for
                 Hasimoto's cell-size dependence (~70 CPU-min; MESORHEO_CYLINDER_RUNS=DIR)
  report         docs/validation_results/verdicts.md from the per-target records that every
                 target with checks writes to docs/validation_results/<target>.json
  dpd_held_out4  the held-out DPD maps, docs/stability/dpd_held_out4.txt (14 maps × seeds 1–3,
                 committed before the current limit was evaluated there; the second and third
                 held-out sets are folded into dpd_stability): the same table and verdicts
                 (~10 min on 2 quiet cores)
  generic_polymer_t1  the thesis's T1 (cases/generic_polymer_shear_2d.toml, GENERIC polymer
                 particle with its transport velocity) at the seven rates γ̇λ_H = 10/2^k,
                 k = 0..6: η_p and Ψ₁ against the Hookean n k_BTλ_H and 2η_pλ_H, within 3 % and
                 within 4.5σ (~25 min per rate on one loaded core, ~3 h in all;
                 MESORHEO_GP_RATES=1.25,10 runs only those)
  generic_model_a  the GENERIC particle's Model A (100 explicit dumbbells per particle,
                 studies/cases/generic_polymer_model_a_shear_2d.toml) against the coupled
                 CONNFFESSIT case in the same flow (cases/connffessit_shear_2d.toml), seeds 1–6:
                 η_p and N₁ the same within 4σ of the seed scatter with the corrected gradient,
                 and resolved as different with the particle's own (~8 min on 2 cores)
  dpd_held_out6  the sixth held-out set, docs/stability/dpd_held_out6.txt (12 maps, 39 points:
                 2D ideal gas and weak repulsion at strong friction, soft-started, raw and
                 lattice starts; committed before the stab6 margin existed): the same table and
                 verdicts (~30 min on 2 loaded cores)
  fuzz           the long fuzz of the stock case files through `mesorheo check` (the ignored test
                 tests/check_fuzz.rs::long_fuzz_through_check; MESORHEO_FUZZ_VARIANTS per case,
                 default here 100 000, ~7 min): no panic, no hang
"""
import contextlib, json, math, os, resource, subprocess, sys, tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.environ.get("MESORHEO_BIN", os.path.join(ROOT, "target/mpi/release/mesorheo"))
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")


def launch(case, sets=(), ranks=1, threads=2, keep=None):
    """Runs a case on `ranks` MPI ranks: (summary, or None when the run failed; the command;
    its stderr). The output goes to a temporary directory, or to `keep`, which stays."""
    with (contextlib.nullcontext(keep) if keep else tempfile.TemporaryDirectory()) as out:
        cmd = ["mpirun", "-n", str(ranks), "--oversubscribe", "--bind-to", "none", BIN, "run",
               os.path.join(ROOT, "cases", case), "--out", out, "-t", str(threads), "-q"]
        for s in sets:
            cmd += ["--set", s]
        p = subprocess.run(cmd, env=ENV, capture_output=True, text=True)
        if p.returncode not in (0, 3):
            return None, cmd, p.stderr
        with open(os.path.join(out, "summary.json")) as f:
            return json.load(f), cmd, p.stderr


def run(case, sets=(), ranks=1, threads=2, keep=None):
    summary, cmd, stderr = launch(case, sets, ranks, threads, keep)
    if summary is None:
        sys.exit(f"failed: {' '.join(cmd)}\n{stderr}")
    return summary


def run_text(text, sets=(), ranks=1, threads=2):
    """run() on a case given as text (written to a temporary file)."""
    with tempfile.NamedTemporaryFile("w", suffix=".toml", delete=False) as f:
        f.write(text)
    try:
        return run(f.name, sets, ranks, threads)
    finally:
        os.unlink(f.name)


def fmt(e):
    return f"{e['mean']:.4f} ± {e['stderr']:.4f}"


# Every verdict of this invocation: (target, check, pass, detail). A target that records none
# prints a table for a reader and cannot fail yet; the summary at the end says which.
VERDICTS = []
CURRENT = {"target": None}


def verdict(check, passed, detail=""):
    """Records one pass/fail check of the running target (what `./run validate` exits on)."""
    VERDICTS.append({"target": CURRENT["target"], "check": check, "pass": bool(passed),
                     "detail": detail})
    if not passed:
        print(f"**MISS** {CURRENT['target']}: {check} {detail}", file=sys.stderr, flush=True)


def finish(todo):
    """Writes the verdicts as JSON (MESORHEO_VALIDATE_JSON, default out/validate/results.json),
    names every miss and the targets without verdicts, and exits 1 on a miss."""
    path = os.environ.get("MESORHEO_VALIDATE_JSON",
                          os.path.join(ROOT, "out", "validate", "results.json"))
    os.makedirs(os.path.dirname(path), exist_ok=True)
    commit = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"],
                            capture_output=True, text=True).stdout.strip()
    import datetime
    stamp = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    dirty = subprocess.run(["git", "-C", ROOT, "status", "--porcelain", "--", "src", "Cargo.toml"],
                           capture_output=True, text=True).stdout.strip()
    if dirty:
        commit += " (src differs)"
    with open(path, "w") as f:
        json.dump({"date": stamp, "commit": commit, "binary": BIN, "targets": todo,
                   "verdicts": VERDICTS}, f, indent=1)
    # Every target with verdicts also keeps its own record in docs/validation_results/ (the
    # evidence that docs/validation_results/verdicts.md is generated from: `validate.py report`).
    if os.environ.get("MESORHEO_VALIDATE_RECORD", "1") != "0":
        for target in todo:
            mine = [v for v in VERDICTS if v["target"] == target]
            if not mine:
                continue
            os.makedirs(RECORDS, exist_ok=True)
            command = f"./run validate {target}"
            if os.environ.get("MESORHEO_STABILITY_TABLES_ONLY") and "dpd_" in target:
                command = ("MESORHEO_STABILITY_TABLES_ONLY=1 " + command
                           + " (judged on the maps' CSVs as measured)")
            with open(os.path.join(RECORDS, f"{target}.json"), "w") as f:
                json.dump({"target": target, "command": command,
                           "date": stamp, "commit": commit, "binary": BIN,
                           "verdicts": mine}, f, indent=1)
                f.write("\n")
    misses = [v for v in VERDICTS if not v["pass"]]
    silent = [t for t in todo if not any(v["target"] == t for v in VERDICTS)]
    print(f"\n{len(VERDICTS)} checks, {len(misses)} missed; results in {path}", file=sys.stderr)
    for v in misses:
        print(f"  MISS {v['target']}: {v['check']} {v['detail']}", file=sys.stderr)
    if silent:
        print(f"  tables only, no pass/fail yet: {', '.join(silent)}", file=sys.stderr)
    sys.exit(1 if misses else 0)


RECORDS = os.path.join(ROOT, "docs", "validation_results")


def report():
    """docs/validation_results/verdicts.md from the per-target records beside it: per target
    its command, date, commit and binary, then every check with its verdict and numbers."""
    import glob
    records = []
    for path in sorted(glob.glob(os.path.join(RECORDS, "*.json"))):
        with open(path) as f:
            records.append(json.load(f))
    lines = ["# Verdicts of `./run validate`", "",
             "Generated by `python3 tools/validate.py report` from the records in this folder, "
             "which each target writes when it runs (`./run validate TARGET`). Do not edit by "
             "hand.", "",
             "| target | checks | missed | date (UTC) | commit | command |",
             "|---|---|---|---|---|---|"]
    for r in records:
        miss = sum(not v["pass"] for v in r["verdicts"])
        lines.append(f"| [{r['target']}](#{r['target']}) | {len(r['verdicts'])} | "
                     f"{'**' + str(miss) + '**' if miss else 0} | {r['date']} | {r['commit']} | "
                     f"`{r['command']}` |")
    for r in records:
        lines += ["", f"## {r['target']}", "",
                  f"`{r['command']}`, {r['date']}, commit {r['commit']}, binary "
                  f"`{os.path.relpath(r['binary'], ROOT) if r['binary'].startswith(ROOT) else r['binary']}`.",
                  "", "| check | verdict | numbers |", "|---|---|---|"]
        for v in r["verdicts"]:
            cell = lambda t: str(t).replace("|", "\\|").replace("\n", " ")
            lines.append(f"| {cell(v['check'])} | {'pass' if v['pass'] else '**MISS**'} | "
                         f"{cell(v['detail'])} |")
    out = os.path.join(RECORDS, "verdicts.md")
    with open(out, "w") as f:
        f.write("\n".join(lines) + "\n")
    print(f"wrote {out}: {len(records)} targets, "
          f"{sum(len(r['verdicts']) for r in records)} checks", file=sys.stderr)


def kt_vs_dt():
    print("### k_BT and pressure vs Δt (Groot–Warren fluid, 3D, ρ = 3, a = 25, γ = 4.5, 1536 particles, t = 80)\n")
    print("| λ | Δt | steps | k_BT | rel. error | p | wall s |")
    print("|---|---|---|---|---|---|---|")
    points = []
    for lam in (0.5, 0.65):
        for dt in (0.01, 0.02, 0.03, 0.04, 0.05, 0.06):
            steps = int(round(80 / dt))
            s = run("dpd_equilibrium_3d.toml", [f"integrator.dt={dt}", f"integrator.lambda={lam}",
                                                f"run.steps={steps}", f"run.equilibration={int(10/dt)}",
                                                f"run.sample_every={max(1, int(0.4/dt))}"])
            t, p = s["observables"]["temperature"], s["observables"]["pressure"]
            points.append((lam, dt, t["mean"], t["stderr"]))
            print(f"| {lam} | {dt} | {steps} | {fmt(t)} | {100*(t['mean']-1):+.2f} % | {fmt(p)} | {s['wall_seconds']:.1f} |")
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(5, 3.5))
        for lam in (0.5, 0.65):
            xs = [p[1] for p in points if p[0] == lam]
            ax.errorbar(xs, [p[2] for p in points if p[0] == lam], yerr=[p[3] for p in points if p[0] == lam],
                        fmt="o-", capsize=3, label=f"λ = {lam}")
        ax.axhline(1.0, color="grey", ls=":"); ax.axhspan(0.98, 1.02, color="grey", alpha=0.15)
        ax.set_xlabel("Δt"); ax.set_ylabel("k_BT (target 1)"); ax.legend()
        fig.tight_layout(); fig.savefig(os.path.join(ROOT, "docs/kt_vs_dt.png"), dpi=120)
        print("\n![k_BT vs Δt](kt_vs_dt.png)\n")
    except ImportError:
        print("\n(matplotlib not installed: no plot)\n")


def viscosity():
    print("### Viscosity of the sheared Groot–Warren fluid vs run length (3D, γ̇ = 0.2, 3000 particles)\n")
    print("| steps | samples | η | N₁ | N₂ | k_BT | wall s |")
    print("|---|---|---|---|---|---|---|")
    for steps in (3000, 6000, 12000, 24000):
        s = run("dpd_shear_3d.toml", [f"run.steps={steps}", "run.equilibration=1000"])
        o = s["observables"]
        print(f"| {steps} | {o['viscosity']['samples']} | {fmt(o['viscosity'])} | {fmt(o['first_normal_stress_difference'])} | "
              f"{fmt(o['second_normal_stress_difference'])} | {fmt(o['temperature'])} | {s['wall_seconds']:.1f} |")
    print()


def _stock_cell(text, limit=160):
    """One line of text fit for a Markdown table cell."""
    text = " ".join(str(text).split()).replace("|", "\\|")
    return text if len(text) <= limit else text[:limit - 1] + "…"


def _stock_error(stderr):
    """The telling line of a failed run's stderr (mesorheo's `error: …`, else the last line that
    is not mpirun's decoration)."""
    lines = [l.strip() for l in stderr.splitlines() if l.strip() and not set(l.strip()) <= set("-=*")]
    for l in lines:
        if l.startswith("error"):
            return l
    return lines[-1] if lines else "no output"


def _stock_launch(case, ranks, threads, binary):
    """launch() of a stock case with a given binary, timed: (summary or None, error, seconds of
    the call). A run that reports other than `ranks` ranks (a serial build under mpirun runs
    `ranks` separate copies) counts as failed."""
    import time
    with tempfile.TemporaryDirectory() as out:
        cmd = ["mpirun", "-n", str(ranks), "--oversubscribe", "--bind-to", "none", binary, "run",
               os.path.join(ROOT, "cases", case), "--out", out, "-t", str(threads), "-q"]
        start = time.monotonic()
        try:
            p = subprocess.run(cmd, env=ENV, capture_output=True, text=True)
        except OSError as e:
            return None, str(e), time.monotonic() - start
        seconds = time.monotonic() - start
        if p.returncode not in (0, 3):
            return None, f"exit {p.returncode}: {_stock_error(p.stderr)}", seconds
        try:
            with open(os.path.join(out, "summary.json")) as f:
                s = json.load(f)
        except (OSError, ValueError) as e:
            return None, f"no summary: {e}", seconds
        if s.get("ranks") != ranks:
            return None, f"ran as {s.get('ranks')} rank(s), not {ranks} (not an MPI build?)", seconds
        return s, "", seconds


def _stock_measured(v, observables):
    """mean ± stderr of the observable a value check names (`relative_error(pressure)`), to the
    stderr's second significant digit; empty for profile checks."""
    import re
    m = re.fullmatch(r"\w+_error\((\w+)\)", v["metric"])
    e = observables.get(m.group(1)) if m else None
    if not e:
        return ""
    mean, err = e["mean"], e["stderr"]
    if not (math.isfinite(err) and err > 0):
        return f"{mean:.6g} ± {err:g}"
    places = max(0, 1 - math.floor(math.log10(err)))
    if places > 6 or abs(mean) >= 1e7:
        return f"{mean:.3g} ± {err:.2g}"
    return f"{mean:.{places}f} ± {err:.{places}f}"


def _stock_header():
    """UTC date, the commit (and whether src/ differs from it) and the binaries used."""
    import datetime
    def git(*args):
        try:
            return subprocess.run(["git", "--no-optional-locks", *args], cwd=ROOT, capture_output=True,
                                  text=True).stdout.strip()
        except OSError:
            return ""
    head = git("rev-parse", "--short", "HEAD") or "?"
    dirty = git("status", "--porcelain", "--untracked-files=no")
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    def built(path):
        try:
            t = datetime.datetime.fromtimestamp(os.path.getmtime(path), datetime.timezone.utc)
            return f"`{path}` (built {t:%Y-%m-%d %H:%M} UTC)"
        except OSError:
            return f"`{path}` (missing)"
    return now, head + (" + uncommitted changes" if dirty else ""), built


def stock():
    """Every stock case with a [[reference]] on 2 ranks × 1 thread (MESORHEO_BIN, an MPI build); a case that fails
    there is retried on 1 rank × 2 threads (with MESORHEO_SERIAL_BIN when set) and says why."""
    import time
    start = time.monotonic()
    now, commit, built = _stock_header()
    serial = os.environ.get("MESORHEO_SERIAL_BIN", BIN)
    print(f"### Stock cases with references (2 ranks × 1 thread; {now}, commit {commit})\n")
    print(f"Binary: {built(BIN)}" + (f"; fallback on 1 rank: {built(serial)}" if serial != BIN else "")
          + ". Wall s: the run's own wall_seconds. Measured: the referenced observable's mean ± "
            "standard error (empty for profile checks).\n", flush=True)
    print("| case | ranks × threads | wall s | check | metric | value | measured | tolerance | pass |")
    print("|---|---|---|---|---|---|---|---|---|", flush=True)
    slow, failed = [], []
    unreferenced = []
    # MESORHEO_STOCK_ONLY=a.toml,b.toml reruns only those cases (to refresh their rows).
    only = set(filter(None, os.environ.get("MESORHEO_STOCK_ONLY", "").split(",")))
    for case in sorted(os.listdir(os.path.join(ROOT, "cases"))):
        if not case.endswith(".toml") or (only and case not in only):
            continue
        with open(os.path.join(ROOT, "cases", case)) as f:
            if "[[reference]]" not in f.read():
                unreferenced.append(case)  # benchmarks, and validations with their own target
                continue
        layout = "2 × 1"
        s, err, secs = _stock_launch(case, 2, 1, BIN)
        if s is None:
            s, err1, secs = _stock_launch(case, 1, 2, serial)
            via = f", {os.path.basename(serial)}" if serial != BIN else ""
            layout = f"1 × 2{via} (2 ranks failed: {_stock_cell(err, 200)})"
            if s is None:
                failed.append(case)
                verdict(f"{case}: runs", False, _stock_cell(err1, 200))
                print(f"| {case} | {layout} | {secs:.1f} | run failed on 1 rank too: {_stock_cell(err1, 200)} "
                      f"| | | | | ERROR |", flush=True)
                continue
        wall = s.get("wall_seconds", secs)
        if wall > 300:
            slow.append((case, wall))
        rows = s.get("validation") or []
        for v in rows:
            verdict(f"{case}: {v['name']}", v["pass"],
                    f"({v['metric']} {v['value']:.4g}, tolerance {v['tolerance']:.4g})")
        if case == "default.toml":
            # The flagship run is sized so that its own error bars need no caveat (issue #41).
            warnings = s.get("warnings") or []
            verdict(f"{case}: ends without a warning", not warnings, _stock_cell("; ".join(warnings), 300))
        if not rows:
            print(f"| {case} | {layout} | {wall:.1f} | (no [[reference]]) | | | | | – |", flush=True)
        for i, v in enumerate(rows):
            if i == 1 and layout != "2 × 1":
                layout = layout.split(" (")[0] + " (as above)"
            print(f"| {case} | {layout} | {wall:.1f} | {_stock_cell(v['name'])} | {_stock_cell(v['metric'])} "
                  f"| {v['value']:.4g} | {_stock_measured(v, s.get('observables', {}))} "
                  f"| {v['tolerance']:.4g} | {'PASS' if v['pass'] else 'FAIL'} |", flush=True)
    total = time.monotonic() - start
    print(f"\nTotal wall time {total:.0f} s ({total / 60:.1f} min)"
          + (f"; over 5 min: {', '.join(f'{c} ({w:.0f} s)' for c, w in slow)}" if slow else "")
          + (f"; failed to run: {', '.join(failed)}" if failed else "") + ".\n")
    if unreferenced:
        print(f"Not run (no [[reference]]: benchmarks, or validated by their own `./run validate` target): "
              f"{', '.join(unreferenced)}.\n")


def startup_errors(summary):
    """{t: error} from the startup_profile checks of a summary."""
    out = {}
    for v in summary["validation"]:
        if " at t = " in v["name"]:
            out[float(v["name"].split(" at t = ")[1])] = v["value"]
    return out


def sph():
    times = [0.01, 0.02, 0.05, 0.1, 0.2, 0.3]
    schemes = [
        ("stock: Tait, Morris term, Morris walls", []),
        ("stock, heun", ['integrator.kind="heun"']),
        ("stock, thesis_predictor_corrector", ['integrator.kind="thesis_predictor_corrector"']),
        ("thesis: quadratic EOS, nested summation, layers",
         ['fluid.equation_of_state="quadratic"', 'fluid.viscous_term="nested_summation"',
          'walls.treatment="layers"']),
        ("quadratic EOS, Morris term, Morris walls", ['fluid.equation_of_state="quadratic"']),
        ("Tait, nested summation, Morris walls", ['fluid.viscous_term="nested_summation"']),
        ("Tait, Morris term, layers", ['walls.treatment="layers"']),
    ]
    print("### Start-up Couette (Re = 1, M = 0.1, Lucy 2.5Δ, Δ = 0.02, Δt = 1e-4): max bin error / U\n")
    print("| scheme | " + " | ".join(f"t = {t}" for t in times) + " |")
    print("|---|" + "---|" * len(times))
    curves = []
    for name, sets in schemes:
        e = startup_errors(run("sph_couette_2d.toml", sets))
        curves.append((name, [e.get(t, float("nan")) for t in times]))
        print(f"| {name} | " + " | ".join(f"{100*e.get(t, float('nan')):.2f} %" for t in times) + " |")
    print("\n### Start-up Couette against the lattice spacing (stock scheme, support 2.5Δ, Δt at 0.04 r_s²/ν)\n")
    print("| Δ | particles | " + " | ".join(f"t = {t}" for t in times) + " | loop s (2 threads) | core-s |")
    print("|---|---|" + "---|" * len(times) + "---|---|")
    resolution = []
    for delta, dt, every in ((0.04, 4e-4, 25), (0.02, 1e-4, 100), (0.01, 2.5e-5, 400)):
        n = round(1 / delta ** 2)
        sets = [f"particles.density={n}.0", f"particles.mass={delta**2}",
                f"fluid.smoothing_length={2.5*delta}", f"integrator.dt={dt}",
                f"run.steps={round(0.3/dt)}", f"run.sample_every={every}",
                f"neighbour.skin={delta/2}", f"diagnostics.profile_bins={round(1/delta)}"]
        s = run("sph_couette_2d.toml", sets)
        e = startup_errors(s)
        resolution.append((delta, s["wall_seconds"], e.get(0.1, float("nan"))))
        print(f"| {delta} | {s['particles']} | " + " | ".join(f"{100*e.get(t, float('nan')):.2f} %" for t in times)
              + f" | {s['loop_seconds']:.1f} | {2*s['loop_seconds']:.1f} |")
    ptimes = [0.05, 0.1, 0.2, 0.3, 0.4, 1.0, 2.0, 4.0]
    print("\n### Start-up Poiseuille (Re = 8, Δ = 0.02, Δt = 1e-4, to t = 4): max bin error / centre velocity\n")
    print("| support | " + " | ".join(f"t = {t}" for t in ptimes) + " | loop s |")
    print("|---|" + "---|" * len(ptimes) + "---|")
    for label, sets in (("3Δ (stock)", []), ("2.5Δ", ["fluid.smoothing_length=0.05"])):
        s = run("sph_poiseuille_2d.toml", sets)
        e = startup_errors(s)
        print(f"| {label} | " + " | ".join(f"{100*e.get(t, float('nan')):.2f} %" for t in ptimes)
              + f" | {s['loop_seconds']:.1f} |")
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.8))
        for name, errs in curves:
            a.semilogy(times, [100 * x for x in errs], "o-", label=name)
        a.axhline(1.0, color="grey", ls=":")
        a.set_xlabel("t"); a.set_ylabel("max bin error / U (%)"); a.set_title("start-up Couette, Δ = 0.02")
        a.legend(fontsize=6)
        b.loglog([r[1] for r in resolution], [100 * r[2] for r in resolution], "o-")
        for d, w, e in resolution:
            b.annotate(f"Δ = {d}", (w, 100 * e), fontsize=7)
        b.set_xlabel("wall time of the run (s)"); b.set_ylabel("error at t = 0.1 (%)")
        b.set_title("accuracy against cost (stock scheme)")
        fig.tight_layout(); fig.savefig(os.path.join(ROOT, "docs/sph_couette.png"), dpi=120)
        print("\n(plot: docs/sph_couette.png)")
    except ImportError:
        print("\n(matplotlib not available: no plot)")

def sph_convergence():
    import math, re
    integrators = ["kick_drift_kick", "heun", "midpoint", "thesis_predictor_corrector"]
    # (flow, stock case, time of the error, support / Δ, Δt of the stock case at Δ = 0.02)
    flows = [("Couette", "sph_couette_2d.toml", 0.1, 2.5), ("Poiseuille", "sph_poiseuille_2d.toml", 0.4, 3.0)]
    results = {}

    def one(case, t, delta, support, dt, integrator):
        text = open(os.path.join(ROOT, "cases", case)).read()
        text = re.sub(r"(?m)^times = \[.*\]$", f"times = [{t}]", text)
        steps = round(t / dt)
        sets = [f"particles.density={round(1 / delta ** 2)}.0", f"particles.mass={delta ** 2}",
                f"fluid.smoothing_length={support * delta}", f"integrator.dt={dt}",
                f"integrator.kind=\"{integrator}\"", f"run.steps={steps}",
                f"run.sample_every={max(d for d in range(1, steps // 10 + 1) if steps % d == 0)}",
                f"neighbour.skin={delta / 2}",
                f"diagnostics.profile_bins={round(1 / delta)}"]
        s = run_text(text, sets)
        return startup_errors(s)[t], s["loop_seconds"]

    for flow, case, t, support in flows:
        print(f"### Start-up {flow}: error at t = {t} against Δt (Δ = 0.02, support {support}Δ)\n")
        print("Max over bins of |u − u_series| / (plate or steady centre velocity); loop seconds on 1 rank × 2 "
              "threads. The observed order p = log₂(e(Δt)/e(Δt/2)) against the series is ≈ 0 where the "
              "spatial error dominates; the order in time itself (self-convergence, "
              "`tests/sph_suite/sph_channel.rs`) is 2 for kick–drift–kick, Heun and midpoint and 1 for the thesis's "
              "scheme as printed.\n")
        print("| integrator | Δt | error | p | loop s |")
        print("|---|---|---|---|---|")
        for integrator in integrators:
            prev = None
            for dt in (1e-4, 5e-5, 2.5e-5):
                e, secs = one(case, t, 0.02, support, dt, integrator)
                results.setdefault((flow, "dt", integrator), []).append((dt, e, secs))
                order = f"{math.log2(prev / e):.2f}" if prev else "–"
                prev = e
                print(f"| {integrator} | {dt:g} | {100 * e:.3f} % | {order} | {secs:.1f} |")
        print(f"\n### Start-up {flow}: error at t = {t} against Δ (support {support}Δ, Δt ∝ Δ², "
              "the stock Δt at Δ = 0.02)\n")
        print("| integrator | Δ | particles | Δt | error | p | loop s |")
        print("|---|---|---|---|---|---|---|")
        for integrator in integrators:
            prev = None
            for delta in (0.04, 0.02, 0.01):
                dt = 1e-4 * (delta / 0.02) ** 2
                e, secs = one(case, t, delta, support, dt, integrator)
                results.setdefault((flow, "dx", integrator), []).append((delta, e, secs))
                order = f"{math.log2(prev / e):.2f}" if prev else "–"
                prev = e
                print(f"| {integrator} | {delta} | {round(1 / delta ** 2)} fluid | {dt:g} | {100 * e:.3f} % | {order} | {secs:.1f} |")
        print()
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
        for ax, (flow, *_rest) in zip(axes, flows):
            for integrator in integrators:
                for kind, marker in (("dt", "o-"), ("dx", "s--")):
                    pts = results[(flow, kind, integrator)]
                    ax.loglog([p[2] for p in pts], [100 * p[1] for p in pts], marker,
                              label=f"{integrator}, {'Δt' if kind == 'dt' else 'Δ'} sweep")
            ax.set_xlabel("loop seconds (1 rank × 2 threads)"); ax.set_ylabel("max bin error (%)")
            ax.set_title(f"start-up {flow}: error against cost"); ax.legend(fontsize=5)
        fig.tight_layout(); fig.savefig(os.path.join(ROOT, "docs/sph_convergence.png"), dpi=120)
        print("![SPH start-up flows: error against cost](sph_convergence.png)\n")
    except ImportError:
        print("(matplotlib not available: no plot)\n")


def viscometric():
    print("### Steady shear of Hookean dumbbells: viscometric functions at Wi = 0.1, 1, 10 "
          "(`cases/dumbbells_hookean_shear_3d.toml` with `--set`)\n")
    print("Exact (upper-convected Maxwell): η_p = Gλ = 1, Ψ₁ = 2Gλ² = 2, Ψ₂ = 0. The stochastic Heun "
          "scheme's steady-state bias is ≤ 6·10⁻⁶ relative at these Δt (exact discrete moments, "
          "`hookean_discrete_moment`); the start-up transient left after the 8λ of equilibration "
          "biases the 24λ average by < 2·10⁻⁵. Wi = 0.1 uses control variates. Every run has its own "
          "seed (with one seed, Q_y — which does not feel κ_xy — is the same path at every Wi, so "
          "the runs would share their fluctuation of c_yy and hence of η_p). σ is the standard error "
          "from the spread of the particles' own time averages (the particles are independent, "
          "so it needs no correlation time); deviations are in units of that σ.\n")
    print("| D | Wi | particles × N_d | Δt/λ | steps | η_p/(Gλ) | dev/σ | Ψ₁/(2Gλ²) | dev/σ | Ψ₂/(Gλ²) | dev/σ | 3σ ≤ 1 % | wall s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    ok = True
    seed = 100
    for dim in (2, 3):
        for wi, dt, n, nd, extra in ((0.1, 0.01, 3000, 1000, ["polymer.variance_reduction=true"]),
                                     (1.0, 0.01, 600, 1000, []),
                                     (10.0, 0.005, 1000, 1000, [])):
            steps = int(round(32 / dt))
            sets = [f"dimension={dim}", f"flow.rate={wi}", f"flow.particles={n}", f"polymer.per_particle={nd}",
                    f"integrator.dt={dt}", f"run.steps={steps}", f"run.equilibration={int(round(8 / dt))}",
                    f"run.sample_every={max(1, int(round(0.1 / dt)))}", f"seed={seed}"] + extra
            seed += 1
            if dim == 2:
                sets.append("reference=[]")
            s = run("dumbbells_hookean_shear_3d.toml", sets, ranks=1, threads=2)
            o = s["observables"]
            row = [str(dim), str(wi), f"{n} × {nd}", str(dt), str(steps)]
            three_sigma_ok = True
            for name, exact, scale in (("polymer_viscosity", 1.0, 1.0),
                                       ("first_normal_stress_coefficient", 2.0, 2.0),
                                       ("second_normal_stress_coefficient", 0.0, 1.0)):
                if name not in o:
                    row += ["–", "–"]
                    continue
                m, e = o[name]["mean"], o[name]["stderr"]
                # σ = 0 happens: with control variates the Hookean Q_y, Q_z paths of the flowing
                # and the equilibrium copy coincide in shear, so N₂'s estimator is exact.
                dev = (m - exact) / e if e > 0 else (0.0 if abs(m - exact) < 1e-12 else float("inf"))
                ok &= abs(dev) <= 3
                three_sigma_ok &= 3 * e <= 0.01 * scale
                verdict(f"D = {dim}, Wi = {wi}: {name} within 3σ of {exact}", abs(dev) <= 3,
                        f"({m:.6g} ± {e:.2g}, {dev:+.1f}σ)")
                # Ψ₂ is ≈ 0 with error bars far below 10⁻⁴: scientific notation shows them.
                fmt = ".2e" if exact == 0.0 else ".4f"
                row += [f"{m / scale:{fmt}} ± {e / scale:{fmt}}", f"{dev:+.1f}"]
            ok &= three_sigma_ok
            verdict(f"D = {dim}, Wi = {wi}: 3σ ≤ 1 % of each function", three_sigma_ok)
            row += ["yes" if three_sigma_ok else "**no**", f"{s['wall_seconds']:.0f}"]
            print("| " + " | ".join(row) + " |")
    print(f"\nAll within 3σ with 3σ ≤ 1 %: {'yes' if ok else '**no**'}\n")


MAXWELL_DE = [0.0125, 0.025, 0.05, 0.1, 0.2, 0.4, 0.8, 1.0, 1.6, 3.2, 6.4, 12.8]


def maxwell():
    eta0 = 10.0
    # The corotational Jeffreys flow curve σ/(η₀γ̇) = βDe + (1 − β)De/(1 + De²) falls between
    # De ≈ 1.02 and 9.8 when β = η_s/η₀ = 0.01: homogeneous shear there is mechanically
    # unstable (it bands), and a banded state, once formed, persists on the rising branch too
    # (De = 12.8). β ≥ 1/9 makes the curve monotone; β = 1/8 (slope ≥ η₀/64) at De ≥ 1. At
    # De = 1 itself the slope with β = 0.01 is only 0.01 η₀: homogeneous shear is stable but
    # barely, and the run of 2026-11-26 banded after t ≈ 20 (η −49 % at t ∈ [40, 56]; it was
    # +0.03 % at t ∈ [8, 20.6]).
    def solvent(de):
        return 0.01 * eta0 if de < 1.0 else eta0 / 8
    def step(de, eta_s):
        eta_p = eta0 - eta_s
        elastic = 0.35 * 0.06 / (100.0 + eta_p / de) ** 0.5
        viscous = 0.042 * 0.06**2 / eta_s
        return min(1e-3, de / 25, 0.9 * elastic, 0.9 * viscous)
    # The averaging window. At β = 0.01 the square lattice melts at t ≈ 5 and the particle-scale
    # velocity noise it leaves decays slowly; its correlation with the particle arrangement biases
    # the mean velocity gradient (⟨D_xx − D_yy⟩ ≠ 0: N₁ high by the same amount with the rotation
    # terms off). Measured at De = 0.0125 over 4-unit windows: N₁ +4.2 % at t ∈ [8, 12], +0.8 % at
    # [16, 20], +0.44 % at [40, 44], +0.17 % at [60, 64] (De = 0.1 alike in absolute terms). So
    # β = 0.01 averages t ∈ [40, 56]; at β = 1/8 the lattice does not melt and t ≥ max(8, 7λ)
    # (the start-up e^{−t/λ} below 10⁻³) suffices.
    def window(de):
        return (40.0, 16.0) if de < 1.0 else (max(8.0, 7.0 * de), max(8.0, 4.0 * 3.141592653589793))
    print("### Corotational Maxwell SPH in Lees–Edwards steady shear (cases/maxwell_shear_2d.toml at each De)\n")
    print("η_s = 0.1 (β = 1 %, Morris) at De < 1, η_s = 1.25 (β = 1/8) at De ≥ 1, η_p = 10 − η_s, γ̇ = 1, corrected velocity "
          "gradient; Δt = min(10⁻³, λ/25, 0.9 × the elastic-wave and viscous limits); averaged over t ∈ [40, 56] at β = 1 % (after the melted lattice's noise has decayed) and "
          "over max(8, 4π) time units after t = max(8, 7λ) at β = 1/8; each point on 1 thread, two at a time. Reference: the corotational Jeffreys fluid, "
          "η = η_s + η_p/(1+De²), Ψ₁γ̇ = 2η_pDe/(1+De²).\n")
    print("| De | β | η/η₀ | exact | error | Ψ₁γ̇/η₀ | exact | error | steps | wall s |")
    print("|---|---|---|---|---|---|---|---|---|---|")

    reuse = os.environ.get("MESORHEO_MAXWELL_RUNS")

    def one(de):
        eta_s = solvent(de)
        dt = step(de, eta_s)
        t_eq, t_avg = window(de)
        steps = int(round((t_eq + t_avg) / dt))
        eq = int(round(t_eq / dt))
        sets = [f"fluid.polymer.relaxation_time={de}", f"run.steps={steps}", f"run.equilibration={eq}",
                "diagnostics.blocks=8", f"fluid.viscosity={eta_s}", f"fluid.polymer.viscosity={eta0 - eta_s}",
                f"integrator.dt={dt}", f"run.sample_every={max(1, round(0.01 / dt))}"]
        keep = os.path.join(reuse, f"de_{de}") if reuse else None
        if keep and os.path.exists(os.path.join(keep, "summary.json")):
            # A finished run: used only if it has exactly these settings.
            with open(os.path.join(keep, "summary.json")) as f:
                s = json.load(f)
            c = s["case"]
            got = (c["fluid"]["polymer"]["relaxation_time"], c["fluid"]["viscosity"], c["integrator"]["dt"], s["steps"],
                   c["run"]["equilibration"])
            if got != (de, eta_s, dt, steps, eq):
                sys.exit(f"{keep}: a run of (λ, η_s, Δt, steps, equilibration) = {got}, not {(de, eta_s, dt, steps, eq)}; "
                         "move it away to rerun")
        else:
            s = run("maxwell_shear_2d.toml", sets, threads=1, keep=keep)
        return de, eta_s, steps, s

    from concurrent.futures import ThreadPoolExecutor
    # The longest first, so that the two workers finish together.
    order = sorted(MAXWELL_DE, key=lambda de: -sum(window(de)) / step(de, solvent(de)))
    with ThreadPoolExecutor(2) as pool:
        done = {r[0]: r for r in pool.map(one, order)}
    rows = []
    for de in MAXWELL_DE:
        _, eta_s, steps, s = done[de]
        eta_p = eta0 - eta_s
        o = s["observables"]
        eta, n1 = o["viscosity"], o["first_normal_stress_difference"]
        eta_x = (eta_s + eta_p / (1 + de * de)) / eta0
        psi_x = 2 * eta_p * de / (1 + de * de) / eta0
        e_eta = eta["mean"] / eta0 / eta_x - 1
        e_psi = n1["mean"] / eta0 / psi_x - 1
        rows.append((de, eta["mean"] / eta0, eta["stderr"] / eta0, eta_x, n1["mean"] / eta0, n1["stderr"] / eta0, psi_x,
                     eta_s / eta0))
        print(f"| {de} | {eta_s / eta0:.3g} | {eta['mean']/eta0:.5f} ± {eta['stderr']/eta0:.5f} | {eta_x:.5f} | {100*e_eta:+.2f} % "
              f"| {n1['mean']/eta0:.5f} ± {n1['stderr']/eta0:.5f} | {psi_x:.5f} | {100*e_psi:+.2f} % | {steps} | {s['wall_seconds']:.0f} |")
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        import numpy as np
        fig, ax = plt.subplots(figsize=(5.5, 3.8))
        for lo, hi, b in ((-2.2, 0.0, 0.01), (0.0, 1.3, 0.125)):
            de = np.logspace(lo, hi, 100)
            ax.plot(de, b + (1 - b) / (1 + de**2), "k-", lw=1, label="η/η₀ exact" if b < 0.1 else None)
            ax.plot(de, 2 * (1 - b) * de / (1 + de**2), "k--", lw=1, label="Ψ₁γ̇/η₀ exact" if b < 0.1 else None)
        ax.axvline(1.0, color="0.7", lw=0.8)
        ax.text(1.1, 0.02, "β = 1/8 →", fontsize=7)
        ax.errorbar([r[0] for r in rows], [r[1] for r in rows], yerr=[r[2] for r in rows], fmt="o", label="η/η₀ SPH")
        ax.errorbar([r[0] for r in rows], [r[4] for r in rows], yerr=[r[5] for r in rows], fmt="s", label="Ψ₁γ̇/η₀ SPH")
        ax.set_xscale("log"); ax.set_xlabel("De = λγ̇"); ax.legend(fontsize=8)
        fig.tight_layout(); fig.savefig(os.path.join(ROOT, "docs/maxwell_shear.png"), dpi=120)
        print("\n![Maxwell viscometric functions](maxwell_shear.png)\n")
    except ImportError:
        print("\n(matplotlib missing: no plot)\n")

    print("### Channel relaxation of sin(πy) (cases/maxwell_channel_relaxation_2d.toml)\n")
    print("max over the 32 bins of |u_x − u_exact| / (initial amplitude); exact: the linearised Jeffreys "
          "solution with η_s = 1 % of η₀ (for η_s = 0 the corrected IVP of "
          "docs/theory/sph_maxwell.md §3 T3).\n")
    times = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.8, 1.0, 1.2, 1.4, 1.6, 1.8, 2.0]
    print("| case | model | " + " | ".join(f"t = {t}" for t in times) + " | wall s |")
    print("|---|---|" + "---|" * (len(times) + 1))
    for label, re, de in (("(a) Re = 1, De = 0.25", 1.0, 0.25), ("(b) Re = 2.5, De = 0.1", 2.5, 0.1)):
        eta0 = 1.0 / re
        for model, rot in (("linear (SPH2)", "false"), ("corotational (SPH1)", "true")):
            s = run("maxwell_channel_relaxation_2d.toml",
                    [f"fluid.viscosity={0.01 * eta0}", f"fluid.polymer.viscosity={0.99 * eta0}",
                     f"fluid.polymer.relaxation_time={de}", f"fluid.polymer.rotation={rot}"])
            e = startup_errors(s)
            print(f"| {label} | {model} | " + " | ".join(f"{100*e[t]:.2f} %" for t in times) + f" | {s['wall_seconds']:.0f} |")
    print()


def maxwell_convergence():
    eta_x, n1_x = 0.1 + 9.9 / 2, 9.9
    print("### Maxwell shear at De = 1: error and cost against Δt and Δ (cases/maxwell_shear_2d.toml, corrected gradient)\n")
    print("η = η_s + η_p/(1+De²) = 5.05, N₁ = 2η_pλγ̇²/(1+De²) = 9.9; t ∈ [8, 16]. Lucy support 3Δ, "
          "skin Δ/2; cost in particle-steps and wall seconds (2 threads).\n")
    print("| sweep | Δ | particles | Δt | steps | η error | N₁ error | particle-steps | wall s |")
    print("|---|---|---|---|---|---|---|---|---|")
    rows = []
    def one(label, delta, dt):
        n = round(1 / delta)
        steps, eq = int(round(16 / dt)), int(round(8 / dt))
        s = run("maxwell_shear_2d.toml", [f"particles.density={n*n}.0", f"particles.mass={1/(n*n)}",
                                          f"fluid.smoothing_length={3*delta}", f"neighbour.skin={delta/2}",
                                          f"integrator.dt={dt}", f"run.steps={steps}", f"run.equilibration={eq}",
                                          f"run.sample_every={max(1, round(0.01 / dt))}"])
        o = s["observables"]
        e_eta = o["viscosity"]["mean"] / eta_x - 1
        e_n1 = o["first_normal_stress_difference"]["mean"] / n1_x - 1
        cost = n * n * steps
        rows.append((label, delta, dt, e_eta, e_n1, cost, s["wall_seconds"]))
        print(f"| {label} | {delta:.4f} | {n*n} | {dt:.2e} | {steps} | {100*e_eta:+.2f} ± {100*o['viscosity']['stderr']/eta_x:.2f} % "
              f"| {100*e_n1:+.2f} ± {100*o['first_normal_stress_difference']['stderr']/n1_x:.2f} % | {cost:.2e} | {s['wall_seconds']:.0f} |")
    for dt in (1e-3, 5e-4, 2.5e-4):
        one("Δt", 0.02, dt)
    for n in (25, 40, 50, 70):
        delta = 1 / n
        # the viscous limit 0.042 (3Δ)² ρ₀/η_s at 0.7 of it, and at most the stock 10⁻³
        one("Δ", delta, min(1e-3, round(0.7 * 0.042 * (3 * delta) ** 2 / 0.1, 6)))
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(5.5, 3.8))
        for label, marker in (("Δt", "o"), ("Δ", "s")):
            r = [x for x in rows if x[0] == label]
            ax.loglog([x[5] for x in r], [max(abs(x[3]), 1e-5) for x in r], marker + "-", label=f"|η error|, {label} sweep")
            ax.loglog([x[5] for x in r], [max(abs(x[4]), 1e-5) for x in r], marker + "--", label=f"|N₁ error|, {label} sweep")
        ax.set_xlabel("cost (particle-steps)"); ax.set_ylabel("relative error"); ax.legend(fontsize=7)
        fig.tight_layout(); fig.savefig(os.path.join(ROOT, "docs/maxwell_convergence.png"), dpi=120)
        print("\n![Maxwell error against cost](maxwell_convergence.png)\n")
    except ImportError:
        print("\n(matplotlib missing: no plot)\n")


def maxwell_couette():
    """Oldroyd-B start-up Couette flow (cases/maxwell_couette_startup_2d.toml with --set) at
    λ = 0.05, 0.2, 1 and β = η_s/η₀ = 0.1, 0.5 (η₀ = 1): the max over the listed times of the
    max-bin error against the series `couette_oldroyd_b`, against Δ and Δt, for the stock scheme
    (Lucy 3Δ, Morris cap 6) and the issue's (Lucy 2.5Δ, cap 2, the Newtonian stock case's). One
    rank × MESORHEO_THREADS threads (default 1); a cell whose estimated loop time exceeds
    MESORHEO_CELL_BUDGET seconds (default 200) is skipped and listed as such."""
    import re
    threads = int(os.environ.get("MESORHEO_THREADS", "1"))
    budget = float(os.environ.get("MESORHEO_CELL_BUDGET", "200"))
    text = open(os.path.join(ROOT, "cases", "maxwell_couette_startup_2d.toml")).read()
    times = {0.05: [0.01, 0.02, 0.05, 0.1, 0.2, 0.3], 0.2: [0.02, 0.05, 0.1, 0.2, 0.5, 1.0],
             1.0: [0.1, 0.2, 0.5, 1.0, 1.5, 2.0]}
    # (scheme, support/Δ, cap, {(Δ, β): Δt values}); every Δt within the binding limit of
    # `check` (the solvent's Morris term 0.042 r_s²/ν_s, or the elastic wave)
    schemes = [
        ("stock: Lucy 3Δ, cap 6", 3.0, 6.0,
         {(0.02, 0.1): (2e-4, 1e-4), (0.02, 0.5): (2e-4, 1e-4), (0.01, 0.1): (2e-4, 1e-4),
          (0.01, 0.5): (6.25e-5, 3.125e-5), (0.005, 0.1): (5e-5,)}),
        ("issue: Lucy 2.5Δ, cap 2", 2.5, 2.0,
         {(0.02, 0.1): (1e-4,), (0.02, 0.5): (1e-4,), (0.01, 0.1): (1e-4,), (0.01, 0.5): (5e-5,)}),
    ]
    print("### Oldroyd-B start-up Couette: max over the listed times of max_bin |u − u_series| / U\n")
    print(f"One rank × {threads} thread(s); loop seconds of each run; bins one lattice row each. "
          "Times: λ = 0.05: " + ", ".join(map(str, times[0.05])) + "; λ = 0.2: "
          + ", ".join(map(str, times[0.2])) + "; λ = 1: " + ", ".join(map(str, times[1.0])) + ".\n")
    print("| λ | β | scheme | Δ | Δt | max error (at t) | error at each listed time (%) | loop s |")
    print("|---|---|---|---|---|---|---|---|")
    for lam in (0.05, 0.2, 1.0):
        for beta in (0.1, 0.5):
            for label, support, cap, dts in schemes:
                for (delta, b), steps_dt in dts.items():
                    if b != beta or (delta == 0.005 and lam != 0.05):
                        continue
                    for dt in steps_dt:
                        n = round(1 / delta)
                        t_end = times[lam][-1]
                        steps = round(t_end / dt)
                        particles = n * n + 2 * n * math.ceil(2 * support - 1e-9)
                        estimate = 6.5e-7 * particles * steps * (support / 3.0) ** 2
                        head = f"| {lam} | {beta} | {label} | {delta} | {dt:g} |"
                        if estimate > budget:
                            print(f"{head} skipped (estimated {estimate:.0f} s) | | |")
                            continue
                        case = re.sub(r"(?m)^times = \[.*\]$",
                                      "times = [" + ", ".join(map(str, times[lam])) + "]", text)
                        sets = [f"particles.density={n * n}.0", f"particles.mass={delta ** 2}",
                                f"fluid.smoothing_length={support * delta}",
                                f"neighbour.skin={delta / 2}", f"walls.morris_cap={cap}",
                                f"fluid.viscosity={beta}", f"fluid.polymer.viscosity={1 - beta:g}",
                                f"fluid.polymer.relaxation_time={lam}", f"integrator.dt={dt}",
                                f"run.steps={steps}", f"run.sample_every={round(0.01 / dt)}",
                                f"diagnostics.profile_bins={n}"]
                        s = run_text(case, sets, threads=threads)
                        e = startup_errors(s)
                        worst = max(e, key=e.get)
                        print(f"{head} {100 * e[worst]:.2f} % ({worst:g}) | "
                              + " ".join(f"{100 * e[t]:.2f}" for t in sorted(e))
                              + f" | {s['loop_seconds']:.0f} |", flush=True)


def maxwell_couette_causes():
    """What the Oldroyd-B start-up Couette error is made of, at the issue's λ = 0.05, β = 0.1:
    the issue's setup (the Newtonian stock case's scheme: Lucy 2.5Δ, Morris cap 2, Δ = 0.02,
    Δt = 10⁻⁴) and one change at a time, then the stock scheme (3Δ, cap 6), at Δ = 0.02 and
    0.01; cases/maxwell_couette_startup_2d.toml with --set, one rank × MESORHEO_THREADS."""
    import re
    threads = int(os.environ.get("MESORHEO_THREADS", "1"))
    times = [0.01, 0.02, 0.05, 0.1, 0.2, 0.3]
    text = open(os.path.join(ROOT, "cases", "maxwell_couette_startup_2d.toml")).read()
    text = re.sub(r"(?m)^times = \[.*\]$", "times = [" + ", ".join(map(str, times)) + "]", text)

    def lattice(delta):
        n = round(1 / delta)
        return [f"particles.density={n * n}.0", f"particles.mass={delta ** 2}",
                f"neighbour.skin={delta / 2}", f"diagnostics.profile_bins={n}"]

    def steps(dt):
        return [f"integrator.dt={dt}", f"run.steps={round(0.3 / dt)}",
                f"run.sample_every={round(0.01 / dt)}"]

    issue = ["fluid.smoothing_length=0.05", "walls.morris_cap=2.0"]
    stock = ["fluid.smoothing_length=0.06", "walls.morris_cap=6.0"]
    fine_issue = ["fluid.smoothing_length=0.025", "walls.morris_cap=2.0"]
    fine_stock = ["fluid.smoothing_length=0.03", "walls.morris_cap=6.0"]
    rows = [
        ("Δ = 0.02, issue: Lucy 2.5Δ, cap 2", lattice(0.02) + steps(1e-4) + issue),
        ("  Δt = 5·10⁻⁵", lattice(0.02) + steps(5e-5) + issue),
        ("  cap 1.5 (the default)", lattice(0.02) + steps(1e-4) + issue + ["walls.morris_cap=1.5"]),
        ("  cap 6", lattice(0.02) + steps(1e-4) + issue + ["walls.morris_cap=6.0"]),
        ("  corrected velocity gradient", lattice(0.02) + steps(1e-4) + issue
         + ['fluid.velocity_gradient="corrected"']),
        ("  corrected velocity gradient, cap 6", lattice(0.02) + steps(1e-4) + issue
         + ['fluid.velocity_gradient="corrected"', "walls.morris_cap=6.0"]),
        ("  method B layers (own τ at the walls)", lattice(0.02) + steps(1e-4) + issue
         + ['walls.treatment="layers"']),
        ("Δ = 0.02, stock scheme: Lucy 3Δ, cap 6", lattice(0.02) + steps(1e-4) + stock),
        ("  c₀ = 20 (M = 0.05)", lattice(0.02) + steps(1e-4) + stock + ["fluid.sound_speed=20.0"]),
        ("  Δt = 5·10⁻⁵", lattice(0.02) + steps(5e-5) + stock),
        ("Δ = 0.01, issue: Lucy 2.5Δ, cap 2", lattice(0.01) + steps(1e-4) + fine_issue),
        ("Δ = 0.01, Lucy 2.5Δ, cap 6", lattice(0.01) + steps(1e-4) + fine_issue
         + ["walls.morris_cap=6.0"]),
        ("Δ = 0.01, stock scheme: Lucy 3Δ, cap 6", lattice(0.01) + steps(1e-4) + fine_stock),
    ]
    print("### Oldroyd-B start-up Couette at λ = 0.05, β = 0.1: max_bin |u − u_series| / U, one change at a time\n")
    print("| run | " + " | ".join(f"t = {t}" for t in times) + " | loop s |")
    print("|---|" + "---|" * len(times) + "---|")
    for label, sets in rows:
        s = run_text(text, sets + ["fluid.viscosity=0.1", "fluid.polymer.viscosity=0.9",
                                   "fluid.polymer.relaxation_time=0.05"], threads=threads)
        e = startup_errors(s)
        print(f"| {label} | " + " | ".join(f"{100 * e[t]:.2f} %" for t in times)
              + f" | {s['loop_seconds']:.0f} |", flush=True)


def try_run(case, sets=(), ranks=1, threads=2):
    """run(), but None when the run fails (a blow-up)."""
    return launch(case, sets, ranks, threads)[0]


def predicted_limit(case, sets):
    """The binding time-step limit `mesorheo check` prints: (name, value)."""
    cmd = [BIN, "check", os.path.join(ROOT, "cases", case), "--set", "run.beyond_stability_limits=true"]
    for s in sets:
        cmd += ["--set", s]
    p = subprocess.run(cmd, env=ENV, capture_output=True, text=True)
    for line in p.stdout.splitlines():
        if "binding]" in line:
            name, value = line.split(": ", 1)[1].rsplit(" = ", 1)
            return name, float(value.split()[0])
    sys.exit(f"no binding limit in:\n{p.stdout}{p.stderr}")


def maxwell_stability():
    print("### Largest stable Δt of the Maxwell fluid against De (cases/maxwell_shear_2d.toml)\n")
    print(f"η_s = 0.1 (Morris), η_p = 9.9, p_b = 20, Lucy 0.06, Δ = 0.02, γ̇ = 1, kick–drift–kick, "
          f"velocity gradient {os.environ.get('MESORHEO_MAXWELL_GRADIENT', 'corrected')}. "
          "Stable: 2000 steps run without a blow-up (a non-finite or out-of-range pair term, or a "
          "particle moving beyond the list's reach). Bisection in log Δt to 2 %, between Δt known "
          "to run and one known to fail; `run.beyond_stability_limits` lets Δt pass the limits.\n")
    print("| De | largest stable Δt | first failing Δt | binding limit (`check`) | limit value | measured / limit |")
    print("|---|---|---|---|---|---|")
    rows = []
    for de in (0.0125, 0.05, 0.2, 1.0, 3.2, 12.8):
        # The stock case's corrected gradient; MESORHEO_MAXWELL_GRADIENT=sph maps the plain one.
        base = [f"fluid.polymer.relaxation_time={de}", "run.steps=2000", "run.equilibration=0",
                "run.sample_every=100", "diagnostics.blocks=2",
                f'fluid.velocity_gradient="{os.environ.get("MESORHEO_MAXWELL_GRADIENT", "corrected")}"']
        name, limit = predicted_limit("maxwell_shear_2d.toml", base)
        ok = lambda dt: try_run("maxwell_shear_2d.toml", base + [f"integrator.dt={dt}",
                                                                  "run.beyond_stability_limits=true"]) is not None
        lo, hi = 0.5 * limit, 2.0 * limit
        while not ok(lo):
            hi, lo = lo, lo / 2
        while ok(hi):
            lo, hi = hi, hi * 2
        while hi / lo > 1.02:
            mid = math.sqrt(lo * hi)
            if ok(mid):
                lo = mid
            else:
                hi = mid
        rows.append((de, lo, limit))
        print(f"| {de} | {lo:.4e} | {hi:.4e} | {name} | {limit:.4e} | {lo/limit:.2f} |")
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(5.5, 3.8))
        ax.loglog([r[0] for r in rows], [r[1] for r in rows], "o-", label="largest stable Δt (measured)")
        ax.loglog([r[0] for r in rows], [r[2] for r in rows], "k--", label="binding limit of `check`")
        ax.set_xlabel("De = λγ̇"); ax.set_ylabel("Δt"); ax.legend(fontsize=8)
        fig.tight_layout(); fig.savefig(os.path.join(ROOT, "docs/maxwell_stability.png"), dpi=120)
        print("\n![Maxwell stability map](maxwell_stability.png)\n")
    except ImportError:
        print("\n(matplotlib missing: no plot)\n")


def inclusion():
    print("### Newtonian cell (cases/inclusion_newtonian_2d.toml at each R and Δ)\n")
    print("Mean fluid stress σ_xy/(ηγ̇) against the exact 1/(1 − φ), φ = πR²; composite viscosity "
          "(fluid stress + traction moments) against dilute theory 1 + 3φ (fixed discs); torque "
          "against the isolated cylinder's −2πηR²γ̇. Averaged over t ∈ [0.2, 1] (one period of the "
          "image lattice).\n")
    print("| R | Δ | fluid mean | exact | error | composite | 1 + 3φ | torque | −2πR² | steps | wall s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for delta in (0.02, 0.01):
        for r in (0.1, 0.15, 0.2):
            sets = [f"inclusions.radius={r}"]
            if delta == 0.01:
                sets += ["particles.density=10000.0", "particles.mass=0.0001",
                         "fluid.smoothing_length=0.01033333", "integrator.dt=2e-5", "run.steps=50000",
                         "run.equilibration=10000", "run.sample_every=50", "neighbour.skin=0.005"]
            s = run("inclusion_newtonian_2d.toml", sets)
            o = s["observables"]
            phi = math.pi * r * r
            exact = 1 / (1 - phi)
            eta, comp, torque = o["viscosity"], o["composite_viscosity"], o["inclusion_torque"]
            print(f"| {r} | {delta} | {fmt(eta)} | {exact:.4f} | {100*(eta['mean']/exact-1):+.2f} % "
                  f"| {fmt(comp)} | {1+3*phi:.4f} | {torque['mean']:.4f} ± {torque['stderr']:.4f} "
                  f"| {-2*math.pi*r*r:.4f} | {s['steps']} | {s['wall_seconds']:.0f} |")
    print()
    print("### Maxwell matrix (cases/inclusion_maxwell_2d.toml at each De and R)\n")
    print("η_s = 0.01, η_p = 0.99, Δ = 0.02, Δt = min(4·10⁻⁴, λ/25), t ∈ [1, 3]. Fluid averages "
          "against the matrix's η(De) = η_s + η_p/(1+De²) and Ψ₁(De)γ̇ = 2η_pDe/(1+De²): the ratios "
          "η_eff/η and Ψ₁,eff/Ψ₁, beside the thesis's fit 1 + ρ_v (slope ≈ 1) and the Newtonian "
          "1/(1 − ρ_v).\n")
    print("| De | R | ρ_v | η_eff | η_eff/η | Ψ₁,eff/Ψ₁ | 1 + ρ_v | 1/(1 − ρ_v) | composite | torque | wall s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for de in (0.01, 0.1):
        dt = min(4e-4, de / 25)
        steps, eq = int(round(3.0 / dt)), int(round(1.0 / dt))
        slope_num = slope_den = 0.0
        for r in (0.1, 0.15, 0.2):
            s = run("inclusion_maxwell_2d.toml",
                    [f"inclusions.radius={r}", f"fluid.polymer.relaxation_time={de}", f"integrator.dt={dt}",
                     f"run.steps={steps}", f"run.equilibration={eq}"])
            o = s["observables"]
            rho_v = math.pi * r * r
            eta_m = 0.01 + 0.99 / (1 + de * de)
            n1_m = 2 * 0.99 * de / (1 + de * de)
            eta, n1 = o["viscosity"], o["first_normal_stress_difference"]
            slope_num += rho_v * (eta["mean"] / eta_m - 1)
            slope_den += rho_v * rho_v
            print(f"| {de} | {r} | {rho_v:.4f} | {fmt(eta)} | {eta['mean']/eta_m:.4f} "
                  f"| {n1['mean']/n1_m:.3f} ± {n1['stderr']/n1_m:.3f} | {1+rho_v:.4f} | {1/(1-rho_v):.4f} "
                  f"| {fmt(o['composite_viscosity'])} | {o['inclusion_torque']['mean']:.4f} | {s['wall_seconds']:.0f} |")
        print(f"| {de} | slope of η_eff/η − 1 against ρ_v (through 0) | | | {slope_num/slope_den:.3f} | | | | | | |")
    print()


def connffessit_shear():
    case = "connffessit_shear_2d.toml"
    with open(os.path.join(ROOT, "cases", case)) as f:
        stock_text = f.read()
    dt = 1.5e-3

    def sets(lam, n_d=100):
        t = 9 * max(lam, 1.0)  # the transient e^{−t/λ}(1 + t/λ) < 10⁻³ after 9λ
        # p_b = 5 τ_xx (τ_xx = 2η_pλγ̇² = λ here, at least the stock 5): with less, the tension
        # feeds the SPH tensile instability at Wi = 3 (p_b = 5: η +5.8 %, N₁ +10 %, the UCM fluid
        # started from a perturbed lattice alike; p_b = 15: +0.17 %, +0.26 %).
        # Lucy 3Δ and no transport velocity, pinned: the settings of the recorded table (the
        # transport velocity's sweep is tools/coupled_bias.py --pt).
        return [f"fluid.polymer.relaxation_time={lam}", f"fluid.polymer.per_particle={n_d}",
                f"fluid.background_pressure={5 * max(lam, 1.0)}",
                "fluid.smoothing_length=0.15", "fluid.transport_pressure=0.0",
                f"run.equilibration={round(t / dt)}", f"run.steps={round(2 * t / dt)}"]

    def rel(o, name, want):
        e = o[name]
        return f"{100 * (e['mean'] / want - 1):+.2f} ± {100 * e['stderr'] / want:.2f} %"

    ucm_text = stock_text.replace('model = "dumbbells"', 'model = "upper_convected_maxwell"') \
                         .replace("per_particle = 100\n", "")
    print("### CONNFFESSIT in steady shear (cases/connffessit_shear_2d.toml)\n")
    print("Hookean dumbbells, η_s = η_p = 0.5 (G = η_p/λ), so η = 1 and N₁ = 2η_pλγ̇² = Wi at every Wi "
          "(Oldroyd-B). 400 particles, Δt = 1.5·10⁻³, Lucy support 3Δ, background pressure p_b = 5 max(Wi, 1) (5 τ_xx) and no transport velocity, averaged over t ∈ [9λ', 18λ'], λ' = max(λ, 1); "
          "errors relative, ± the run's block standard error (about half the seed-to-seed spread, "
          "see the case file). The UCM SPH fluid (model = \"upper_convected_maxwell\") on the same "
          "particles beside it.\n")
    print("| Wi | model | N_d | gradient | η error | N₁ error | wall s |")
    print("|---|---|---|---|---|---|---|")
    for wi in (0.5, 1.0, 3.0):
        for label, text, n_d, grad in (("UCM", ucm_text, 0, "corrected"), ("dumbbells", stock_text, 100, "corrected")):
            st = sets(wi, max(n_d, 1))
            if n_d == 0:
                st = [x for x in st if "per_particle" not in x]
            s = run_text(text, st)
            o = s["observables"]
            print(f"| {wi} | {label} | {n_d or '–'} | {grad} | {rel(o, 'viscosity', 1.0)} "
                  f"| {rel(o, 'first_normal_stress_difference', wi)} | {s['wall_seconds']:.0f} |")
    s = run(case, sets(1.0) + ["fluid.velocity_gradient=sph"])
    o = s["observables"]
    print(f"| 1.0 | dumbbells | 100 | sph | {rel(o, 'viscosity', 1.0)} | {rel(o, 'first_normal_stress_difference', 1.0)} "
          f"| {s['wall_seconds']:.0f} |")
    print()
    print("Error and cost against N_d at Wi = 1 (dumbbell-steps = 400 N_d × steps):\n")
    print("| N_d | η error | N₁ error | dumbbell-steps | wall s |")
    print("|---|---|---|---|---|")
    rows = []
    for n_d in (25, 100, 400, 1600):
        s = run(case, sets(1.0, n_d))
        o = s["observables"]
        work = 400 * n_d * s["steps"]
        rows.append((n_d, o, work, s["wall_seconds"]))
        print(f"| {n_d} | {rel(o, 'viscosity', 1.0)} | {rel(o, 'first_normal_stress_difference', 1.0)} "
              f"| {work:.2e} | {s['wall_seconds']:.0f} |")
    print()
    print("FENE dumbbells (b = 50, semi-implicit) in the coupled fluid against the homogeneous-flow "
          "ensembles (400 particles × 250 dumbbells, the same λ, G, Δt and averaging window) at the "
          "same Wi: the flow is homogeneous, so they must agree within error bars. η_p = η − η_s.\n")
    print("| Wi | coupled η_p | homogeneous η_p | coupled Ψ₁ | homogeneous Ψ₁ | η_p/(Gλ) |")
    print("|---|---|---|---|---|---|")
    for wi in (1.0, 3.0):
        st = sets(wi) + ['fluid.polymer.spring="fene"', "fluid.polymer.b=50.0"]
        o = run(case, st)["observables"]
        t = 9 * max(wi, 1.0)
        flow = f"""dimension = 2
seed = 4
[flow]
kind = "simple_shear"
rate = 1.0
particles = 400
[polymer]
kind = "dumbbells"
spring = "fene"
b = 50.0
relaxation_time = {wi}
modulus = {0.5 / wi}
per_particle = 250
[integrator]
kind = "brownian_dynamics"
dt = {dt}
[run]
steps = {round(2 * t / dt)}
equilibration = {round(t / dt)}
sample_every = 10
"""
        h = run_text(flow)["observables"]
        eta_p = o["viscosity"]["mean"] - 0.5
        psi1 = o["first_normal_stress_difference"]
        hp, hpsi = h["polymer_viscosity"], h["first_normal_stress_coefficient"]
        print(f"| {wi} | {eta_p:.4f} ± {o['viscosity']['stderr']:.4f} | {fmt(hp)} | {fmt(psi1)} | {fmt(hpsi)} "
              f"| {hp['mean'] / 0.5:.3f} |")
    print()
    plot_connffessit(rows)


def plot_connffessit(rows):
    """Signed errors of η and N₁ at Wi = 1 with their standard errors, against the cost."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("(matplotlib missing: no plot)\n")
        return
    fig, ax = plt.subplots(figsize=(5.5, 3.8))
    for name, label, marker in (("viscosity", "η", "o"), ("first_normal_stress_difference", "N₁", "s")):
        ax.errorbar([r[2] for r in rows], [100 * (r[1][name]["mean"] - 1) for r in rows],
                    yerr=[100 * r[1][name]["stderr"] for r in rows], fmt=marker + "-", capsize=3,
                    label=f"{label} error")
    ax.axhline(0, color="grey", lw=0.8)
    ax.set_xscale("log")
    ax.set_xlabel("cost (dumbbell-steps; N_d = 25, 100, 400, 1600)")
    ax.set_ylabel("relative error at Wi = 1 (%)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(ROOT, "docs/connffessit_shear.png"), dpi=120)
    print("![CONNFFESSIT error against cost](connffessit_shear.png)\n")


def channel_profiles(summary):
    """{t: [(y, u, u_exact)]} from the startup_profile checks of a summary."""
    return {float(v["name"].split(" at t = ")[1]): v.get("profile", [])
            for v in summary["validation"] if " at t = " in v["name"]}


def msph_channel():
    u_max = 0.072  # the steady centre velocity fH²/(8η₀), H = 24

    def stock_text(name):
        with open(os.path.join(ROOT, "cases", name)) as f:
            return f.read()

    def centre(profile):
        """(u, u_exact) at the centre: the mean of the two middle rows."""
        mid = [row for row in profile if abs(row[0] - 12.0) < 1.0]
        return sum(r[1] for r in mid) / len(mid), sum(r[2] for r in mid) / len(mid)

    newtonian, ucm = stock_text("msph_channel_2d.toml"), stock_text("maxwell_ucm_channel_2d.toml")
    # Pairwise SPH: the stock Oldroyd-B case, and its Newtonian twin (η = 1 by Morris's term).
    sph_ucm = stock_text("sph_ucm_channel_2d.toml")
    polymer = sph_ucm[sph_ucm.index("[fluid.polymer]"):sph_ucm.index("[walls]")]
    sph_newtonian = sph_ucm.replace(polymer, "").replace("viscosity = 0.1\n", "viscosity = 1.0\n")
    assert "[fluid.polymer]" not in sph_newtonian and "viscosity = 1.0\n" in sph_newtonian
    literal = (newtonian.replace('treatment = "mirror"', 'treatment = "layers"')
               .replace("morris_share = 0.1\n", "").replace("tolerance = 0.03", "tolerance = 100.0"))
    print("### The paper's channel (cases/msph_channel_2d.toml, maxwell_ucm_channel_2d.toml)\n")
    print("Start-up Poiseuille flow in Murashima & Taniguchi's channel: 20a × 24a of fluid (480 particles) "
          "between walls three rows thick, f = 10⁻³, Δt = 0.01, η₀ = 1, c = 1, truncated Gaussian "
          "h = 2a; the polymer fluids carry η_s = 0.1 by Morris's term and η_p = 0.9 (Oldroyd-B β = 0.1, "
          "docs/theory/msph_dumbbells.md §3 T2). Errors: the largest over the 24 rows of "
          "|ū − u_series| and the centre rows' "
          "error, both in % of the scale (0.072, or the λ = 1000 plug's centre velocity at t = 150, "
          "0.1459). Pairwise SPH (cases/sph_ucm_channel_2d.toml): quintic spline h = 1.2a (support 3.6a, "
          "four wall rows), c = 10, Morris wall images with the cap on β = 1 + d_j/d_i at 6 (and at the "
          "usual 1.5).\n")
    print("| fluid | scheme | Δt | profile error t = 50 / 100 / 150 | centre error t = 50 / 100 / 150 | wall s |")
    print("|---|---|---|---|---|---|")
    rows = [("Newtonian", "MSPH, mirror walls", newtonian, []),
            ("Newtonian", "MSPH, the paper's literal walls, η_s = 0", literal, []),
            ("Newtonian", "pairwise SPH", sph_newtonian, []),
            ("Newtonian", "pairwise SPH, cap 1.5", sph_newtonian, ["walls.morris_cap=1.5"]),
            ("UCM λ = 10", "MSPH, mirror walls", ucm, []),
            ("UCM λ = 10", "MSPH, mirror walls", ucm, ["integrator.dt=0.02", "run.steps=7500", "run.sample_every=250"]),
            ("UCM λ = 10", "MSPH, mirror walls", ucm, ["integrator.dt=0.005", "run.steps=30000", "run.sample_every=1000"]),
            ("UCM λ = 10", "pairwise SPH", sph_ucm, []),
            ("UCM λ = 10", "pairwise SPH, cap 1.5", sph_ucm, ["walls.morris_cap=1.5"]),
            ("UCM λ = 1000", "MSPH, mirror walls", ucm, ["fluid.polymer.relaxation_time=1000"])]
    ucm_profiles = None
    for fluid, scheme, text, sets in rows:
        s, cmd, err = launch_text(text, sets)
        dt = next((x.split("=")[1] for x in sets if x.startswith("integrator.dt")), "0.01")
        if s is None:
            print(f"| {fluid} | {scheme} | {dt} | failed: {err.strip().splitlines()[-1][:80] if err.strip() else '?'} | | |")
            continue
        errs = startup_errors(s)
        profiles = channel_profiles(s)
        scale = u_max if "1000" not in fluid else 0.1459
        cents = []
        for t in sorted(profiles):
            u, ue = centre(profiles[t])
            cents.append(f"{100 * (u - ue) / scale:+.2f}")
        print(f"| {fluid} | {scheme} | {dt} | {' / '.join(f'{100 * errs[t]:.2f}' for t in sorted(errs))} % "
              f"| {' / '.join(cents)} % | {s['wall_seconds']:.0f} |")
        if fluid == "UCM λ = 10" and scheme.startswith("MSPH") and not sets:
            ucm_profiles = profiles
    print()
    print("CONNFFESSIT (cases/connffessit_channel_2d.toml: the UCM λ = 10 case with N_d Hookean dumbbells "
          "per fluid particle instead of the constitutive equation, seed 1): the row-mean velocity "
          "against the UCM run on the same particles (same MSPH error, so the difference is the "
          "dumbbells' noise and bias) and against the series; max and rms over the 24 rows, in % of "
          "0.072, at t = 50 / 100 / 150.\n")
    print("| N_d | max abs(ū − ū_UCM) | rms(ū − ū_UCM) | max abs(ū − u_series) | dumbbell-steps | wall s | ensembles s |")
    print("|---|---|---|---|---|---|---|")
    cf = stock_text("connffessit_channel_2d.toml").replace("tolerance = 0.075", "tolerance = 100.0")
    for n_d in (250, 1000, 4000, 10000):
        s = run_text(cf, [f"fluid.polymer.per_particle={n_d}"])
        profiles = channel_profiles(s)
        errs = startup_errors(s)
        maxd, rmsd = [], []
        for t in sorted(profiles):
            d = [(a[1] - b[1]) / u_max for a, b in zip(profiles[t], ucm_profiles[t])]
            maxd.append(f"{100 * max(abs(x) for x in d):.2f}")
            rmsd.append(f"{100 * math.sqrt(sum(x * x for x in d) / len(d)):.2f}")
        work = 480 * n_d * s["steps"]
        print(f"| {n_d} | {' / '.join(maxd)} | {' / '.join(rmsd)} | "
              f"{' / '.join(f'{100 * errs[t]:.2f}' for t in sorted(errs))} | {work:.2e} | "
              f"{s['wall_seconds']:.0f} | {s['phase_seconds']['particle_state']:.0f} |")
    print()
    # The Newtonian channel in 3D (periodic in z, 10a deep) against 2D at t = 50.
    to50 = {"steps = 15000": "steps = 5000", "times = [50.0, 100.0, 150.0]": "times = [50.0]"}
    three = {"dimension = 2": "dimension = 3", "lengths = [20.0, 24.0]": "lengths = [20.0, 24.0, 10.0]",
             'boundaries = ["periodic", "wall"]': 'boundaries = ["periodic", "wall", "periodic"]',
             "body_force = [1e-3, 0.0]": "body_force = [1e-3, 0.0, 0.0]"}
    runs = {}
    for d, edits in ((2, to50), (3, {**to50, **three})):
        text = newtonian
        for a, b in edits.items():
            assert a in text, a
            text = text.replace(a, b)
        runs[d] = run_text(text)
    p2, p3 = (channel_profiles(runs[d])[50.0] for d in (2, 3))
    diff = max(abs(a[1] - b[1]) for a, b in zip(p2, p3)) / u_max
    print(f"The Newtonian channel in 3D (20a × 24a × 10a, periodic in z; 4 800 fluid particles, 10 × 10 "
          f"systems) at t = 50: every row within {100 * startup_errors(runs[3])[50.0]:.2f} % of 0.072 of "
          f"the series (2D: {100 * startup_errors(runs[2])[50.0]:.2f} %) and within {100 * diff:.2f} % of "
          f"the 2D profile; {runs[3]['wall_seconds']:.0f} s (2D: {runs[2]['wall_seconds']:.0f} s).\n")


def connffessit_channel_seeds():
    """The seed spread that cases/connffessit_channel_2d.toml and the README quote: the stock case
    at seeds 1–4, max over rows |ū − u_series| / 0.072 at t = 50, 100, 150; mean and sd of the
    12 errors; each seed against the case's 7.5 % (~5 min on 2 cores)."""
    with open(os.path.join(ROOT, "cases/connffessit_channel_2d.toml")) as f:
        text = f.read()
    errors = []
    print("| seed | max row error t = 50 / 100 / 150 (% of 0.072) | wall s |")
    print("|---|---|---|")
    for seed in (1, 2, 3, 4):
        s, cmd, err = launch_text(text, [f"seed={seed}"])
        if s is None:
            verdict(f"connffessit_channel_2d seed {seed} runs", False, err.strip()[-200:])
            continue
        errs = startup_errors(s)
        row = [100 * errs[t] for t in sorted(errs)]
        errors += row
        print(f"| {seed} | {' / '.join(f'{e:.1f}' for e in row)} | {s['wall_seconds']:.0f} |")
        verdict(f"connffessit_channel_2d seed {seed}: every row within 7.5 % at t = 50, 100, 150",
                max(row) < 7.5, f"(worst {max(row):.2f} %)")
    if errors:
        mean = sum(errors) / len(errors)
        sd = math.sqrt(sum((e - mean) ** 2 for e in errors) / max(len(errors) - 1, 1))
        print(f"\n{len(errors)} errors: mean {mean:.1f} %, sd {sd:.1f} % (the case file quotes "
              "mean 3.7 %, sd 0.9 %)")


def coupled_configuration_fields():
    """The coupled CONNFFESSIT shear with `fluid.polymer.noise = "configuration_fields"` against
    Oldroyd-B (tools/coupled_bias.py's points; docs/validation.md, "The cause, and its removal"):
    N_d = 1 000 at Wi = 1, 2 (p_b = 5) and 4 (p_b = 20 > τ_xx, below which the tensile instability
    grows), seeds 1–4, and N_d = 10 000 at Wi = 2 (p_b = 5) and 4 (p_b = 20), seed 1. Checks: every setting's mean flux
    bias of η and N₁ within 4 of its error bars (seed scatter/√4; the run's block error for one
    seed): unbiased, where independent noise is +3.6 % (η) at Wi = 2; and the N_d = 10 000 run
    within 1 % at Wi = 2 (the issue's target), which its ±0.12 % (η) and ±0.6 % (N₁) can
    resolve; at Wi = 4 one seed's ±0.4 % and ±0.7 % cannot (measured −0.83 %, −1.07 %: no 1 %
    check there, the 4σ one only). About 65 core-minutes."""
    import importlib.util
    spec = importlib.util.spec_from_file_location(
        "coupled_bias", os.path.join(ROOT, "tools", "coupled_bias.py"))
    cb = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(cb)
    out = os.path.join(ROOT, "out", "validate", "coupled_configuration_fields")
    os.makedirs(out, exist_ok=True)
    noise = "configuration_fields"
    points = [(wi, 1000, 5.0 if wi < 4 else 20.0, seed) for wi in (1.0, 2.0, 4.0)
              for seed in (1, 2, 3, 4)] + [(2.0, 10000, 5.0, 1), (4.0, 10000, 20.0, 1)]
    for wi, nd, pb, seed in points:
        cb.run_point(BIN, out, wi, nd, pb, 400.0, seed, 2, noise)
    groups = cb.aggregate(cb.read_points(out))
    print("| Wi | N_d | p_b | seeds | η flux | N₁ flux |")
    print("|---|---|---|---|---|---|")
    for g in groups:
        pct = lambda k: f"{100 * g[k]:+.2f} ± {100 * g[k + '_err']:.2f} %"
        print(f"| {g['wi']:g} | {g['nd']:g} | {g['pb']:g} | {g['seeds']} | {pct('eta_flux')} | "
              f"{pct('n1_flux')} |")
        for k, name in (("eta_flux", "η"), ("n1_flux", "N₁")):
            detail = f"({100 * g[k]:+.2f} ± {100 * g[k + '_err']:.2f} %)"
            verdict(f"configuration fields Wi = {g['wi']:g}, N_d = {g['nd']:g}: {name} unbiased "
                    "within 4σ", abs(g[k]) <= 4 * g[k + "_err"], detail)
            if g["nd"] >= 10000 and g["wi"] <= 2:
                verdict(f"configuration fields Wi = {g['wi']:g}, N_d = {g['nd']:g}: {name} "
                        "within 1 %", abs(g[k]) < 0.01, detail)


def weak_order():
    """Bias of the stock Hookean shear scene's Ψ₁/(2Gλ²) − 1 and η_p/(Gλ) − 1 against Δt, for
    Euler–Maruyama and Heun, with the averaging time long enough that the bias is resolved; the
    slope of log|bias| against log Δt by weighted least squares (weights 1/σ_log²)."""
    case = "dumbbells_hookean_shear_3d.toml"
    print("### Weak order of the dumbbell schemes, measured (cases/dumbbells_hookean_shear_3d.toml)\n")
    print("600 particles × 1 000 Hookean dumbbells, Wi = 1, 8λ of start-up, then t_avg of averaging; "
          "bias = estimate − exact (η_p = Gλ, Ψ₁ = 2Gλ²), ± the standard error over particles.\n")
    print("| scheme | Δt/λ | t_avg/λ | η_p/(Gλ) − 1 | Ψ₁/(2Gλ²) − 1 | wall s |")
    print("|---|---|---|---|---|---|")
    plan = {"euler_maruyama": [(0.2, 200.0), (0.1, 200.0), (0.05, 200.0), (0.025, 100.0)],
            "heun": [(0.4, 400.0), (0.2, 400.0), (0.1, 400.0)]}
    slopes = {}
    for scheme, points in plan.items():
        xs, ys, ws = [], [], []
        for dt, t_avg in points:
            eq = int(round(8.0 / dt))
            steps = eq + int(round(t_avg / dt))
            every = max(1, int(round(0.1 / dt)))
            s = run(case, [f"polymer.scheme={scheme}", f"integrator.dt={dt}", f"run.steps={steps}",
                           f"run.equilibration={eq}", f"run.sample_every={every}"])
            o = s["observables"]
            eta, psi = o["polymer_viscosity"], o["first_normal_stress_coefficient"]
            b, sb = psi["mean"] / 2 - 1, psi["stderr"] / 2
            print(f"| {scheme} | {dt} | {t_avg:.0f} | {eta['mean'] - 1:+.5f} ± {eta['stderr']:.5f} "
                  f"| {b:+.5f} ± {sb:.5f} | {s['wall_seconds']:.0f} |")
            if abs(b) > 3 * sb:
                xs.append(math.log(dt)); ys.append(math.log(abs(b))); ws.append((abs(b) / sb) ** 2)
        if len(xs) >= 2:
            sw = sum(ws); mx = sum(w * x for w, x in zip(ws, xs)) / sw; my = sum(w * y for w, y in zip(ws, ys)) / sw
            sxx = sum(w * (x - mx) ** 2 for w, x in zip(ws, xs))
            slope = sum(w * (x - mx) * (y - my) for w, x, y in zip(ws, xs, ys)) / sxx
            slopes[scheme] = (slope, math.sqrt(1 / sxx), len(xs))
    print()
    for scheme, (slope, err, n) in slopes.items():
        print(f"- {scheme}: slope of log|Ψ₁ bias| against log Δt = {slope:.2f} ± {err:.2f} "
              f"({n} points resolved beyond 3σ)")
    print()


FENE_OBSERVABLES = (("polymer_viscosity", "eta_p/(G lambda)"),
                    ("first_normal_stress_coefficient", "Psi1/(G lambda^2)"),
                    ("mean_square_connector_length", "<|Q|^2>"))


def fene_fokker_planck(dim, b, wi):
    """{observable: value} of the converged Fokker–Planck solution (tools/fene_fokker_planck.py),
    parsed from its printout; its η_p/(Gλ), Ψ₁/(Gλ²) and ⟨|Q|²⟩ (k_BT/H) are the scene's units
    at λ = G = 1 (both: dQ = (κ·Q − F/(2λ)) dt + √(1/λ) dW, τ = G(⟨QF⟩ − I))."""
    cmd = [sys.executable, os.path.join(ROOT, "tools", "fene_fokker_planck.py"),
           "--dim", str(dim), "--b", str(b), "--wi", str(wi)]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0 or "WARNING" in p.stdout:
        sys.exit(f"failed: {' '.join(cmd)}\n{p.stdout}{p.stderr}")
    labels = {label: name for name, label in FENE_OBSERVABLES}
    out = {}
    for line in p.stdout.splitlines():
        label, sep, value = line.partition("=")
        if sep and label.strip() in labels:
            out[labels[label.strip()]] = float(value)
    if len(out) != len(labels):
        sys.exit(f"cannot parse {' '.join(cmd)}:\n{p.stdout}")
    return out


def fene_table():
    """FENE dumbbells (cases/dumbbells_fene_shear_3d.toml, semi-implicit) in steady shear at
    b = 10, 50, Wi = 1, 10, in 2D and 3D, against the deterministic Fokker–Planck solution:
    (BD − FP)/σ for η_p, Ψ₁ and ⟨|Q|²⟩; the table also goes to docs/fene_table.csv."""
    import csv
    case = "dumbbells_fene_shear_3d.toml"
    print("### FENE dumbbells in steady shear against the Fokker–Planck solution "
          "(`cases/dumbbells_fene_shear_3d.toml` with `--set`)\n")
    print("Brownian dynamics (semi-implicit predictor–corrector, λ = G = 1) against the Galerkin "
          "solution of the dumbbell's Fokker–Planck equation (`tools/fene_fokker_planck.py --dim d "
          "--b b --wi Wi`, converged to ~10⁻⁸, run here). Δt = 0.01λ at Wi = 1 and 0.005λ at Wi = 10 "
          "(γ̇Δt ≤ 0.05; the scheme's O(Δt²) bias is ≲ 3·10⁻⁵ relative there: docs/validation.md's "
          "3D Δt sweep scaled as Δt²); 8λ of start-up at Wi = 1, 4λ at Wi = 10, then t_avg of averaging. σ is the "
          "standard error from the spread of the particles' own time averages (independent "
          "ensembles); every point has its own seed.\n")
    head = ["d", "b", "Wi", "Δt/λ", "particles × N_d, t_avg", "η_p BD ± σ", "FP", "(BD−FP)/σ",
            "Ψ₁ BD ± σ", "FP", "dev/σ", "⟨Q²⟩ BD ± σ", "FP", "dev/σ", "wall s"]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    rows, worst, seed = [], (0.0, None), 300
    for dim in (2, 3):
        for b in (10, 50):
            # (Wi, Δt/λ, start-up/λ, t_avg/λ, particles, N_d)
            for wi, dt, t_eq, t_avg, n, nd in ((1.0, 0.01, 8.0, 32.0, 400, 500),
                                              (10.0, 0.005, 4.0, 12.0, 400, 500)):
                fp = fene_fokker_planck(dim, b, wi)
                eq = int(round(t_eq / dt))
                steps = eq + int(round(t_avg / dt))
                s = run(case, [f"dimension={dim}", f"polymer.b={b}.0", f"flow.rate={wi}",
                               f"flow.particles={n}", f"polymer.per_particle={nd}",
                               f"integrator.dt={dt}", f"run.steps={steps}", f"run.equilibration={eq}",
                               f"run.sample_every={max(1, int(round(0.1 / dt)))}", f"seed={seed}",
                               "reference=[]"], ranks=1, threads=2)
                seed += 1
                o = s["observables"]
                row = [str(dim), str(b), f"{wi:g}", f"{dt:g}", f"{n} × {nd}, {t_avg:g}λ"]
                csv_row = {"d": dim, "b": b, "Wi": wi, "dt": dt, "t_eq": t_eq, "t_avg": t_avg,
                           "particles": n, "per_particle": nd}
                for name, _ in FENE_OBSERVABLES:
                    m, e = o[name]["mean"], o[name]["stderr"]
                    dev = (m - fp[name]) / e
                    # 4σ: 18 rows × 3 functions at a two-sided 4σ miss 6·10⁻⁵ each by chance.
                    verdict(f"d = {dim}, b = {b}, Wi = {wi:g}: {name} within 4σ of Fokker–Planck",
                            abs(dev) <= 4, f"({m:.5g} ± {e:.2g} against {fp[name]:.5g}, {dev:+.1f}σ)")
                    if abs(dev) > abs(worst[0]):
                        worst = (dev, f"d = {dim}, b = {b}, Wi = {wi:g}, {name}")
                    row += [f"{m:.4f} ± {e:.4f}", f"{fp[name]:.4f}", f"{dev:+.1f}"]
                    csv_row.update({name: m, f"{name}_stderr": e, f"{name}_fp": fp[name],
                                    f"{name}_dev_sigma": dev})
                csv_row["wall_seconds"] = s["wall_seconds"]
                rows.append(csv_row)
                row.append(f"{s['wall_seconds']:.0f}")
                print("| " + " | ".join(row) + " |", flush=True)
    print(f"\nLargest |BD − FP|/σ: {abs(worst[0]):.1f} ({worst[1]})\n")
    path = os.path.join(ROOT, "docs", "fene_table.csv")
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print("(CSV: docs/fene_table.csv)\n")

BDDFS_CASE = """
title = "T2 (Ellero Sec. 5.4): 2D FENE b = 50 in shear"
dimension = 2
seed = {seed}
[flow]
kind = "simple_shear"
rate = {rate}
particles = {particles}
[polymer]
kind = "{kind}"
spring = "fene"
b = 50.0
relaxation_time = 1.0
per_particle = {per_particle}
scheme = "semi_implicit"
{grid}
[integrator]
kind = "brownian_dynamics"
dt = {dt}
[run]
steps = {steps}
equilibration = {equilibration}
sample_every = {sample_every}
"""

BDDFS_OBSERVABLES = ("polymer_viscosity", "first_normal_stress_coefficient",
                     "mean_square_connector_length")


def bddfs_run(rate, dt, cells=None, particles=100, per_particle=1000, t_eq=3.0, t_avg=10.0,
              seed=45, threads=2):
    """One T2 run: BD (cells None) or BDDFS on n_c = cells; the same seed, so the same initial
    dumbbells and noise keys for both."""
    eq = int(round(t_eq / dt))
    text = BDDFS_CASE.format(
        seed=seed, rate=rate, particles=particles, per_particle=per_particle, dt=dt,
        kind="dumbbells" if cells is None else "bddfs",
        grid="" if cells is None else f"cells = {cells}",
        steps=eq + int(round(t_avg / dt)), equilibration=eq,
        sample_every=max(1, int(round(0.05 / dt))))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    s = run_text(text, ranks=1, threads=threads)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    # CPU seconds of the whole child run (set-up included), which a loaded machine does not
    # inflate the way it inflates wall seconds.
    s["_cpu_seconds"] = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    s["_dumbbell_steps"] = particles * per_particle * (eq + int(round(t_avg / dt)))
    return s


def bddfs_rel(s, bd, name):
    """(BDDFS − BD)/BD of an observable and its standard error (independent-error sum: the two
    runs share initial dumbbells and noise keys, so this is conservative)."""
    a, b = s["observables"][name], bd["observables"][name]
    rel = a["mean"] / b["mean"] - 1.0
    se = abs(a["mean"] / b["mean"]) * math.hypot(a["stderr"] / a["mean"], b["stderr"] / b["mean"])
    return rel, se


def bddfs_t2():
    """The thesis's T2 benchmark, relative: BDDFS against plain Brownian dynamics (the dumbbell
    model, same N_d, same Δt, same seed) for 2D FENE b = 50 in steady shear, with the grid's
    predicted artificial diffusion r = λΔQ²/(6Δt) (src/models/bddfs.rs) beside each error."""
    q_max = math.sqrt(50.0)
    n_d, particles = 1000, 100
    print("### BDDFS against Brownian dynamics: the thesis's T2, relative (`./run validate bddfs_t2`)\n")
    print(f"2D FENE b = 50, λ = G = 1, semi-implicit scheme, {particles} particles × {n_d} dumbbells "
          "(BD and BDDFS alike, the same seed: the same initial dumbbells and noise keys), 3λ of "
          "start-up then 10λ of averaging; grid [−√b, √b]². Relative differences (BDDFS − BD)/BD "
          "with the standard error of the difference (the two runs' errors added in quadrature). "
          "r = λΔQ²/(6Δt) is the grid's artificial diffusion relative to the Brownian one; "
          "memory is 8 B per occupied cell (measured occupancy) against N_d × 2 × 8 B for BD; "
          "CPU is wall seconds per dumbbell-step on 2 threads of a shared 2-core machine (noisy).\n")
    head = ["γ̇", "Δt/λ", "n_c", "r", "η_p", "Ψ₁", "⟨Q²⟩", "mem B/particle", "BD/BDDFS mem",
            "ns per dumbbell-step", "CPU vs BD"]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    results = {}

    def row(rate, dt, cells, s, bd):
        r = (2 * q_max / cells) ** 2 / 6.0 / dt if cells else 0.0
        ns = 1e9 * s["wall_seconds"] / s["_dumbbell_steps"]
        ns_bd = 1e9 * bd["wall_seconds"] / bd["_dumbbell_steps"]
        cells_used = s["observables"].get("occupied_histogram_cells", {}).get("mean")
        mem = 8.0 * cells_used if cells_used else 16.0 * n_d
        cols = [f"{rate:g}", f"{dt:g}", str(cells) if cells else "BD", f"{100 * r:.2f} %" if cells else "–"]
        rel = {}
        for name in BDDFS_OBSERVABLES:
            if cells:
                rel[name] = bddfs_rel(s, bd, name)
                cols.append(f"{100 * rel[name][0]:+.2f} ± {100 * rel[name][1]:.2f} %")
            else:
                cols.append(fmt(s["observables"][name]))
        cols += [f"{mem:.0f}", f"{16.0 * n_d / mem:.1f}" if cells else "1",
                 f"{ns:.0f}", f"{100 * (ns / ns_bd - 1):+.0f} %" if cells else "–"]
        print("| " + " | ".join(cols) + " |", flush=True)
        results[(rate, dt, cells)] = rel
        return rel

    for rate in (5.0, 0.01):
        bd = bddfs_run(rate, 0.01)
        row(rate, 0.01, None, bd, bd)
        for cells in ((40, 80, 200, 1000) if rate == 5.0 else (40, 80, 200)):
            row(rate, 0.01, cells, bddfs_run(rate, 0.01, cells), bd)
    for dt in (0.02, 0.005):
        bd = bddfs_run(5.0, dt)
        row(5.0, dt, None, bd, bd)
        row(5.0, dt, 200, bddfs_run(5.0, dt, 200), bd)
    print()
    eta = "polymer_viscosity"
    fine = results[(5.0, 0.01, 1000)]
    for name in BDDFS_OBSERVABLES:
        rel, se = fine[name]
        # r = 0.33 % at n_c = 1000: the issue's 1 % holds where the grid diffusion is below it.
        verdict(f"γ̇ = 5, n_c = 1000 (r = 0.33 %): {name} within 1 % of BD",
                abs(rel) <= 0.01,
                f"({100 * rel:+.2f} ± {100 * se:.2f} %)")
    coarse = [results[(5.0, 0.01, c)][eta] for c in (40, 80, 200)]
    verdict("γ̇ = 5: the η_p bias is positive and grows as n_c falls (200 → 80 → 40), each "
            "step beyond 3σ",
            coarse[2][0] > 3 * coarse[2][1]
            and coarse[1][0] - coarse[2][0] > 3 * math.hypot(coarse[1][1], coarse[2][1])
            and coarse[0][0] - coarse[1][0] > 3 * math.hypot(coarse[0][1], coarse[1][1]),
            f"({', '.join(f'{100 * c[0]:+.1f} %' for c in coarse)})")
    # The ΔQ²/Δt law at n_c = 200 (r = 4.2, 8.3, 16.7 %): halving Δt doubles the error. The
    # law is first order in r, so the ratio may deviate from 2 by O(r): 25 % allowed.
    e = {dt: results[(5.0, dt, 200)][eta] for dt in (0.02, 0.01, 0.005)}
    for fine_dt, coarse_dt in ((0.01, 0.02), (0.005, 0.01)):
        ratio = e[fine_dt][0] / e[coarse_dt][0]
        verdict(f"γ̇ = 5, n_c = 200: the η_p error at Δt = {fine_dt:g} is 2× that at {coarse_dt:g} "
                "(ΔQ²/Δt law, ±25 %)", 1.5 <= ratio <= 2.5, f"(×{ratio:.2f})")
    print("The thesis's Tab. 5.1 (γ̇ = 5, N_d = 10⁶, its unknown b): +16.5, +4.3, +0.34 % in η at "
          "n_c = 40, 80, 200. Here (b = 50) the grid errors are those of the ΔQ²/Δt law, "
          "far larger at n_c = 200, as the spec's own NumPy runs found (+6.3 % at Δt = 0.01).\n")


# The settings of `bddfs_memory`: (Δt/λ, n_c or None for BD), in the order run.
BDDFS_MEMORY_RUNS = [(0.08, None), (0.08, 200), (0.08, 280), (0.08, 400),
                     (0.04, None), (0.04, 400)]


def bddfs_memory():
    """The issue's "at equal accuracy (η within 1 %), ≥ 50× less memory per particle and
    ≤ +20 % CPU per dumbbell-step" at the thesis's N_d = 10⁶: T2 (2D FENE b = 50, Wi = 5,
    semi-implicit) with 4 particles × 10⁶ dumbbells, 3λ of start-up and 1λ of averaging, 1 thread,
    BD against BDDFS at larger Δt (the grid's bias ≈ 0.8 r, r = λΔQ²/(6Δt): at fixed r the
    occupied cells fall as 1/ΔQ² ∝ 1/Δt). Memory: the stored bytes per particle each run
    reports (BD N_d × 2 × 8 B; BDDFS 8 B per occupied cell at the end of the run)."""
    n_d, particles = 1_000_000, 4
    q_max = math.sqrt(50.0)
    print("### BDDFS memory at equal accuracy, N_d = 10⁶ (`./run validate bddfs_memory`)\n")
    print(f"T2: 2D FENE b = 50, Wi = 5, semi-implicit, {particles} particles × {n_d} dumbbells, "
          "3λ of start-up then 1λ of averaging, the same seed for all; 1 rank × 1 thread. "
          "Difference (BDDFS − BD)/BD at the same Δt with the two runs' standard errors in "
          "quadrature; FP: the Fokker–Planck η_p = 0.613257. CPU: the child run's CPU seconds "
          "(user + system, set-up included) per dumbbell-step against the BD run at that Δt; "
          "the loop's wall seconds beside it (a shared machine inflates them).\n")
    head = ["Δt/λ", "n_c", "r", "η_p", "vs FP", "BDDFS − BD", "occupied cells", "B/particle",
            "BD/BDDFS memory", "CPU ns per dumbbell-step", "CPU vs BD", "loop wall ns"]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    runs = []
    for dt, cells in BDDFS_MEMORY_RUNS:
        s = bddfs_run(5.0, dt, cells, particles=particles, per_particle=n_d, t_eq=3.0,
                      t_avg=1.0, threads=1)
        runs.append((dt, cells, s))
    fp = 0.613257
    best = None
    for dt, cells, s in runs:
        bds = [b for d, c, b in runs if d == dt and c is None]
        bd_eta = sum(b["observables"]["polymer_viscosity"]["mean"] for b in bds) / len(bds)
        bd_se = math.sqrt(sum(b["observables"]["polymer_viscosity"]["stderr"] ** 2
                              for b in bds)) / len(bds)
        bd_bytes = bds[0]["ensemble_bytes_per_particle"]
        ns_bd = sum(1e9 * b["_cpu_seconds"] / b["_dumbbell_steps"] for b in bds) / len(bds)
        e = s["observables"]["polymer_viscosity"]
        ns = 1e9 * s["_cpu_seconds"] / s["_dumbbell_steps"]
        wall_ns = 1e9 * s["loop_seconds"] / s["_dumbbell_steps"]
        mem = s["ensemble_bytes_per_particle"]
        cols = [f"{dt:g}", str(cells) if cells else "BD"]
        if cells:
            r = (2 * q_max / cells) ** 2 / (6 * dt)
            d = e["mean"] / bd_eta - 1
            sd = abs(e["mean"] / bd_eta) * math.hypot(e["stderr"] / e["mean"], bd_se / bd_eta)
            cols += [f"{100 * r:.2f} %", fmt(e), f"{100 * (e['mean'] / fp - 1):+.2f} %",
                     f"{100 * d:+.2f} ± {100 * sd:.2f} %",
                     f"{s['observables']['occupied_histogram_cells']['mean']:.0f}",
                     f"{mem:.0f}", f"{bd_bytes / mem:.1f}×", f"{ns:.0f}",
                     f"{100 * (ns / ns_bd - 1):+.0f} %", f"{wall_ns:.0f}"]
            if abs(d) + 2 * sd <= 0.01 and (best is None or bd_bytes / mem > best[0]):
                best = (bd_bytes / mem, dt, cells, d, sd, ns / ns_bd - 1)
        else:
            cols += ["–", fmt(e), f"{100 * (e['mean'] / fp - 1):+.2f} %", "–", "–",
                     f"{mem:.0f}", "1", f"{ns:.0f}", "–", f"{wall_ns:.0f}"]
        print("| " + " | ".join(cols) + " |", flush=True)
    print()
    verdict("some setting has η_p within 1 % of BD with 2σ to spare and ≥ 50× less memory per "
            "particle", best is not None and best[0] >= 50.0,
            "(none within 1 %)" if best is None else
            f"(best: Δt = {best[1]:g}, n_c = {best[2]}: {best[0]:.0f}×, "
            f"{100 * best[3]:+.2f} ± {100 * best[4]:.2f} %)")
    if best is not None:
        verdict("that setting costs ≤ +20 % CPU per dumbbell-step against BD", best[5] <= 0.20,
                f"({100 * best[5]:+.0f} %)")


THESIS_ETA_K = [28.9, 28.3, 26.8, 25.0]  # Nguyen 2021 ch. 4, η_k at k = 2πj/15, j = 1 … 4
THESIS_ETA_0 = 29.02


def transverse_current():
    """η(k) of Nguyen's ch. 4 solvent by TCAF (cases/dpd_transverse_current_3d.toml, ~1 h on 2
    threads), against the thesis's η_k at the four smallest k and η₀; and our Lees–Edwards
    NEMD η of the same fluid at γ̇ = 0.2 (9³). An existing output directory of the TCAF case can
    be given as MESORHEO_TCAF_OUT to skip its run. Plot: docs/transverse_current.png."""
    out = os.environ.get("MESORHEO_TCAF_OUT")
    if not out:
        out = os.path.join(ROOT, "out", "validate_transverse_current")
        cmd = [BIN, "run", os.path.join(ROOT, "cases", "dpd_transverse_current_3d.toml"),
               "--out", out, "-t", "2", "-q"]
        p = subprocess.run(cmd, env=ENV, capture_output=True, text=True)
        if p.returncode not in (0, 3):
            sys.exit(f"failed: {' '.join(cmd)}\n{p.stderr}")
    with open(os.path.join(out, "summary.json")) as f:
        obs = json.load(f)["observables"]
    rows = {}
    with open(os.path.join(out, "transverse_current.csv")) as f:
        next(f)
        for line in f:
            v = [float(x) for x in line.split(",")]
            rows.setdefault(int(v[0]), []).append(v)
    print("| j | k | η_k (ours) | thesis | difference | τ_k | C⊥(k,0) / k²k_BT/m |")
    print("|---|---|---|---|---|---|---|")
    ks, etas, errs = [], [], []
    for j in sorted(rows):
        r = rows[j][0]
        e = obs[f"transverse_current_viscosity_k{j}"]
        ks.append(r[1]); etas.append(e["mean"]); errs.append(e["stderr"])
        ref = THESIS_ETA_K[j - 1] if j <= len(THESIS_ETA_K) else None
        diff = f"{100 * (e['mean'] / ref - 1):+.1f} % ({(e['mean'] - ref) / e['stderr']:+.1f}σ)" if ref else ""
        print(f"| {j} | {r[1]:.4f} | {e['mean']:.2f} ± {e['stderr']:.2f} | {ref or ''} | {diff} | "
              f"{r[4]:.4f} ± {r[5]:.4f} | {r[6] / r[8]:.4f} ± {r[7] / r[8]:.4f} |")
    e0 = obs["transverse_current_viscosity"]
    print(f"η₀ = {e0['mean']:.2f} ± {e0['stderr']:.2f} (thesis {THESIS_ETA_0}: "
          f"{100 * (e0['mean'] / THESIS_ETA_0 - 1):+.1f} %); k_BT = {fmt(obs['temperature'])}")
    nemd = run_text("""title = "Nguyen ch. 4 solvent, Lees-Edwards NEMD, 9^3"
dimension = 3
seed = 8
[box]
lengths = [9.0, 9.0, 9.0]
shear_rate = 0.2
[particles]
lattice = "random"
density = 4.0
temperature = 1.0
velocity_profile = "shear"
[fluid]
kind = "dpd"
kt = 1.0
cutoff = 1.5
[fluid.physical]
viscosity = 30.0
schmidt_number = 500.0
[integrator]
kind = "groot_warren"
dt = 0.002
lambda = 0.5
[neighbour]
skin = 0.3
[run]
steps = 60000
equilibration = 2000
sample_every = 20
[diagnostics]
observables = ["temperature", "viscosity"]
blocks = 10
""")
    eta_le = nemd["observables"]["viscosity"]
    print(f"Lees–Edwards NEMD (9³, γ̇ = 0.2, 6·10⁴ steps): η = {fmt(eta_le)} (thesis Couette 29.08); "
          f"TCAF η₀ − NEMD = {100 * (e0['mean'] / eta_le['mean'] - 1):+.1f} %")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    a.errorbar(ks, etas, yerr=errs, fmt="o", label="mesorheo TCAF (Maxwell fits)")
    a.plot([2 * math.pi * j / 15 for j in range(1, 5)], THESIS_ETA_K, "s", mfc="none",
           label="Nguyen 2021 (62 data sets)")
    a.errorbar([0], [e0["mean"]], yerr=[e0["stderr"]], fmt="D", label="η₀ (k → 0, 4 smallest k)")
    a.errorbar([0.03], [eta_le["mean"]], yerr=[eta_le["stderr"]], fmt="^", label="LE NEMD, γ̇ = 0.2")
    a.axhline(30, color="grey", lw=0.6, ls=":")
    a.set_xlabel("k"); a.set_ylabel("η_k"); a.legend(fontsize=8)
    for j in sorted(rows)[:4]:
        t = [r[9] for r in rows[j]]
        b.plot(t, [r[10] for r in rows[j]], ".", ms=3, label=f"k{j} measured")
        b.plot(t, [r[11] for r in rows[j]], "-", lw=0.8, color=b.lines[-1].get_color())
    b.set_xscale("log"); b.set_xlabel("t"); b.set_ylabel("C⊥(k,t)/C⊥(k,0)"); b.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(ROOT, "docs", "transverse_current.png"), dpi=110)


T8_THESIS_VV = {5e-4: None, 2.5e-4: None, 1e-4: 0.8917, 7.5e-5: 0.9164, 5e-5: 0.9422, 2.5e-5: 0.9696,
                1e-5: 0.9872}  # Nguyen 2021 Table 3.1, velocity-Verlet column (None: diverged)
T8_THESIS_SETD = {5e-4: 0.4928, 2.5e-4: 0.7717, 1e-4: 0.9525, 7.5e-5: 0.9723, 5e-5: 0.9871, 2.5e-5: 0.9959,
                  1e-5: 0.9984}  # the same table, SETD column


def mean_field_friction_rate(case):
    """ω₀ = γ n [w_D]/(d m) of a DPD case as run (its mapped γ and s): the rate the exponential
    thermostat integrates exactly (docs/theory/dpd_physical_parameters.md §10 A7;
    src/models/dpd/time_step.rs)."""
    fluid, d = case["fluid"], case["dimension"]
    s, rc = fluid["weight_exponent"], fluid["cutoff"]
    n, m = case["particles"]["density"], case["particles"]["mass"]
    if d == 2:
        wd = 2 * math.pi * rc ** 2 / ((s + 1) * (s + 2))
    else:
        wd = 8 * math.pi * rc ** 3 / ((s + 1) * (s + 2) * (s + 3))
    return fluid["gamma"] * n * wd / (d * m)


def fuzz():
    """The ignored long fuzz of tests/check_fuzz.rs: every stock case mutated as text and taken
    through what `mesorheo check` does, asserting no panic and no hang."""
    variants = os.environ.get("MESORHEO_FUZZ_VARIANTS", "100000")
    print(f"### Fuzz of the stock case files through check ({variants} variants per case)\n")
    env = dict(ENV, MESORHEO_FUZZ_VARIANTS=variants)
    p = subprocess.run(["cargo", "test", "--release", "--test", "check_fuzz", "--",
                        "--ignored", "--nocapture", "long_fuzz_through_check"],
                       cwd=ROOT, env=env, capture_output=True, text=True)
    tail = [l for l in (p.stdout + p.stderr).splitlines() if l.strip()][-12:]
    print("\n".join(tail))
    if p.returncode != 0:
        sys.exit("fuzz: a panic or a hang (above)")


def kt_vs_dt_low_mass():
    """Nguyen 2021 Table 3.1 (docs/theory/dpd_physical_parameters.md §8 T8): the low-mass Couette
    fluid (2D 10 × 10, n = 10, r_c = 1.6, m = 0.01, η = 100, α = 10 → a = 234.08, s̄ = 13.92,
    γ = 3.825; Lees–Edwards γ̇ = 0.2) under
    Groot–Warren velocity Verlet (λ = ½), explicit and with the exponential thermostat (SETD),
    against Δt: the profile-unbiased k_BT (100 bins of 0.1,
    the thesis's bin width along y), and k_BT_x = P_kin,xx/n, the kinetic stress about the same
    interpolated bin means divided by N (what a per-bin ⟨m V_x²⟩ without the degrees-of-freedom
    correction gives), and the exponential thermostat's shear viscosity against φη (its
    dissipative viscosity). t = 0.1 equilibration + 0.4 sampled per point (~4 min)."""
    base = """dimension = 2
seed = 12
[box]
lengths = [10.0, 10.0]
shear_rate = 0.2
[particles]
lattice = "random"
density = 10.0
mass = 0.01
temperature = 1.0
velocity_profile = "shear"
[fluid]
kind = "dpd"
kt = 1.0
cutoff = 1.6
[fluid.physical]
viscosity = 100.0
time_scale_ratio = 10.0
[integrator]
kind = "groot_warren"
dt = DT
lambda = 0.5
thermostat = "THERMOSTAT"
[neighbour]
skin = 0.3
[run]
steps = STEPS
equilibration = EQUIL
sample_every = EVERY
beyond_stability_limits = true
[diagnostics]
observables = ["temperature", "stress", "viscosity"]
profile_bins = 100
blocks = 10
"""
    print("| Δt | ω₀Δt | explicit k_BT | explicit k_BT_x = P_kin,xx/n | thesis VV | exponential k_BT | "
          "exponential η (φη_input = 100φ) | thesis SETD | steps |")
    print("|---|---|---|---|---|---|---|---|---|")
    omega0 = None  # γ n [w_D]/(d m), from the mapped fluid of the first run's summary
    for dt in sorted(T8_THESIS_VV, reverse=True):
        steps = int(round(0.5 / dt))
        row = {}
        for thermostat in ("explicit", "exponential"):
            text = (base.replace("DT", repr(dt)).replace("STEPS", str(steps))
                    .replace("EQUIL", str(steps // 5)).replace("EVERY", str(max(1, steps // 1000)))
                    .replace("THERMOSTAT", thermostat))
            summary, _, stderr = launch_text(text)
            row[thermostat] = (summary, stderr)
        cells = []
        for thermostat in ("explicit", "exponential"):
            summary, stderr = row[thermostat]
            if summary is not None and omega0 is None:
                omega0 = mean_field_friction_rate(summary["case"])
            if summary is None:
                cells.append([f"blow-up: {_stock_error(stderr)}", ""])
                continue
            o = summary["observables"]
            if thermostat == "explicit":
                kx = o["stress_kinetic_xx"]
                kx = {"mean": kx["mean"] / 10.0, "stderr": kx["stderr"] / 10.0}
                cells.append([fmt(o["temperature"]), fmt(kx)])
            else:
                x = omega0 * dt
                phi = -math.expm1(-x) / x
                cells.append([fmt(o["temperature"]), f"{fmt(o['viscosity'])} ({100 * phi:.1f})"])
        vv = T8_THESIS_VV[dt]
        vv = "diverges" if vv is None else f"{vv:.4f}"
        x = "?" if omega0 is None else f"{omega0 * dt:.3f}"
        print(f"| {dt:g} | {x} | {cells[0][0]} | {cells[0][1]} | {vv} | {cells[1][0]} | "
              f"{cells[1][1]} | {T8_THESIS_SETD[dt]:.4f} | {steps} |")


def dpd_maps(manifest="dpd_maps.txt"):
    """The maps of docs/stability/<manifest>: [(name, case, over, options, fixed overrides)]."""
    maps = []
    with open(os.path.join(ROOT, "docs/stability", manifest)) as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            name, case, over, options, fixed = [c.strip() for c in line.split("|")]
            maps.append((name, case, over, options.split(), fixed.split()))
    return maps


def dpd_stability(manifest="dpd_maps.txt"):
    """Runs every DPD stability map (a serial child per trial) and prints, per map, the measured
    bracket and `check`'s verdict at each point, then the summary over all points."""
    import csv, shutil
    out = os.path.join(ROOT, "docs/stability")
    rows = []
    for name, case, over, options, fixed in dpd_maps(manifest):
        work = os.path.join(tempfile.gettempdir(), f"mesorheo_stability_{name}")
        args = ["stability", f"cases/{case}", "--over", over, *options, "--steps", "1000",
                "--tolerance", "0.03"]
        for f in fixed:
            args += ["--set", f]
        print("mesorheo " + " ".join(args), file=sys.stderr)
        # MESORHEO_STABILITY_TABLES_ONLY=1: the tables of the CSVs already in docs/stability/.
        if not os.environ.get("MESORHEO_STABILITY_TABLES_ONLY"):
            shutil.rmtree(work, ignore_errors=True)
            args[1] = os.path.join(ROOT, args[1])
            subprocess.run([BIN, *args, "--out", work, "-q"], env=ENV, check=False)
            for ext in ("csv", "png"):
                src = os.path.join(work, f"stability.{ext}")
                if os.path.exists(src):
                    shutil.copy(src, os.path.join(out, f"{name}.{ext}"))
        with open(os.path.join(out, f"{name}.csv")) as f:
            for r in csv.DictReader(f):
                key = next(iter(r))
                rows.append((name, f"{key} = {float(r[key]):.4g}", float(r["largest_stable"]),
                             float(r["smallest_unstable"]), float(r["check_limit"])))
    print("| map | point | largest stable Δt | smallest unstable | check's limit | check / unstable | check accepts |")
    print("|---|---|---|---|---|---|---|")
    for name, point, stable, unstable, limit in rows:
        accepts = min(limit, stable) / stable
        mark = "**" if accepts < 0.8 or limit >= unstable else ""
        print(f"| {name} | {point} | {stable:.4g} | {unstable:.4g} | {limit:.4g} | "
              f"{limit / unstable:.3f} | {mark}{100 * accepts:.0f} %{mark} |")
    for name, point, stable, unstable, limit in rows:
        verdict(f"{name} at {point}: check refuses the smallest unstable Δt", limit < unstable,
                f"(check {limit:.4g}, unstable {unstable:.4g})")
    accepted = sorted(min(l, s) / s for _, _, s, _, l in rows)
    print(f"\n{len(rows)} points: check refuses the unstable step at "
          f"{sum(l < u for *_, u, l in rows)}; accepts ≥ 80 % of the stable range at "
          f"{sum(a >= 0.8 for a in accepted)}; worst {100 * accepted[0]:.0f} %, median "
          f"{100 * accepted[len(accepted) // 2]:.0f} %; largest check / unstable "
          f"{max(l / u for *_, u, l in rows):.3f}")


def dpd_held_out4():
    """The fourth held-out DPD stability set (docs/stability/dpd_held_out4.txt, chosen and
    committed before the margin fitted to the third set was evaluated there)."""
    dpd_stability("dpd_held_out4.txt")


def default_weissenberg():
    """The default scene (cases/default.toml, Lucy 4Δ, 1 000 dumbbells per particle, p_b = 0) at
    Wi = 2 (p_t = 50 = 12.5 τ_xx, c₀ = 10, Δt = 1.5·10⁻³) and Wi = 4 (p_t = 200 = 12.5 τ_xx,
    c₀ = 20, Δt = 7.5·10⁻⁴), seeds 1–3, averaged over t ∈ [9 λ, 27 λ]: the momentum-flux η and N₁ against Oldroyd-B (η = η_s + η_p = 1, N₁ = 2η_pλγ̇² = Wi²).
    Tolerances: η 1 %, N₁ 1.3 % on every seed. The seeds measured on 2026-11-27 read, mean ± seed
    standard deviation, Wi = 2 (over [9 λ, 18 λ]): η −0.54 ± 0.05 %, N₁ −0.68 ± 0.07 %; Wi = 4: η +0.32 ± 0.07 %,
    N₁ +0.52 ± 0.17 %; the bounds are the largest |mean| + 4.5 sd of the two (η: 0.77 %, N₁:
    1.29 %), rounded up. A sign error or a lost factor of the polymer force moves η by ≈ 50 %;
    p_t = 50 at Wi = 4 (3 τ_xx, below check's 12 τ_xx rule) reads η +5 %, and misses."""
    settings = {
        2: ["box.shear_rate=2.0", "fluid.sound_speed=10.0", "integrator.dt=1.5e-3",
            "fluid.transport_pressure=50.0", "run.equilibration=6000", "run.steps=18000"],
        4: ["box.shear_rate=4.0", "fluid.sound_speed=20.0", "integrator.dt=7.5e-4",
            "fluid.transport_pressure=200.0", "run.equilibration=12000", "run.steps=36000"],
    }
    pinned = ["fluid.smoothing_length=0.2", "fluid.background_pressure=0.0",
              "fluid.polymer.per_particle=1000", "fluid.polymer.relaxation_time=1.0",
              "fluid.polymer.viscosity=0.5", "fluid.viscosity=0.5", "diagnostics.blocks=5"]
    print("### The default scene at Wi = 2 and 4 (`./run validate default_weissenberg`)\n")
    print("Relative errors of the momentum flux (`viscosity`, `first_normal_stress_difference`) "
          "and of the particles' own stress (`_constitutive`) against η = 1, N₁ = 2η_pλγ̇² = Wi², "
          "± the run's block error; one rank × 2 threads. Bounds: |η error| ≤ 1 %, "
          "|N₁ error| ≤ 1.3 % per seed.\n")
    print("| Wi | p_t/τ_xx | seed | flux η | flux N₁ | particles' η | particles' N₁ | wall s |")
    print("|---|---|---|---|---|---|---|---|")
    for wi, sets in settings.items():
        n1 = float(wi * wi)
        tension = 2 * 0.5 * 1.0 * wi * wi
        pt = float(sets[3].split("=")[1])
        for seed in (1, 2, 3):
            s = run("default.toml", sets + pinned + [f"seed={seed}"])
            o = s["observables"]

            def rel(name, want):
                e = o[name]
                return 100 * (e["mean"] / want - 1), 100 * e["stderr"] / want

            cells = [rel("viscosity", 1.0), rel("first_normal_stress_difference", n1),
                     rel("viscosity_constitutive", 1.0),
                     rel("first_normal_stress_difference_constitutive", n1)]
            text = " | ".join(f"{m:+.2f} ± {e:.2f} %" for m, e in cells)
            print(f"| {wi} | {pt / tension:.1f} | {seed} | {text} | {s['wall_seconds']:.0f} |",
                  flush=True)
            verdict(f"Wi = {wi} seed {seed}: flux η within 1 %", abs(cells[0][0]) <= 1.0,
                    f"{cells[0][0]:+.2f} %")
            verdict(f"Wi = {wi} seed {seed}: flux N₁ within 1.3 %", abs(cells[1][0]) <= 1.3,
                    f"{cells[1][0]:+.2f} %")
    print()

# Hasimoto (1959), simple cubic array of spheres, with Sangani & Acrivos ("Slow flow through a
# periodic array of spheres", Int. J. Multiphase Flow 8, 343, 1982) extending the series: the
# drag F = 6πηaU / K(c) on each sphere
# of a periodic cubic array of cell side L, c = (4π/3)a³/L³ the spheres' volume fraction, U the
# mean velocity of the fluid relative to the spheres.
def hasimoto_cubic_k(c):
    x = c ** (1.0 / 3.0)
    return 1.0 - 1.7601 * x + c - 1.5593 * c**2 + 3.9799 * x**8 - 3.0734 * x**10


def stokes_radius_in_cubic_cell(zeta, eta, cell):
    """The radius a of the sphere whose drag coefficient ζ = F/U in a periodic cube of side
    `cell` is 6πηa/K(c) (hasimoto_cubic_k), by fixed-point iteration a = ζK(c(a))/(6πη)."""
    a = zeta / (6 * math.pi * eta)
    for _ in range(200):
        a = zeta * hasimoto_cubic_k(4 * math.pi / 3 * a**3 / cell**3) / (6 * math.pi * eta)
    return a


def suspension_viscosity():
    """Relative viscosity of rigid colloids in physical-parameter DPD against φ (issue #44, T12–T14;
    cases/dpd_suspension_viscosity_3d.toml with --set): Lees–Edwards shear of octahedral bodies at
    body counts 19, 38, 85 (φ_p = N_C/(N_C + N_S) = 0.053, 0.100, 0.199), beside their free twins
    (tie springs cut, H = 10⁻⁹: the thesis's "free" system of ch. 5 §2.2) and the solvent alone.

    The reference solvent is the solvent alone at the suspension's solvent number density
    (n_S = 4, the stock case without [fluid.colloids]): Einstein's η₀ is the viscosity of the
    fluid the bodies are put into, and it is the thesis's "original" η_r (L1428, spec §6.4:
    η_susp over the Couette solvent viscosity). η_r = η/η_S is compared with 1 + 2.5φ for two
    volume fractions: the thesis's particle fraction φ_p (what its Fig. 5.4 plots against
    Einstein) and the hydrodynamic φ_h = n_b (4π/3) a_h³ with the Stokes radius a_h from the drag
    on one fixed body (Hasimoto 1959, simple cubic). The free twin at the same particles shows what
    the constituents add as particles; η/η_free − 1 is what rigidity adds.
    Checks: the intrinsic viscosity (η/η_S − 1)/φ at the most dilute point against Einstein's 2.5
    within 4σ, for φ_p and for φ_h; rigidity's share η/η_free − 1 against 2.5 φ_h within 4σ
    (~60 CPU-min; MESORHEO_SUSPENSION_RUNS=DIR keeps each run in DIR/<name>/ and reuses it;
    MESORHEO_SUSPENSION_STEPS overrides run.steps, default the case's 21 000)."""
    case = "dpd_suspension_viscosity_3d.toml"
    with open(os.path.join(ROOT, "cases", case)) as f:
        stock_text = f.read()
    reuse = os.environ.get("MESORHEO_SUSPENSION_RUNS")
    steps = os.environ.get("MESORHEO_SUSPENSION_STEPS")
    length = [f"run.steps={int(steps)}"] if steps else []
    counts = (19, 38, 85)
    drag_force, drag_cell, drag_solvent = 0.15, 6.0, 864
    runs = {}
    for n in counts:
        runs[f"rigid_{n}"] = [f"fluid.colloids.count={n}"] + length
        runs[f"free_{n}"] = [f"fluid.colloids.count={n}", "fluid.colloids.spring_stiffness=1e-9"] + length
    # One fixed body in a resting periodic 6³ cell, the solvent driven by g = 0.15 (Re = ρUa/η ≈ 0.1);
    # the fluid's momentum relaxes in M_fluid/ζ ≈ 6.4 time units, hence 30 (6000 steps) before
    # sampling.
    runs["drag"] = ["box.shear_rate=0.0", f"box.lengths=[{drag_cell}, {drag_cell}, {drag_cell}]",
                    f"fluid.body_force=[{drag_force}, 0.0, 0.0]",
                    "fluid.colloids.count=1", "fluid.colloids.fixed=true", "run.steps=30000",
                    "run.equilibration=6000", 'diagnostics.observables=["momentum", "temperature"]']

    def one(name):
        keep = os.path.join(reuse, name) if reuse else None
        if keep and os.path.exists(os.path.join(keep, "summary.json")):
            with open(os.path.join(keep, "summary.json")) as f:
                return name, json.load(f)
        return name, run(case, runs[name], threads=1, keep=keep)

    from concurrent.futures import ThreadPoolExecutor
    with ThreadPoolExecutor(2) as pool:
        results = dict(pool.map(one, list(runs)))
    # The solvent alone (the stock case without [fluid.colloids]): the reference solvent.
    solvent_text = (stock_text.split("\n[fluid.colloids]\n")[0] + "\n[integrator]\n"
                    + stock_text.split("\n[integrator]\n")[1]).replace(
        '"colloid_velocity_variance"', "").replace('"temperature", ]', '"temperature"]')
    solvent_keep = os.path.join(reuse, "solvent") if reuse else None
    if solvent_keep and os.path.exists(os.path.join(solvent_keep, "summary.json")):
        with open(os.path.join(solvent_keep, "summary.json")) as f:
            solvent = json.load(f)
    else:
        with tempfile.NamedTemporaryFile("w", suffix=".toml", delete=False) as f:
            f.write(solvent_text)
        try:
            solvent = run(f.name, length, threads=1, keep=solvent_keep)
        finally:
            os.unlink(f.name)
    eta_s, eta_s_se = solvent["observables"]["viscosity"]["mean"], solvent["observables"]["viscosity"]["stderr"]
    d = results["drag"]
    n_solvent = 2048
    volume = 8.0**3
    u = d["observables"]["momentum_x"]["mean"] / drag_solvent
    u_se = d["observables"]["momentum_x"]["stderr"] / drag_solvent
    force = drag_solvent * drag_force  # steady state: the body holds the whole body force
    a_h = stokes_radius_in_cubic_cell(force / u, eta_s, drag_cell)
    # Its error: U and η_S perturbed by one standard error each, added in quadrature.
    a_u = stokes_radius_in_cubic_cell(force / (u + u_se), eta_s, drag_cell) - a_h
    a_e = stokes_radius_in_cubic_cell(force / u, eta_s + eta_s_se, drag_cell) - a_h
    a_h_se = math.hypot(a_u, a_e)
    print("### Suspension viscosity against φ (`./run validate suspension_viscosity`)\n")
    print(f"Solvent alone (n_S = 4, γ̇ = 1): η_S = {eta_s:.3f} ± {eta_s_se:.3f}. Drag on one fixed octahedron, "
          f"g = {drag_force}: U = {u:.4f} ± {u_se:.4f}, F = N_S m g = {force:.2f}, ζ = F/U = {force / u:.2f}; "
          f"Stokes radius with Hasimoto's K(c): a_h = {a_h:.4f} ± {a_h_se:.4f} "
          f"(K = {hasimoto_cubic_k(4 * math.pi / 3 * a_h**3 / drag_cell**3):.4f}, Re = ρUa_h/η = {4 * u * a_h / eta_s:.3f}).\n")
    print("| bodies | φ_p | φ_h | η (rigid) | η_free | η/η_S − 1 | (η/η_S − 1)/φ_p | (η/η_S − 1)/φ_h | "
          "η_free/η_S − 1 | η/η_free − 1 | 2.5φ_h | k_BT rigid | wall s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")

    def ratio(a, a_se, b, b_se):
        return a / b - 1.0, (a / b) * math.hypot(a_se / a, b_se / b)

    rows = []
    for n in counts:
        r, f = results[f"rigid_{n}"]["observables"], results[f"free_{n}"]["observables"]
        er, er_se = r["viscosity"]["mean"], r["viscosity"]["stderr"]
        ef, ef_se = f["viscosity"]["mean"], f["viscosity"]["stderr"]
        xs, xs_se = ratio(er, er_se, eta_s, eta_s_se)
        fs, fs_se = ratio(ef, ef_se, eta_s, eta_s_se)
        xf, xf_se = ratio(er, er_se, ef, ef_se)
        phi_h = n * 4 * math.pi / 3 * a_h**3 / volume
        phi_h_se = 3 * phi_h * a_h_se / a_h
        phi_p = 6 * n / (6 * n + n_solvent)
        ih, ih_se = xs / phi_h, math.hypot(xs_se / phi_h, xs * phi_h_se / phi_h**2)
        rows.append((n, phi_p, phi_h, phi_h_se, xs, xs_se, xf, xf_se, ih, ih_se))
        print(f"| {n} | {phi_p:.4f} | {phi_h:.4f} ± {phi_h_se:.4f} | {er:.3f} ± {er_se:.3f} | {ef:.3f} ± {ef_se:.3f} | "
              f"{xs:.4f} ± {xs_se:.4f} | {xs / phi_p:.2f} ± {xs_se / phi_p:.2f} | {ih:.1f} ± {ih_se:.1f} | "
              f"{fs:.4f} ± {fs_se:.4f} | {xf:+.4f} ± {xf_se:.4f} | {2.5 * phi_h:.4f} | {r['temperature']['mean']:.4f} | "
              f"{results[f'rigid_{n}']['wall_seconds']:.0f} + {results[f'free_{n}']['wall_seconds']:.0f} |")
    # Weighted least squares of (η/η_S − 1)/φ_p = A + B φ_p over the points: Einstein–Batchelor
    # would give A = 2.5; the constituents counted as plain extra particles under the dissipative
    # viscosity's n² law, (N/N_S)² − 1 = (1 − φ_p)⁻² − 1 = 2φ_p + 3φ_p² + …, give A = 2, B = 3.
    def slope_fit(eta_ref):
        pts = []
        for n in counts:
            o = results[f"rigid_{n}"]["observables"]["viscosity"]
            phi_p = 6 * n / (6 * n + n_solvent)
            pts.append((phi_p, (o["mean"] / eta_ref - 1) / phi_p, o["stderr"] / eta_ref / phi_p))
        w = [1 / e**2 for (_, _, e) in pts]
        sw, sx = sum(w), sum(a * p for a, (p, _, _) in zip(w, pts))
        sy = sum(a * y for a, (_, y, _) in zip(w, pts))
        sxx = sum(a * p * p for a, (p, _, _) in zip(w, pts))
        sxy = sum(a * p * y for a, (p, y, _) in zip(w, pts))
        det = sw * sxx - sx * sx
        return (sxx * sy - sx * sxy) / det, (sw * sxy - sx * sy) / det, math.sqrt(sxx / det), math.sqrt(sw / det)

    a_fit, b_fit, a_se, b_se = slope_fit(eta_s)
    # η_S's error is shared by every point: refit with η_S one standard error higher, in quadrature.
    a_up, b_up, _, _ = slope_fit(eta_s + eta_s_se)
    a_se, b_se = math.hypot(a_se, a_up - a_fit), math.hypot(b_se, b_up - b_fit)
    print(f"\nFit (η/η_S − 1)/φ_p = A + B φ_p (weights 1/σ², η_S's shared error added by refitting at η_S + σ): "
          f"A = {a_fit:.3f} ± {a_se:.3f}, B = {b_fit:.2f} ± {b_se:.2f}; Einstein A = 2.5; the constituents "
          "as plain extra particles, (N/N_S)² − 1, A = 2, B = 3.\n")
    n0, p0, h0, h0_se, x0, x0_se, f0, f0_se, i0, i0_se = rows[0]  # noqa: F841
    verdict("Einstein against the solvent, φ_p: the fitted dilute slope A within 4σ of 2.5",
            abs(a_fit - 2.5) < 4 * a_se, f"(A = {a_fit:.3f} ± {a_se:.3f})")
    verdict(f"Einstein against the solvent, φ_h: (η/η_S − 1)/φ_h at φ_h = {h0:.4f} within 4σ of 2.5",
            abs(i0 - 2.5) < 4 * i0_se, f"({i0:.2f} ± {i0_se:.2f})")
    # Rigidity's share η/η_free − 1 = C φ_h through the origin over all points (weights 1/σ²):
    # Einstein's C = 2.5 if making the constituents a rigid body is what adds the stresslet.
    wc = [1 / r[7] ** 2 for r in rows]
    sc = sum(w_ * r[2] ** 2 for w_, r in zip(wc, rows))
    c_fit = sum(w_ * r[6] * r[2] for w_, r in zip(wc, rows)) / sc
    c_se = 1 / math.sqrt(sc)
    print(f"Rigidity's share η/η_free − 1 = C φ_h (through the origin, weights 1/σ²): C = {c_fit:.2f} ± {c_se:.2f} "
          "(Einstein 2.5; a_h's error scales C by 3σ_a/a ≈ 2 % more).\n")
    verdict("rigidity's share: C in η/η_free − 1 = C φ_h within 4σ of Einstein's 2.5",
            abs(c_fit - 2.5) < 4 * c_se, f"(C = {c_fit:.2f} ± {c_se:.2f})")


# Hasimoto (1959, J. Fluid Mech. 5, 317) for a square array of cylinders, extended to O(c³) by
# Sangani & Acrivos (1982, Int. J. Multiphase Flow 8, 193): the drag per unit length on each
# cylinder F = 4πηU / (−½ ln c − 0.738 + c − 0.887c² + 2.039c³), c = πa²/L² the cylinders' area
# fraction, U the mean fluid velocity relative to the array.
def hasimoto_square_drag(a, cell):
    c = math.pi * a * a / cell**2
    return 4 * math.pi / (-0.5 * math.log(c) - 0.738 + c - 0.887 * c**2 + 2.039 * c**3)


def exclusion_radius(snapshots, n_fluid, centre, cell, first_step, threshold=0.01, width=0.02,
                     about_constituents=True):
    """The cylinder–fluid RDF about a fixed centre from the H5MD positions of `snapshots`
    (frames after `first_step`, fluid ids < n_fluid), g(r) = s/(2πrΔr)/(N/A), and the exclusion
    radius: the r below which g < threshold (Nguyen 2021 L877), read as the outer edge of the
    last bin with g < threshold. Returns
    (radius, [(r, g)], frames)."""
    import h5py
    import numpy as np
    with h5py.File(snapshots, "r") as f:
        steps = f["particles/fluid/position/step"][:]
        ids = f["particles/fluid/id"][:]
        fluid = ids < n_fluid
        frames = [k for k, st in enumerate(steps) if st > first_step]
        counts = np.zeros(int(cell / 2 / width))
        for k in frames:
            frame = f["particles/fluid/position/value"][k]
            x = frame[fluid]
            middle = np.asarray(centre, dtype=float)
            if about_constituents:
                # The cloud's own centre: the constituents' mean position (minimum image about
                # the site centre). Under drag the ties stretch, the cloud sits F/(n_cp H)
                # downstream of its sites, and an RDF about the sites would see the fluid
                # closer on the upstream side by that much.
                c = frame[~fluid] - middle
                c -= cell * np.round(c / cell)
                middle = middle + c.mean(axis=0)
            d = x - middle
            d -= cell * np.round(d / cell)
            r = np.hypot(d[:, 0], d[:, 1])
            counts += np.histogram(r, bins=len(counts), range=(0.0, len(counts) * width))[0]
    edges = np.arange(len(counts) + 1) * width
    shell = np.pi * (edges[1:] ** 2 - edges[:-1] ** 2)
    g = counts / (len(frames) * shell * n_fluid / cell**2)
    # The outer edge of the last bin below the threshold: a lone visitor deep inside (one count
    # in a small inner shell already reads g ≈ 0.02) does not end the excluded region.
    below = np.nonzero(g < threshold)[0]
    radius = edges[below[-1] + 1] if len(below) else float("nan")
    return radius, list(zip(0.5 * (edges[1:] + edges[:-1]), g)), len(frames)


def cylinder_array():
    """Flow past a periodic square array of fixed cylinders (issue #44, T6–T7;
    cases/dpd_cylinder_array_2d.toml): the drag F = N_f m g against the mean fluid velocity U at
    F_e = m g = 0.3 and 0.1, against Hasimoto's F/(ηU) for the exclusion radius measured from the
    cylinder–fluid RDF (g < 0.01) and the fluid's η measured by Lees–Edwards shear of the same
    fluid. Checks: the measured F/(ηU) within 10 % of Hasimoto's (the issue's bound), and the
    drag linear in U (the two forces' F/(ηU) within 4σ); and Hasimoto's cell-size dependence: a
    20 × 20 cell (3 200 fluid particles, F_e = 0.075, the same F = 240; 14 000 steps) gives the
    same hydrodynamic radius a_H (the radius whose Hasimoto drag is the measured one) as the
    10 × 10 cell within 4σ (~70 CPU-min; MESORHEO_CYLINDER_RUNS=DIR keeps each run in DIR/<name>/
    and reuses it)."""
    case = "dpd_cylinder_array_2d.toml"
    with open(os.path.join(ROOT, "cases", case)) as f:
        text = f.read()
    reuse = os.environ.get("MESORHEO_CYLINDER_RUNS")
    n_fluid, mass, cell, dt, equilibration = 800, 0.5, 10.0, 0.004, 2000
    forces = {"array": 0.6, "array_g0.2": 0.2}
    # The fluid alone in Lees–Edwards shear at γ̇ = 1 (the local rates about the cylinder are ~U/a ≈ 1;
    # at the thesis's Couette rate 0.2 the stress is 5 times closer to the noise), for η.
    shear_text = text.split("\n[fluid.colloids]\n")[0] + "\n[integrator]\n" + text.split("\n[integrator]\n")[1]
    shear_text = shear_text.replace("body_force = [0.6, 0.0]\n", "").replace(
        "lengths = [10.0, 10.0]", "lengths = [10.0, 10.0]\nshear_rate = 1.0").replace(
        'observables = ["momentum", "temperature"]', 'observables = ["viscosity", "temperature"]').replace(
        '[output]\nsnapshot_every = 100\nsnapshot_fields = ["position"]\n', "")

    def one(name):
        keep = os.path.join(reuse, name) if reuse else tempfile.mkdtemp(prefix=f"cyl_{name}_")
        if os.path.exists(os.path.join(keep, "summary.json")):
            with open(os.path.join(keep, "summary.json")) as f:
                return name, (json.load(f), keep)
        if name == "shear":
            with tempfile.NamedTemporaryFile("w", suffix=".toml", delete=False) as f:
                f.write(shear_text)
            try:
                return name, (run(f.name, [], threads=1, keep=keep), keep)
            finally:
                os.unlink(f.name)
        if name == "array_L20":
            sets = ["box.lengths=[20.0, 20.0]", "fluid.body_force=[0.15, 0.0]", "run.steps=14000"]
            return name, (run(case, sets, threads=1, keep=keep), keep)
        g = forces[name]
        return name, (run(case, [f"fluid.body_force=[{g}, 0.0]"], threads=1, keep=keep), keep)

    from concurrent.futures import ThreadPoolExecutor
    with ThreadPoolExecutor(2) as pool:
        results = dict(pool.map(one, ["array", "array_g0.2", "shear", "array_L20"]))
    sh = results["shear"][0]["observables"]
    eta, eta_se = sh["viscosity"]["mean"], sh["viscosity"]["stderr"]
    print("### Cylinder array against Hasimoto (`./run validate cylinder_array`)\n")
    print(f"Fluid alone, Lees–Edwards γ̇ = 1: η = {eta:.2f} ± {eta_se:.2f} (input 100), "
          f"k_BT = {fmt(sh['temperature'])}.\n")
    print("| F_e = m g | U | F = N_f F_e | F/(ηU) | exclusion radius (g < 0.01) | Hasimoto F/(ηU) at that radius | measured/Hasimoto − 1 | Stokes radius from F/(ηU) | k_BT | frames | wall s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    rows = {}
    for name, g in forces.items():
        s, keep = results[name]
        o = s["observables"]
        u = o["momentum_x"]["mean"] / (n_fluid * mass)
        u_se = o["momentum_x"]["stderr"] / (n_fluid * mass)
        force = n_fluid * mass * g
        k = force / (eta * u)
        k_se = k * math.hypot(u_se / u, eta_se / eta)
        radius, rdf, frames = exclusion_radius(os.path.join(keep, "snapshots.h5"), n_fluid,
                                               (cell / 2, cell / 2), cell, equilibration)
        ref = hasimoto_square_drag(radius, cell)
        # The radius whose Hasimoto drag is the measured one (bisection on a ∈ (0.01, 3)).
        lo, hi = 0.01, 3.0
        for _ in range(100):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if hasimoto_square_drag(mid, cell) < k else (lo, mid)
        rows[name] = (k, k_se, radius, ref, 0.5 * (lo + hi))
        print(f"| {mass * g:.2f} | {u:.4f} ± {u_se:.4f} | {force:.1f} | {k:.3f} ± {k_se:.3f} | {radius:.2f} | "
              f"{ref:.3f} | {100 * (k / ref - 1):+.1f} % | {0.5 * (lo + hi):.3f} | {fmt(o['temperature'])} | "
              f"{frames} | {s['wall_seconds']:.0f} |")
        verdict(f"cylinder array F_e = {mass * g:.2f}: F/(ηU) within 10 % of Hasimoto's at the exclusion radius",
                abs(k / ref - 1) < 0.10, f"({k:.3f} ± {k_se:.3f} against {ref:.3f} at a = {radius:.2f})")
        if name == "array":
            print("\nRDF (F_e = 0.3) near the edge: " + ", ".join(f"g({r:.2f}) = {gv:.3f}" for r, gv in rdf if 0.2 < r < 1.0))
            print()
    (k1, e1, _, _, _), (k2, e2, _, _, _) = rows["array"], rows["array_g0.2"]
    # η's error is common to both: leave it out of the linearity comparison.
    e1u = k1 * results["array"][0]["observables"]["momentum_x"]["stderr"] / results["array"][0]["observables"]["momentum_x"]["mean"]
    e2u = k2 * results["array_g0.2"][0]["observables"]["momentum_x"]["stderr"] / results["array_g0.2"][0]["observables"]["momentum_x"]["mean"]
    verdict("cylinder array: drag linear in U (F/(ηU) at F_e = 0.1 and 0.3 within 4σ)",
            abs(k1 - k2) < 4 * math.hypot(e1u, e2u), f"({k2:.3f} and {k1:.3f}, σ = {math.hypot(e1u, e2u):.3f})")

    # Hasimoto's cell-size dependence: the 20 × 20 cell (same total force) against the 10 × 10.
    # a_H is where hasimoto_square_drag(a, L) = F/(ηU); its error from F/(ηU) ± σ by bisection.
    def a_of(k, cell):
        lo, hi = 0.01, 3.0
        for _ in range(100):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if hasimoto_square_drag(mid, cell) < k else (lo, mid)
        return 0.5 * (lo + hi)

    s20, keep20 = results["array_L20"]
    o20 = s20["observables"]
    cell20, n20 = 20.0, 3200
    u20 = o20["momentum_x"]["mean"] / (n20 * mass)
    u20_se = o20["momentum_x"]["stderr"] / (n20 * mass)
    k20 = n20 * mass * 0.15 / (eta * u20)
    k20_se = k20 * math.hypot(u20_se / u20, eta_se / eta)
    r20, _, frames20 = exclusion_radius(os.path.join(keep20, "snapshots.h5"), n20, (cell20 / 2, cell20 / 2),
                                        cell20, equilibration)
    ref20 = hasimoto_square_drag(r20, cell20)
    a20 = a_of(k20, cell20)
    a20_se = 0.5 * (a_of(k20 + k20_se, cell20) - a_of(k20 - k20_se, cell20))
    a10 = a_of(k1, cell)
    a10_se = 0.5 * (a_of(k1 + e1, cell) - a_of(k1 - e1, cell))
    print(f"\n20 × 20 cell, F_e = 0.075 (F = 240): U = {u20:.4f} ± {u20_se:.4f}, F/(ηU) = {k20:.3f} ± {k20_se:.3f}, "
          f"exclusion radius {r20:.2f}, Hasimoto there {ref20:.3f} ({100 * (k20 / ref20 - 1):+.1f} %), "
          f"a_H = {a20:.3f} ± {a20_se:.3f} (10 × 10: {a10:.3f} ± {a10_se:.3f}); {frames20} frames, "
          f"wall {s20['wall_seconds']:.0f} s")
    verdict("cylinder array: Hasimoto's cell-size dependence (a_H of the 20 × 20 cell within 4σ of the 10 × 10's)",
            abs(a20 - a10) < 4 * math.hypot(a20_se, a10_se), f"({a20:.3f} ± {a20_se:.3f} and {a10:.3f} ± {a10_se:.3f})")


def generic_polymer_t1():
    """The thesis's T1 (Ellero 2004 §4.8, docs/theory/generic_polymer_particle.md §5): the stock
    case at the seven rates γ̇λ_H = 10/2^k, each averaged over t ∈ [8, 16]λ_H after the start-up
    from equilibrium, against the Hookean η_p = n k_BT λ_H and Ψ₁ = 2η_pλ_H (reduced), and the
    momentum flux's η (`viscosity`, the stress the pair forces transmit, theory §8) against
    η̄_s + η_p. A check passes when the error is within 3 % (the issue's bound) and within 4.5
    standard errors."""
    eta, psi, eta_s = 4.1419e-3, 8.2839e-3, 0.01
    rates = [10.0 / 2 ** k for k in range(6, -1, -1)]
    only = os.environ.get("MESORHEO_GP_RATES")
    if only:
        rates = [float(x) for x in only.split(",")]
    print("### GENERIC polymer particle, thesis T1: η_p and Ψ₁ against γ̇λ_H "
          "(`./run validate generic_polymer_t1`)\n")
    print("| γ̇λ_H | η_p | error | Ψ₁ | error | η (flux) | error | ⟨Q̄²⟩/(4.395·10⁻⁵(1 + γ̇²)) − 1 | wall s |")
    print("|---|---|---|---|---|---|---|---|---|")
    for rate in rates:
        s = run("generic_polymer_shear_2d.toml", [f"box.shear_rate={rate}", "reference=[]"],
                ranks=1, threads=2)
        o = s["observables"]
        v, ve = o["viscosity_constitutive"]["mean"], o["viscosity_constitutive"]["stderr"]
        n1 = o["first_normal_stress_difference_constitutive"]
        p, pe = n1["mean"] / rate ** 2, n1["stderr"] / rate ** 2
        q2 = o["conformation_q2"]["mean"] / (4.3947e-5 * (1 + rate ** 2)) - 1
        flux, flux_e = o["viscosity"]["mean"], o["viscosity"]["stderr"]
        row = [f"{rate:g}"]
        for name, m, e, exact in (("η_p", v, ve, eta), ("Ψ₁", p, pe, psi),
                                  ("η (momentum flux)", flux, flux_e, eta_s + eta)):
            err = m / exact - 1
            ok = abs(err) <= 0.03 and abs(m - exact) <= 4.5 * e
            verdict(f"γ̇λ_H = {rate:g}: {name} within 3 % and 4.5σ of {exact}", ok,
                    f"({m:.5g} ± {e:.2g}, {err:+.2%})")
            row += [f"{m:.4e} ± {e:.1e}", f"{err:+.2%}"]
        row += [f"{q2:+.2%}", f"{s['wall_seconds']:.0f}"]
        print("| " + " | ".join(row) + " |")
    print()


def dpd_held_out6():
    """The sixth held-out DPD stability set (docs/stability/dpd_held_out6.txt, chosen and
    committed before the margin fitted after the fifth set existed)."""
    dpd_stability("dpd_held_out6.txt")


def generic_model_a():
    """Model A of the GENERIC polymer particle against CONNFFESSIT (issue #43: "the same flow with
    N^d explicit dumbbells per particle gives the same viscometric functions as the coupled
    CONNFFESSIT model within error bars"). Both carry 100 Hookean dumbbells per particle in the
    same 400-particle Lees–Edwards shear at Wi = 1 (λ = 1, G = η_p = 0.5, η_s = 0.5, p_b = 5,
    Lucy 0.15, t ∈ [9, 18]λ averaged), seeds 1–6 each: η_p and N₁ of the particles' own polymer
    stress (`*_constitutive`; CONNFFESSIT's η less η_s), mean ± seed scatter/√6.
    Checks: Model A with `conformation_gradient = "corrected"` (the estimate CONNFFESSIT's case
    uses) equals CONNFFESSIT within 4σ of the combined error in η_p and N₁; with the particle's
    own gradient (`"particle"`, the thesis's) its N₁ differs by more than 4σ (so the comparison
    resolves a 2 % gradient bias); the corrected Model A's and CONNFFESSIT's means within 4.5σ
    of Oldroyd-B (η_p = 0.5, N₁ = 1). Measured 2026-11-28 (858bde1): corrected η_p 0.5037 ± 0.0015,
    N₁ 0.9960 ± 0.0030; particle 0.5005 ± 0.0016, 0.9822 ± 0.0023; CONNFFESSIT 0.5030 ± 0.0015,
    1.0016 ± 0.0021."""
    model_a = "../studies/cases/generic_polymer_model_a_shear_2d.toml"
    variants = {
        "Model A, corrected κ": (model_a, ['fluid.conformation_gradient="corrected"'], 0.0),
        "Model A, particle κ": (model_a, ['fluid.conformation_gradient="particle"'], 0.0),
        "CONNFFESSIT": ("connffessit_shear_2d.toml", [], 0.5),
    }
    stats = {}
    print("| variant | seed | η_p | N₁ | wall s |")
    print("|---|---|---|---|---|")
    for name, (case, sets, eta_s) in variants.items():
        etas, n1s = [], []
        for seed in range(1, 7):
            s, cmd, err = launch(case, sets + [f"seed={seed}"], threads=2)
            if s is None:
                verdict(f"{name} seed {seed} runs", False, err.strip()[-200:])
                continue
            o = s["observables"]
            eta = o["viscosity_constitutive"]["mean"] - eta_s
            n1 = o["first_normal_stress_difference_constitutive"]["mean"]
            etas.append(eta)
            n1s.append(n1)
            print(f"| {name} | {seed} | {eta:.5f} | {n1:.5f} | {s['wall_seconds']:.0f} |")
        if len(etas) < 2:
            continue

        def mean_se(v):
            m = sum(v) / len(v)
            sd = math.sqrt(sum((x - m) ** 2 for x in v) / (len(v) - 1))
            return m, sd / math.sqrt(len(v))

        stats[name] = {"η_p": mean_se(etas), "N₁": mean_se(n1s)}
    print("\n| variant | η_p (mean ± se) | N₁ (mean ± se) |\n|---|---|---|")
    for name, st in stats.items():
        print(f"| {name} | {st['η_p'][0]:.5f} ± {st['η_p'][1]:.5f} | "
              f"{st['N₁'][0]:.5f} ± {st['N₁'][1]:.5f} |")
    exact = {"η_p": 0.5, "N₁": 1.0}
    for name, st in stats.items():
        if name == "Model A, particle κ":
            continue  # the known ~2 % N₁ bias of the particle's own gradient, checked below
        for q, (m, se) in st.items():
            verdict(f"{name}: {q} within 4.5σ of Oldroyd-B ({exact[q]})",
                    abs(m - exact[q]) < 4.5 * se, f"({m:.5f} ± {se:.5f})")
    ref = stats.get("CONNFFESSIT")
    if ref is None:
        return
    for name, same in (("Model A, corrected κ", True), ("Model A, particle κ", False)):
        if name not in stats:
            continue
        for q in ("η_p", "N₁") if same else ("N₁",):
            (a, sa), (b, sb) = stats[name][q], ref[q]
            z = (a - b) / math.sqrt(sa * sa + sb * sb)
            if same:
                verdict(f"{name} against CONNFFESSIT: {q} the same within 4σ", abs(z) < 4.0,
                        f"({z:+.2f}σ)")
            else:
                verdict(f"{name} against CONNFFESSIT: {q} resolved as different (> 4σ)",
                        abs(z) > 4.0, f"({z:+.2f}σ)")


def launch_text(text, sets=(), ranks=1, threads=2):
    """launch() on a case given as text."""
    with tempfile.NamedTemporaryFile("w", suffix=".toml", delete=False) as f:
        f.write(text)
    try:
        return launch(f.name, sets, ranks, threads)
    finally:
        os.unlink(f.name)


if __name__ == "__main__":
    todo = sys.argv[1:] or ["stock", "kt_vs_dt", "viscosity", "viscometric", "sph", "sph_convergence", "maxwell",
                            "inclusion", "maxwell_convergence", "maxwell_stability", "connffessit_shear",
                            "msph_channel", "connffessit_channel_seeds", "weak_order", "fene_table", "transverse_current",
                            "kt_vs_dt_low_mass", "dpd_stability", "dpd_held_out4", "dpd_held_out6", "fuzz", "maxwell_couette_causes", "maxwell_couette",
                            "coupled_configuration_fields", "bddfs_t2", "bddfs_memory",
                            "default_weissenberg", "suspension_viscosity", "cylinder_array",
                            "generic_polymer_t1", "generic_model_a"]
    targets = {"kt_vs_dt": kt_vs_dt, "viscosity": viscosity, "stock": stock,
               "viscometric": viscometric, "sph": sph, "sph_convergence": sph_convergence,
               "maxwell": maxwell, "inclusion": inclusion,
               "maxwell_convergence": maxwell_convergence, "maxwell_stability": maxwell_stability,
               "connffessit_shear": connffessit_shear, "msph_channel": msph_channel,
               "weak_order": weak_order, "fene_table": fene_table,
               "transverse_current": transverse_current, "kt_vs_dt_low_mass": kt_vs_dt_low_mass,
               "dpd_stability": dpd_stability, "dpd_held_out4": dpd_held_out4,
               "dpd_held_out6": dpd_held_out6,
               "connffessit_channel_seeds": connffessit_channel_seeds, "fuzz": fuzz,
               "bddfs_t2": bddfs_t2, "bddfs_memory": bddfs_memory,
               "maxwell_couette": maxwell_couette,
               "maxwell_couette_causes": maxwell_couette_causes,
               "coupled_configuration_fields": coupled_configuration_fields,
               "default_weissenberg": default_weissenberg,
               "suspension_viscosity": suspension_viscosity, "cylinder_array": cylinder_array,
               "generic_polymer_t1": generic_polymer_t1, "generic_model_a": generic_model_a}
    if todo == ["report"]:
        report()
        sys.exit(0)
    for name in todo:
        if name not in targets:
            sys.exit(f"unknown validation '{name}'; valid: {', '.join(targets)}, or report")
    for name in todo:
        CURRENT["target"] = name
        targets[name]()
    finish(todo)
