#!/usr/bin/env python3
"""Scaling model for mesorheo (issue #42): `./run scale --model ARGS`.

Fits per-phase costs (per owned particle, per ghost, per message) to measured runs at a few
rank counts, checks the fit on the measured runs it was not fitted on, and predicts the time per
step and the efficiency at 64, 256 and 1 024 cores, with the slab cap and threads included.

  tools/scale_model.py --runs DIR|summaries.tgz [--fit '*:1,2,4'] [--ranks 64,256,1024]
                       [--case CASE.toml|summary.json [--particles N] [--as-kind KIND]]
                       [--phases] [--max-threads 64] [--exclude le_digest,smoke]
  tools/scale_model.py --selftest

Input: the layout of ../shared/tools/devscale/scale.sh, runs/<label>-n<ranks>-t<threads>/
summary.json (a folder, or its summaries.tgz). Output: Markdown tables on stdout.

The model (docs/performance.md, "A scaling model"), per rank and per phase p of phase_seconds:

    t_p = occ(C) · (c_o,p · W_o,p + c_g,p · W_g,p) · ((1 − f_p) + f_p / T) + c_m,p · M_p
    t_wait = j · g(P) · Σ_{p = neighbour, forces} (the first term of t_p)

occ(C), C = min(P·T, node cores): 1, 1 + κ(C − 1), 1 + κ log₂C or 1 + κ(1 − 1/C); g(P): √(2 ln P),
E[max of P standard normals] or ln P. Every form is fitted and compared (`--occupancy`, `--wait`
force one); the phase times fitted are the mean over ranks where summary.json has them.

W_o, W_g: owned and ghost particles × the phase's events (rebuilds, stages, force evaluations,
samples), × neighbours per particle ρ·V(range) in the pair phases (neighbour, forces), × dumbbells
per particle in particle_state; M: messages (sendrecvs to another rank, and ⌈log₂ P⌉ rounds per
allreduce). Slab decomposition: with P ranks the slab is w = L_axis / P wide; the ghosts are
the two face layers (depth = range = cutoff + skin) plus the local periodic images along the other
periodic axes of owned and slab ghosts alike (the cascade of domain/halo.rs):
    n_g = n_o · [(1 + 2h/w) · Π_other (1 + 2h/L_o) − 1].
c ≥ 0 by non-negative least squares, one fit per model kind and phase, each run weighted by
1 / its loop time; f (Amdahl's parallel fraction of a phase's particle work) from 1 × 1 against
1 × T runs. P_max = floor(L_axis / range) (capacity::max_ranks); beyond it only threads help.
Only numpy (and the standard library) is needed.
"""
import argparse
import json
import math
import os
import re
import sys
import tarfile
import tempfile
from dataclasses import dataclass, field, replace

import numpy as np

PHASES = ["integrate", "particle_state", "neighbour", "rebuild_comm", "halo", "forces", "diagnostics"]
WAIT = "pass_wait"               # the wait at the collective after the force passes (engines after 2026-11-28)
ALL_PHASES = PHASES + [WAIT]
WORK_PHASES = ("neighbour", "forces")   # the work between the halo check's allreduce and the pass collective
OCC_FORMS = ("none", "linear", "log", "share")   # node occupancy factor on the particle work
WAIT_FORMS = ("none", "sqrt2lnP", "emaxP", "lnP")   # growth of the wait for the slowest of P ranks
NODE_CORES = 16                  # cores of the measured node: occupancy saturates there
PAIR_PHASES = {"neighbour", "forces"}
TERMS = ("owned", "ghost", "message")
INTEGRATOR_STAGES = {"groot_warren": 1, "kick_drift_kick": 1}  # every other integrator: 2


# ---------------------------------------------------------------------------------------------
# Geometry of one scene
# ---------------------------------------------------------------------------------------------
@dataclass
class Scene:
    """What the model needs of a case (from summary.json's resolved `case` or a case file)."""
    kind: str                 # model kind, e.g. "dpd/3d", "sph+dumbbells/3d"
    dim: int
    lengths: list
    axis: int                 # slab axis index
    periodic: list            # per axis
    cutoff: float
    skin: float
    particles: int
    lattice: str = "random"
    lattice_density: float = 0.0
    temperature: float = 1.0
    shear_rate: float = 0.0
    stages: int = 1
    passes: int = 1           # model passes per force evaluation
    field_passes: int = 0     # passes whose ghosts need fields refreshed first (a message pair each)
    dumbbells: int = 0        # per particle (CONNFFESSIT ensembles)
    setup_forces: int = 1     # force evaluations before the loop (2 with companion models)
    sample_every: int = 1
    rebuild_rate: float = float("nan")  # neighbour-list builds per step (from a measured run)

    @property
    def range(self):
        return self.cutoff + self.skin

    @property
    def volume(self):
        return float(np.prod(self.lengths))

    def p_max(self):
        """The engine's slab cap (capacity::max_ranks; sim/mod.rs refuses slabs thinner than
        cutoff + skin on more than one rank)."""
        return max(1, math.floor(self.lengths[self.axis] / self.range))

    def neighbours(self):
        """Particles within the list range of a particle: ρ · V_D(range)."""
        h = self.range
        v = {1: 2 * h, 2: math.pi * h * h, 3: 4.0 / 3.0 * math.pi * h ** 3}[self.dim]
        return self.particles / self.volume * v

    def band(self, a):
        """Width 2h_eff such that the fraction of particles within `range` of the two faces
        normal to axis `a` is 2h_eff / L_a. Thermal particles (and the Lees–Edwards flow axis x
        of a sheared scene) are spread evenly: 2h. A cold lattice (temperature 0, as the SPH
        scenes start) keeps its planes, at (k + b + ¼) spacings (sim/initial.rs): count them."""
        h, L = self.range, self.lengths[a]
        even = (self.temperature > 0 or self.lattice == "random" or self.lattice_density <= 0
                or (a == 0 and self.shear_rate != 0.0))
        if even:
            return min(2 * h, L)
        basis = 1 if self.lattice == "cubic" else (2 if self.dim == 2 else 4)
        spacing0 = (basis / self.lattice_density) ** (1.0 / self.dim)
        cells = max(1, math.floor(L / spacing0 + 0.5))
        s = L / cells
        offsets = [0.25] if basis == 1 else [0.25, 0.75]
        k = np.arange(cells)
        inside = 0
        for o in offsets:
            x = (k + o) * s
            inside += np.count_nonzero((x < h) | (x >= L - h))
        return inside / (cells * len(offsets)) * L

    def owned(self, P):
        return self.particles / P

    def ghosts(self, P):
        """Ghosts of the busiest rank: two slab faces (one on two ranks of a non-periodic axis,
        none on one), then the local images of owned and slab ghosts along the other periodic
        axes, as HaloPlan::build makes them."""
        a = self.axis
        w = self.lengths[a] / P
        if self.periodic[a]:
            faces = 2
        else:
            faces = 0 if P == 1 else (1 if P == 2 else 2)
        factor = 1.0 + 0.5 * faces * self.band(a) / w
        for o in range(self.dim):
            if o != a and self.periodic[o]:
                factor *= 1.0 + self.band(o) / self.lengths[o]
        return self.owned(P) * (factor - 1.0)

    def scaled_along_axis(self, k):
        """The weak-scaling twin: the slab axis and the particle count × k."""
        lengths = list(self.lengths)
        lengths[self.axis] *= k
        return replace(self, lengths=lengths, particles=int(round(self.particles * k)))


def _get(d, path, default=KeyError):
    cur = d
    for key in path.split("."):
        if not isinstance(cur, dict) or key not in cur:
            if default is KeyError:
                raise KeyError(path)
            return default
        cur = cur[key]
    return cur


def lattice_count(case):
    """Particles the initialiser creates (Case::lattice_counts)."""
    dim = case["dimension"]
    lengths = case["box"]["lengths"]
    lattice = _get(case, "particles.lattice", "random")
    rho = case["particles"]["density"]
    if lattice == "random":
        return int(round(rho * float(np.prod(lengths))))
    basis = 1 if lattice == "cubic" else (2 if dim == 2 else 4)
    spacing = (basis / rho) ** (1.0 / dim)
    return int(np.prod([max(1.0, math.floor(L / spacing + 0.5)) for L in lengths]) * basis)  # f64::round


def scene_from_case(case, particles=None, passes=None, rebuild_rate=float("nan")):
    """A Scene from a resolved case (summary.json `case`) or a case file's dict (defaults of
    src/config filled in: skin 0.3, slab axis y, all periodic)."""
    dim = int(case["dimension"])
    fluid = case["fluid"]
    kind = fluid["kind"]
    polymer = fluid.get("polymer") or {}
    if polymer:
        kind += "+" + str(polymer.get("model", "polymer"))
    if "cutoff" in fluid:                              # DPD
        cutoff = fluid["cutoff"]
    elif fluid["kind"] == "sph":                       # the kernel support (SphCfg::support)
        factor = {"lucy": 1.0, "cubic_spline": 2.0, "wendland_c2": 2.0, "truncated_gaussian": 2.0,
                  "quintic_spline": 3.0}[fluid["kernel"]]
        cutoff = factor * fluid["smoothing_length"]
    else:                                              # generic_polymer: its smoothing length
        cutoff = fluid["smoothing_length"]
    bounds = _get(case, "box.boundaries", None)
    periodic = [True] * dim if not bounds else [b == "periodic" for b in bounds]
    axis = "xyz".index(_get(case, "decomposition.axis", "y"))
    if passes is None:
        passes = 3 if kind.startswith("sph") else 1
    return Scene(
        kind=f"{kind}/{dim}d", dim=dim, lengths=list(map(float, case["box"]["lengths"])),
        axis=axis, periodic=periodic, cutoff=float(cutoff),
        skin=float(_get(case, "neighbour.skin", 0.3)),
        particles=int(particles if particles is not None else lattice_count(case)),
        lattice=_get(case, "particles.lattice", "random"),
        lattice_density=float(_get(case, "particles.density", 0.0)),
        temperature=float(_get(case, "particles.temperature", 1.0)),
        shear_rate=float(_get(case, "box.shear_rate", 0.0) or 0.0),
        stages=INTEGRATOR_STAGES.get(_get(case, "integrator.kind", "groot_warren"), 2),
        passes=passes,
        # Heuristic from models/*/ (Pass::ghost_fields): a model's first pass needs positions
        # and velocities only, every later one needs the fields an earlier one wrote.
        field_passes=max(0, passes - 1),
        dumbbells=int(polymer.get("per_particle", 0) or 0) if polymer.get("model") == "dumbbells" else 0,
        setup_forces=2 if polymer else 1,
        sample_every=max(1, int(_get(case, "run.sample_every", 1))),
        rebuild_rate=rebuild_rate,
    )


# ---------------------------------------------------------------------------------------------
# Runs, events and features
# ---------------------------------------------------------------------------------------------
@dataclass
class Run:
    label: str
    scene: Scene
    ranks: int
    threads: int
    steps: int
    rebuilds: int
    loop: float
    phases: dict
    source: str = ""
    fit: bool = False
    load: dict = None        # summary.json `load` (newer engines): owned/ghosts/pairs, mean and max over ranks
    spread: dict = None      # summary.json `phase_seconds_over_ranks` (newer engines): mean and max
    phases_rank0: dict = None
    mean_phases: bool = False  # phases are the mean over ranks

    @property
    def key(self):
        return (self.scene.kind, self.label, self.ranks, self.threads)


def run_events(run, in_loop):
    """Event counts of a run. phase_seconds also hold the setup before the loop (one rebuild,
    `setup_forces` force evaluations), loop_seconds do not: `in_loop` leaves them out."""
    s = run.scene
    S = run.steps
    R = run.rebuilds - (1 if in_loop else 0)
    stage_steps = S * s.stages
    return {
        "steps": S,
        "stage_steps": stage_steps,
        "rebuilds": R,
        "force_evals": stage_steps + (0 if in_loop else s.setup_forces),
        "forwards": max(0.0, stage_steps - (run.rebuilds - 1)),
        "samples": S // s.sample_every + (0 if in_loop else 1),
    }


def step_events(scene):
    """Events of one step inside the loop, at the scene's rebuild rate."""
    r = scene.rebuild_rate
    return {"steps": 1, "stage_steps": scene.stages, "rebuilds": r, "force_evals": scene.stages,
            "forwards": max(0.0, scene.stages - r), "samples": 1.0 / scene.sample_every}


def features(scene, P, ev):
    """Per phase: [W_owned, W_ghost, M_messages] of the busiest rank for the events `ev`."""
    n_o, n_g = scene.owned(P), scene.ghosts(P)
    nb = scene.neighbours()
    ext = 1.0 if P > 1 else 0.0                        # sendrecvs to itself are copies (per ghost)
    lg = math.ceil(math.log2(P)) if P > 1 else 0       # rounds of one allreduce
    dumb = max(1, scene.dumbbells)
    R, ss, fe, fw, smp = ev["rebuilds"], ev["stage_steps"], ev["force_evals"], ev["forwards"], ev["samples"]
    refreshes = fw + ss * scene.field_passes           # ghost refreshes between rebuilds
    return {
        "integrate": np.array([ss * n_o, 0.0, 0.0]),
        "particle_state": np.array([ev["steps"] * n_o * dumb, 0.0, 0.0]),
        "neighbour": np.array([R * n_o * nb, R * n_g * nb, 0.0]),
        # migration (2 sendrecvs + 1 allreduce) and the halo build (2 sendrecvs)
        "rebuild_comm": np.array([R * n_o, R * n_g, R * (4 * ext + lg)]),
        # per stage: the displacement scan and its allreduce, then the ghost refreshes
        "halo": np.array([ss * n_o, refreshes * n_g, 2 * ext * refreshes + ss * lg]),
        # pair work; one failure allreduce per pass
        "forces": np.array([fe * n_o * nb, fe * n_g * nb, fe * scene.passes * lg]),
        "diagnostics": np.array([smp * n_o, 0.0, smp * lg]),
    }


def amdahl(f, T):
    return (1.0 - f) + f / T


# ---------------------------------------------------------------------------------------------
# Loading
# ---------------------------------------------------------------------------------------------
DIR_RE = re.compile(r"^(?P<label>.+)-n(?P<n>\d+)-t(?P<t>\d+)$")


def run_from_summary(s, label, source="", rank0=False):
    """phases: the mean over ranks (`phase_seconds_over_ranks.mean`) where the summary has it
    (less noisy than one rank's; their sum is the loop time as well as rank 0's is), else rank 0's."""
    ph = s["phase_seconds"]
    passes = len(ph.get("passes") or []) or None
    steps = int(s["steps"]) - int((s.get("segments") or [{}])[-1].get("first_step", 0) or 0)
    scene = scene_from_case(s["case"], particles=int(s["particles"]), passes=passes)
    scene.rebuild_rate = max(0.0, (int(ph["rebuilds"]) - 1) / max(1, steps))
    run = Run(label=label, scene=scene, ranks=int(s["ranks"]), threads=int(s["threads"]),
               steps=steps, rebuilds=int(ph["rebuilds"]), loop=float(s["loop_seconds"]),
               phases={p: float(ph.get(p, 0.0)) for p in ALL_PHASES}, source=source,
               load=s.get("load"), spread=s.get("phase_seconds_over_ranks"))
    mean = (run.spread or {}).get("mean") or {}
    run.phases_rank0 = dict(run.phases)
    if mean and not rank0:
        run.phases = {p: float(mean.get(p, run.phases[p])) for p in ALL_PHASES}
        run.mean_phases = True
    return run


def load_runs(path, exclude=(), rank0=False):
    """Every runs/<label>-n<N>-t<T>/summary.json under a folder or in a .tgz."""
    found = []
    if os.path.isdir(path):
        for root, _dirs, files in os.walk(path):
            if "summary.json" in files:
                p = os.path.join(root, "summary.json")
                with open(p) as f:
                    found.append((os.path.basename(root), json.load(f), p))
    else:
        with tarfile.open(path) as tar:
            for m in tar.getmembers():
                if m.isfile() and m.name.endswith("/summary.json"):
                    found.append((os.path.basename(os.path.dirname(m.name)),
                                  json.load(tar.extractfile(m)), m.name))
    runs, skipped = [], []
    for name, s, p in sorted(found, key=lambda x: x[2]):
        m = DIR_RE.match(name)
        label = m.group("label") if m else name
        if any(re.fullmatch(x, label) for x in exclude):
            continue
        if not s.get("completed", True):
            skipped.append(f"{p} (run not completed)")
            continue
        runs.append(run_from_summary(s, label, p, rank0))
    return runs, skipped


# ---------------------------------------------------------------------------------------------
# Fitting
# ---------------------------------------------------------------------------------------------
def nnls(A, b, tol=1e-12, max_iter=500):
    """Lawson–Hanson non-negative least squares (numpy only): min |Ax − b|, x ≥ 0."""
    m, n = A.shape
    x = np.zeros(n)
    passive = np.zeros(n, bool)
    w = A.T @ (b - A @ x)
    scale = tol * max(1.0, np.abs(A).max() * np.abs(b).max())
    for _ in range(max_iter):
        if passive.all() or w[~passive].max(initial=-np.inf) <= scale:
            break
        j = np.where(~passive)[0][np.argmax(w[~passive])]
        passive[j] = True
        while True:
            z = np.zeros(n)
            z[passive] = np.linalg.lstsq(A[:, passive], b, rcond=None)[0]
            if (z[passive] > 0).all():
                x = z
                break
            neg = passive & (z <= 0)
            alpha = np.min(x[neg] / (x[neg] - z[neg]))
            x = x + alpha * (z - x)
            passive &= x > 1e-300
            x[~passive] = 0.0
        w = A.T @ (b - A @ x)
    return x


@dataclass
class KindFit:
    kind: str
    coef: dict = field(default_factory=dict)      # phase → array(3)
    frac: dict = field(default_factory=dict)      # phase → Amdahl parallel fraction
    thread_data: bool = False
    rows: int = 0
    rms: dict = field(default_factory=dict)       # phase → rms residual / loop
    under: list = field(default_factory=list)     # phases with fewer rows than terms
    occ_form: str = "none"                        # node occupancy: none, linear, log
    kappa: float = 0.0                            # its coefficient
    node_cores: int = NODE_CORES
    wait_form: str = "none"                       # growth of the pass wait with P
    jitter: float = 0.0                           # j: wait / (work × g(P))
    wait_rows: int = 0                            # fit runs with P > 1 behind j
    sse: float = 0.0                              # fit-set residual (phases and wait), Σ (res / loop)²


def occupancy(form, kappa, P, T, node_cores=NODE_CORES):
    """Slowdown of the same particle work when C = min(P·T, node) cores of a node are busy
    (shared memory bandwidth and last-level cache): 1 + κ (C − 1), 1 + κ log₂ C, or
    1 + κ (1 − 1/C) (`share`: the share of the shared cache and bandwidth the other C − 1 cores
    take; it saturates, at 1 + κ, on a full node)."""
    C = max(1, min(P * T, node_cores))
    if form == "linear":
        return 1.0 + kappa * (C - 1)
    if form == "log":
        return 1.0 + kappa * math.log2(C)
    if form == "share":
        return 1.0 + kappa * (1.0 - 1.0 / C)
    return 1.0


_EMAX = {}


def expected_max_normal(P):
    """E[max of P independent standard normals] (0 at P = 1): ∫ x · P φ(x) Φ(x)^(P−1) dx."""
    if P not in _EMAX:
        x = np.linspace(-12.0, 12.0, 4801)
        Phi = 0.5 * (1.0 + np.array([math.erf(v / math.sqrt(2.0)) for v in x]))
        phi = np.exp(-0.5 * x * x) / math.sqrt(2.0 * math.pi)
        y = x * P * phi * Phi ** (P - 1)
        _EMAX[P] = float(np.sum((y[1:] + y[:-1]) * 0.5 * np.diff(x)))
    return _EMAX[P]


def wait_growth(form, P):
    """g(P): the expected lead of the slowest of P ranks, in units of one rank's spread σ."""
    if P <= 1 or form == "none":
        return 0.0
    if form == "sqrt2lnP":
        return math.sqrt(2.0 * math.log(P))
    if form == "emaxP":
        return expected_max_normal(P)
    if form == "lnP":
        return math.log(P)
    raise ValueError(form)


def parse_fit_spec(spec):
    items = []
    for part in spec.split(";"):
        part = part.strip()
        if not part:
            continue
        label, _, ranks = part.partition(":")
        items.append((label.strip() or "*", {int(r) for r in ranks.split(",") if r.strip()} if ranks else None))
    return items


def in_fit_set(run, items):
    """A run is fitted on when its label and rank count are named and it runs one thread per rank
    (a 1 × T run is used for the thread fractions)."""
    for label, ranks in items:
        if (label == "*" or re.fullmatch(label, run.label)) and (ranks is None or run.ranks in ranks):
            return run.threads == 1 or run.ranks == 1
    return False


def _fit_costs(kind, fr, terms, occ_form, kappa, node_cores):
    """Thread fractions and per-phase costs at a given occupancy coefficient κ."""
    use = [TERMS.index(t) for t in terms]
    kf = KindFit(kind, occ_form=occ_form, kappa=kappa, node_cores=node_cores)
    occ = {id(r): occupancy(occ_form, kappa, r.ranks, r.threads, node_cores) for r in fr}
    feats = {id(r): features(r.scene, r.ranks, run_events(r, False)) for r in fr}
    # Thread fractions: the same label on one rank, 1 thread against T threads, the T cores'
    # occupancy divided out.
    for p in PHASES:
        est = []
        for r1 in fr:
            if r1.ranks != 1 or r1.threads != 1:
                continue
            for rT in fr:
                if rT.label == r1.label and rT.ranks == 1 and rT.threads > 1:
                    x1 = feats[id(r1)][p][0]
                    xT = feats[id(rT)][p][0]
                    if x1 > 0 and xT > 0 and r1.phases[p] > 0:
                        ratio = (rT.phases[p] / xT) / (r1.phases[p] / x1) / (occ[id(rT)] / occ[id(r1)])
                        est.append((1.0 - ratio) / (1.0 - 1.0 / rT.threads))
        kf.frac[p] = float(np.clip(np.mean(est), 0.0, 1.0)) if est else 0.0
        kf.thread_data = kf.thread_data or bool(est)
    kf.rows = len([r for r in fr if r.threads == 1])
    for p in PHASES:
        X, b = [], []
        for r in fr:
            x = feats[id(r)][p].copy()
            x[:2] *= amdahl(kf.frac[p], r.threads) * occ[id(r)]
            wgt = 1.0 / r.loop
            X.append(x * wgt)
            b.append(r.phases[p] * wgt)
        X, b = np.array(X), np.array(b)
        # c = M θ, θ ≥ 0. In the pair phases c_o = θ_o + θ_g, c_g = θ_g: a ghost costs at
        # most what an owned particle costs there (it pairs only with owned particles, about
        # 2 pairs per ghost against 22 per owned particle in the trace logs of the DPD 64k
        # case, and carries no force), which keeps noisy runs from handing the owned work to
        # the nearly proportional ghost count.
        M = np.eye(len(TERMS))
        if p in PAIR_PHASES and {"owned", "ghost"} <= set(terms):
            M[0, 1] = 1.0
        M = M[:, use]
        A = X @ M
        norms = np.linalg.norm(A, axis=0)
        live = norms > 0
        theta = np.zeros(len(use))
        if live.any():
            theta[live] = nnls(A[:, live] / norms[live], b) / norms[live]
        c = M @ theta
        kf.coef[p] = c
        res = X @ c - b
        kf.rms[p] = float(np.sqrt(np.mean(res ** 2))) if len(b) else 0.0
        kf.sse += float(np.sum(res ** 2))
        # Terms the fit runs cannot tell apart: too few runs, or owned, ghost and message
        # counts (nearly) proportional across them (condition number of the scaled matrix).
        if live.sum() > 1:
            sv = np.linalg.svd(A[:, live] / norms[live], compute_uv=False)
            if len(sv) < live.sum() or sv[-1] < 1e-2 * sv[0]:
                kf.under.append(p)
    return kf


def _fit_wait(kf, fr, wait_form):
    """j from the fit runs on P > 1 ranks: pass_wait ≈ j · g(P) · (their predicted work between
    the halo check and the pass collective); least squares, each run weighted by 1 / its loop."""
    kf.wait_form = wait_form
    kf.rms = dict(kf.rms)
    num = den = 0.0
    rows = []
    for r in fr:
        g = wait_growth(wait_form, r.ranks)
        if g <= 0:
            continue
        w = work_between(kf, r.scene, r.ranks, r.threads, run_events(r, False)) * g / r.loop
        y = r.phases.get(WAIT, 0.0) / r.loop
        num += w * y
        den += w * w
        rows.append((w, y))
    kf.jitter = max(0.0, num / den) if den > 0 else 0.0
    kf.wait_rows = len(rows)
    kf.rms[WAIT] = float(np.sqrt(np.mean([(kf.jitter * w - y) ** 2 for w, y in rows]))) if rows else 0.0
    return kf


def fit(runs, terms=TERMS, occ_form="none", wait_form="none", node_cores=NODE_CORES, kappa=None):
    """One KindFit per model kind, from the runs marked `fit`. With an occupancy form, κ ≥ 0
    minimises the fit set's summed residual (a grid, then golden-section search); the costs
    and thread fractions are refitted at each κ. Then the jitter j of the pass wait."""
    fits = {}
    for kind in sorted({r.scene.kind for r in runs if r.fit}):
        fr = [r for r in runs if r.fit and r.scene.kind == kind]
        if occ_form == "none":
            kf = _fit_costs(kind, fr, terms, occ_form, 0.0, node_cores)
        elif kappa is not None:
            kf = _fit_costs(kind, fr, terms, occ_form, kappa, node_cores)
        else:
            cost = lambda k: _fit_costs(kind, fr, terms, occ_form, k, node_cores).sse
            grid = np.linspace(0.0, {"linear": 0.3, "log": 1.0}.get(occ_form, 3.0), 16)
            vals = [cost(k) for k in grid]
            i = int(np.argmin(vals))
            lo, hi = grid[max(0, i - 1)], grid[min(len(grid) - 1, i + 1)]
            gr = (math.sqrt(5.0) - 1.0) / 2.0
            a, bb = lo, hi
            c1, c2 = bb - gr * (bb - a), a + gr * (bb - a)
            f1, f2 = cost(c1), cost(c2)
            while bb - a > 1e-7:
                if f1 < f2:
                    bb, c2, f2 = c2, c1, f1
                    c1 = bb - gr * (bb - a)
                    f1 = cost(c1)
                else:
                    a, c1, f1 = c1, c2, f2
                    c2 = a + gr * (bb - a)
                    f2 = cost(c2)
            best = min([(vals[i], grid[i]), (f1, c1), (f2, c2)])[1]
            kf = _fit_costs(kind, fr, terms, occ_form, float(best), node_cores)
        _fit_wait(kf, fr, wait_form)
        fits[kind] = kf
    return fits


def work_between(kf, scene, P, T, ev):
    """The particle work of the phases between the halo check's allreduce and the pass
    collective (neighbour builds and force passes), occupancy included: what the wait scales with."""
    X = features(scene, P, ev)
    occ = occupancy(kf.occ_form, kf.kappa, P, T, kf.node_cores)
    return sum((kf.coef[p][0] * X[p][0] + kf.coef[p][1] * X[p][1]) * amdahl(kf.frac[p], T) * occ
               for p in WORK_PHASES)


def predict(kf, scene, P, T, ev):
    """Seconds per phase (mean over ranks) for the events `ev`:
    t_p = occ(P·T) · (c_o W_o + c_g W_g) · A(f_p, T) + c_m M, and
    t_wait = j · g(P) · Σ_{neighbour, forces} occ · (c_o W_o + c_g W_g) · A(f_p, T)."""
    out = {}
    X = features(scene, P, ev)
    occ = occupancy(kf.occ_form, kf.kappa, P, T, kf.node_cores)
    for p in PHASES:
        c = kf.coef[p]
        x = X[p]
        out[p] = (c[0] * x[0] + c[1] * x[1]) * amdahl(kf.frac[p], T) * occ + c[2] * x[2]
    out[WAIT] = kf.jitter * wait_growth(kf.wait_form, P) * work_between(kf, scene, P, T, ev)
    return out


def predict_loop(kf, run):
    return sum(predict(kf, run.scene, run.ranks, run.threads, run_events(run, True)).values())


def per_step(kf, scene, P, T):
    return sum(predict(kf, scene, P, T, step_events(scene)).values())


def held_errors(runs, fits):
    return [predict_loop(fits[r.scene.kind], r) / r.loop - 1.0 for r in runs
            if not r.fit and r.scene.kind in fits]


def choose_form(rows):
    """The pass wait is a measured phase (its share of the loop grows with P), so a wait term is
    always modelled: its form g(P) is the one with the smallest fit-set residual of pass_wait.
    The occupancy form, with that wait form: the one-standard-error rule on the leave-one-out
    mean squared error (the simplest form, `none`, unless another beats it by more than one
    standard error of the best's; among forms with one κ, the smallest)."""
    wait_rms = {}
    for x in rows:
        if x["occ"] == "none" and x["wait"] != "none":
            wait_rms[x["wait"]] = sum(kf.rms.get(WAIT, 0.0) ** 2 * kf.wait_rows for kf in x["fits"].values())
    wait = min(wait_rms, key=wait_rms.get) if wait_rms else "none"
    cand = [x for x in rows if x["wait"] == wait]
    for x in cand:
        e2 = np.square(x["loo"]) if x["loo"] else np.array([0.0])
        x["loo_mse"] = float(e2.mean())
        x["loo_se"] = float(e2.std(ddof=1) / math.sqrt(len(e2))) if len(e2) > 1 else 0.0
    best = min(cand, key=lambda x: x["loo_mse"])
    ok = [x for x in cand if x["loo_mse"] <= best["loo_mse"] + best["loo_se"]]
    simple = [x for x in ok if x["occ"] == "none"]
    pick = simple[0] if simple else min(ok, key=lambda x: x["loo_mse"])
    return pick["occ"], wait, best


def compare_forms(runs, terms=TERMS, node_cores=NODE_CORES):
    """Every occupancy × wait form: the fit set's residual, leave-one-out over the fit runs on
    more than one rank (refit without the run, predict its loop time), and the held-out error
    (shown, never used to choose). The choice: the smallest leave-one-out rms."""
    loo_runs = [r for r in runs if r.fit and r.ranks > 1]
    rows = []
    for occ_form in OCC_FORMS:
        full = fit(runs, terms, occ_form, "none", node_cores)
        loo_fits = []
        for r in loo_runs:
            r.fit = False
            loo_fits.append((r, fit(runs, terms, occ_form, "none", node_cores)))
            r.fit = True
        for wait_form in WAIT_FORMS:
            fits = {k: replace(kf) for k, kf in full.items()}
            for k, kf in fits.items():
                _fit_wait(kf, [r for r in runs if r.fit and r.scene.kind == k], wait_form)
            fit_err = [predict_loop(fits[r.scene.kind], r) / r.loop - 1.0 for r in runs if r.fit]
            loo = []
            for r, lf in loo_fits:
                r.fit = False
                kf = replace(lf[r.scene.kind])
                _fit_wait(kf, [x for x in runs if x.fit and x.scene.kind == r.scene.kind], wait_form)
                r.fit = True
                loo.append(predict_loop(kf, r) / r.loop - 1.0)
            held = held_errors(runs, fits)
            rows.append({"occ": occ_form, "wait": wait_form, "fits": fits,
                         "fit_rms": float(np.sqrt(np.mean(np.square(fit_err)))),
                         "loo_rms": float(np.sqrt(np.mean(np.square(loo)))) if loo else float("nan"),
                         "loo_max": float(np.max(np.abs(loo))) if loo else float("nan"),
                         "loo": loo,
                         "held": held})
    return rows


# ---------------------------------------------------------------------------------------------
# Reports
# ---------------------------------------------------------------------------------------------
def weak_labels(runs):
    out = set()
    for label in {r.label for r in runs}:
        ns = [r.scene.particles / r.ranks for r in runs if r.label == label]
        ps = [r.scene.particles for r in runs if r.label == label]
        if len(set(ps)) > 1 and max(ns) / min(ns) < 1.5:
            out.add(label)
    return out


def fmt_ms(s):
    return f"{1e3 * s:.3g}" if s < 1 else f"{1e3 * s:.0f}"


def pct(x):
    return f"{100 * x:.0f} %" if math.isfinite(x) else "—"


def validation(runs, fits, weak, show_phases=False):
    lines = ["### Validation: measured against predicted loop time", "",
             "Efficiency: strong scaling t(1 × 1) / (P·T · t); weak scaling t(1) / t; the measured "
             "1 × 1 time is the base of both columns, so the efficiency's error is the time's.", "",
             "| scene | kind | P × T | role | measured ms/step | predicted | error | measured eff. | predicted eff. |",
             "|---|---|---|---|---|---|---|---|---|"]
    held = []
    for r in sorted(runs, key=lambda r: (r.scene.kind, r.label, r.ranks * r.threads, r.ranks)):
        kf = fits.get(r.scene.kind)
        if kf is None:
            lines.append(f"| {r.label} | {r.scene.kind} | {r.ranks} × {r.threads} | no fit for this kind | "
                         f"{fmt_ms(r.loop / r.steps)} | — | — | — | — |")
            continue
        pred = predict_loop(kf, r)
        base = [b for b in runs if b.label == r.label and b.ranks == 1 and b.threads == 1]
        err = pred / r.loop - 1.0
        if base:
            b = base[0]
            cores = 1 if r.label in weak else r.ranks * r.threads
            em = (b.loop / b.steps) / (cores * r.loop / r.steps)
            ep = (b.loop / b.steps) / (cores * pred / r.steps)
        else:
            em = ep = float("nan")
        role = "fit" if r.fit else "**held out**"
        if not r.fit:
            held.append(abs(err))
        lines.append(f"| {r.label} | {r.scene.kind} | {r.ranks} × {r.threads} | {role} | {fmt_ms(r.loop / r.steps)} | "
                     f"{fmt_ms(pred / r.steps)} | {100 * err:+.1f} % | {pct(em)} | {pct(ep)} |")
    lines.append("")
    if held:
        lines.append(f"Held-out points: {len(held)}; |error| median {100 * float(np.median(held)):.1f} %, "
                     f"largest {100 * max(held):.1f} %.")
    else:
        lines.append("No held-out points: every run was in the fit set (`--fit`).")
    lines.append("")
    if show_phases:
        lines += ["#### Per phase (seconds over the run, setup included; measured / predicted)", "",
                  "| scene | P × T | " + " | ".join(ALL_PHASES) + " |",
                  "|---|---|" + "---|" * len(ALL_PHASES)]
        for r in sorted(runs, key=lambda r: (r.scene.kind, r.label, r.ranks * r.threads, r.ranks)):
            kf = fits.get(r.scene.kind)
            if kf is None:
                continue
            pp = predict(kf, r.scene, r.ranks, r.threads, run_events(r, False))
            cells = [f"{r.phases[p]:.3g} / {pp[p]:.3g}" for p in ALL_PHASES]
            lines.append(f"| {r.label} | {r.ranks} × {r.threads} | " + " | ".join(cells) + " |")
        lines.append("")
    return lines


def engine_counts(runs):
    """Where the summaries carry the engine's own counts (`load`, `phase_seconds_over_ranks`,
    engines after 2026-11-28): the geometry against them, and the imbalance between ranks."""
    lines = []
    with_load = [r for r in runs if r.load]
    if with_load:
        lines += ["### Ghosts: the geometry against the engine's counts (`load`, at the run's end)", "",
                  "| scene | P × T | owned (max) | ghosts, engine mean / max | ghosts, model | model / engine max | pairs per owned |",
                  "|---|---|---|---|---|---|---|"]
        for r in sorted(with_load, key=lambda r: (r.label, r.ranks, r.threads)):
            g = r.load["ghosts"]
            model = r.scene.ghosts(r.ranks)
            ratio = model / g["max"] if g["max"] else float("nan")
            lines.append(f"| {r.label} | {r.ranks} × {r.threads} | {r.load['owned']['max']:.0f} | "
                         f"{g['mean']:.0f} / {g['max']:.0f} | {model:.0f} | {ratio:.3f} | "
                         f"{r.load['pairs']['max'] / max(1.0, r.load['owned']['max']):.2f} |")
        lines.append("")
    with_spread = [r for r in runs if r.spread and r.ranks > 1]
    if with_spread:
        lines += ["### Imbalance between ranks (`phase_seconds_over_ranks`: max / mean)", "",
                  "The message term absorbs rank 0's waits for the slowest rank; this is how uneven the ranks "
                  "are (the forces, halo and rebuild_comm timers hold the waits at their allreduces, so there "
                  "the ratio mixes work and wait).", "",
                  "| scene | P × T | " + " | ".join(ALL_PHASES) + " |", "|---|---|" + "---|" * len(ALL_PHASES)]
        for r in sorted(with_spread, key=lambda r: (r.label, r.ranks, r.threads)):
            cells = []
            for p in ALL_PHASES:
                mean, mx = r.spread["mean"].get(p, 0.0), r.spread["max"].get(p, 0.0)
                cells.append(f"{mx / mean:.2f}" if mean > 0 else "—")
            lines.append(f"| {r.label} | {r.ranks} × {r.threads} | " + " | ".join(cells) + " |")
        lines.append("")
    return lines


def coefficient_table(fits):
    lines = ["### Fitted costs", "",
             "Per owned particle and per ghost: ns per particle and event (in the pair phases "
             "`neighbour` and `forces`, per particle-neighbour, neighbours = ρ·V(cutoff + skin); in "
             "`particle_state`, per dumbbell); per message: µs per sendrecv or allreduce round. "
             "f: the phase's parallel fraction over threads (Amdahl). rms: the fit's residual, "
             "relative to the loop time.", "",
             "| kind | phase | per owned (ns) | per ghost (ns) | per message (µs) | f | rms |",
             "|---|---|---|---|---|---|---|"]
    for kind, kf in fits.items():
        for p in PHASES:
            c = kf.coef[p]
            lines.append(f"| {kind} | {p} | {1e9 * c[0]:.4g} | {1e9 * c[1]:.4g} | {1e6 * c[2]:.4g} | "
                         f"{kf.frac[p]:.2f} | {100 * kf.rms[p]:.1f} % |")
    lines.append("")
    for kind, kf in fits.items():
        lines.append(f"- {kind}: occupancy `{kf.occ_form}` κ = {kf.kappa:.4g} (occ at {kf.node_cores} busy cores "
                     f"{occupancy(kf.occ_form, kf.kappa, kf.node_cores, 1, kf.node_cores):.3f}); pass wait "
                     f"`{kf.wait_form}` j = {kf.jitter:.4g} from {kf.wait_rows} runs on P > 1 "
                     f"(rms {100 * kf.rms.get(WAIT, 0.0):.1f} % of the loop).")
    for kind, kf in fits.items():
        if not kf.thread_data:
            lines.append(f"- {kind}: no 1 × T run in the fit set: threads are assumed to give nothing (f = 0).")
        if kf.under:
            lines.append(f"- {kind}: in {', '.join(kf.under)} the fit runs ({kf.rows} at one thread) hardly "
                         "separate the terms (too few runs, or owned, ghost and message counts nearly proportional "
                         "across them: condition number > 100): the split between the terms there is uncertain, "
                         "and so are predictions far from the fit set.")
    lines.append("")
    return lines


FORM_TEXT = {"none": "1", "linear": "1 + κ(C − 1)", "log": "1 + κ log₂C", "share": "1 + κ(1 − 1/C)",
             "sqrt2lnP": "√(2 ln P)", "emaxP": "E max of P normals", "lnP": "ln P"}


def forms_table(rows, occ_form, wait_form):
    lines = ["### Model forms tried (all of them; the choice uses the fit set only)", "",
             "occ(C): the same particle work's slowdown with C = min(P·T, node) busy cores; g(P): the wait "
             "for the slowest of P ranks, in units of the per-step work's spread. fit rms: every fit run's "
             "loop time; LOO: leave-one-out over the fit runs on 2 and 4 ranks (refit without the run, "
             "predict it). Choice: the wait form with the smallest pass_wait residual, then the occupancy by "
             "the one-standard-error rule on the LOO error (`none` unless beaten by more than one standard "
             "error). The held-out columns are shown, never used to choose.", "",
             "| occ(C) | g(P) | κ per kind | j per kind | fit rms | LOO rms (largest) | held out: median / largest | held out: signed range |",
             "|---|---|---|---|---|---|---|---|"]
    for x in rows:
        h = np.abs(x["held"]) if x["held"] else np.array([float("nan")])
        mark = " **chosen**" if (x["occ"], x["wait"]) == (occ_form, wait_form) else ""
        ks = ", ".join(f"{kf.kappa:.3g}" for kf in x["fits"].values())
        js = ", ".join(f"{kf.jitter:.3g}" for kf in x["fits"].values())
        sg = (f"{100 * min(x['held']):+.0f} … {100 * max(x['held']):+.0f} %" if x["held"] else "—")
        lines.append(f"| {FORM_TEXT[x['occ']]}{mark} | {FORM_TEXT.get(x['wait'], '0') if x['wait'] != 'none' else '0 (no wait)'} | "
                     f"{ks} | {js} | {100 * x['fit_rms']:.1f} % | {100 * x['loo_rms']:.1f} % ({100 * x['loo_max']:.0f} %) | "
                     f"{100 * np.median(h):.1f} / {100 * h.max():.1f} % | {sg} |")
    lines += ["", f"κ and j listed per kind in the order {', '.join(rows[0]['fits'])}.", ""]
    return lines


def limits(runs, fits, rows, weak, cores, max_threads):
    """One line: what limits the prediction, with numbers from these runs."""
    one = [r.loop / r.steps for r in runs if r.ranks == 1 and r.threads == 1]
    occ16 = {x["occ"]: max(occupancy(x["occ"], kf.kappa, 99999, 1, kf.node_cores) for kf in x["fits"].values())
             for x in rows if x["wait"] == "none"}
    # How far apart the wait forms are at the largest core count, same occupancy.
    chosen_occ = next(iter(fits.values())).occ_form
    spread = []
    C = max(cores)
    for label in sorted(weak):
        tmpl = min((r for r in runs if r.label == label), key=lambda r: r.ranks)
        ts = []
        for x in rows:
            if x["occ"] != chosen_occ or x["wait"] == "none" or tmpl.scene.kind not in x["fits"]:
                continue
            sc = tmpl.scene.scaled_along_axis(C / tmpl.ranks)
            ts.append(per_step(x["fits"][tmpl.scene.kind], sc, C, 1))
        if ts:
            spread.append(f"{label} at {C} ranks {fmt_ms(min(ts))}–{fmt_ms(max(ts))} ms/step")
    txt = ("**What limits the prediction:** the fit runs stop at 4 ranks, where the effects to be "
           "extrapolated are of the size of the run-to-run noise (single-rank runs vary by ±25 % on this node; "
           "repeats.csv), so the form of the occupancy slowdown is not determined by them (fitted occ at a full "
           "node: " + ", ".join(f"{k} ×{v:.2f}" for k, v in occ16.items()) + "; the weak series' rank-mean "
           "neighbour and forces times grow ×1.3–1.4 from 1 to 16 ranks, 16 independent copies ×1.12, "
           "contention.csv); the wait's growth beyond the node is g(P) extrapolated from P = 2, 4 (the three "
           "forms give " + "; ".join(spread) + "); nothing between nodes (network latency, bandwidth) was measured.")
    return [txt, ""]


def best_layout(kf, scene, cores, max_threads):
    """Ranks ≤ min(cores, P_max), threads = min(cores // P, max_threads): the fastest."""
    best = None
    for P in range(1, min(cores, scene.p_max()) + 1):
        T = max(1, min(cores // P, max_threads))
        t = per_step(kf, scene, P, T)
        if best is None or t < best[2] * (1 - 1e-12):
            best = (P, T, t)
    return best


def prediction_rows(name, kf, scene, cores_list, max_threads, weak, ranks0=1):
    rows = []
    if weak:
        scene = scene.scaled_along_axis(1.0 / ranks0)   # the one-rank member of the series
        t1 = per_step(kf, scene, 1, 1)
        for C in cores_list:
            sc = scene.scaled_along_axis(C)
            t = per_step(kf, sc, C, 1)
            rows.append(f"| {name} (weak, {sc.particles:,} particles) | {C} | {C} × 1 | {fmt_ms(t)} | — | {pct(t1 / t)} | "
                        f"ghosts/owned {sc.ghosts(C) / sc.owned(C):.2f} |")
        return rows
    t1 = per_step(kf, scene, 1, 1)
    pmax = scene.p_max()
    rows.append(f"| {name} | 1 | 1 × 1 | {fmt_ms(t1)} | 1.0 | 100 % | P_max = {pmax} |")
    for C in cores_list:
        P, T, t = best_layout(kf, scene, C, max_threads)
        note = []
        if P == pmax and pmax < C:
            note.append(f"slab cap P_max = {pmax}")
        if P * T < C:
            note.append(f"{P * T} of {C} cores used")
        note.append(f"ghosts/owned {scene.ghosts(P) / scene.owned(P):.2f}")
        rows.append(f"| {name} | {C} | {P} × {T} | {fmt_ms(t)} | {t1 / t:.1f} | {pct(t1 / (C * t))} | {'; '.join(note)} |")
    return rows


def predictions(runs, fits, weak, cores_list, max_threads, user=None):
    lines = ["### Predictions", "",
             f"Per scene, the fastest layout P × T with P ≤ min(cores, P_max) and T ≤ {max_threads} "
             "threads per rank; efficiency = t(1 × 1) / (cores · t), the cores asked for "
             "(strong scaling), or t(1) / t (weak scaling, the box grown along the slab axis). "
             "The 1 × 1 time is the model's.", "",
             "| scene | cores | P × T | ms/step | speedup | efficiency | note |", "|---|---|---|---|---|---|---|"]
    for label in sorted({r.label for r in runs}):
        mine = [r for r in runs if r.label == label]
        tmpl = min(mine, key=lambda r: (r.ranks * r.threads, r.ranks))
        kf = fits.get(tmpl.scene.kind)
        if kf is None:
            lines.append(f"| {label} | — | — | — | — | — | model kind {tmpl.scene.kind} not in the fit data |")
            continue
        lines += prediction_rows(label, kf, tmpl.scene, cores_list, max_threads, label in weak, tmpl.ranks)
    lines.append("")
    if user is not None:
        scene, name, as_kind, notes = user
        lines += [f"#### The case {name}", ""]
        lines += [f"- {n}" for n in notes]
        kind = as_kind or scene.kind
        kf = fits.get(kind)
        lines.append(f"- {scene.particles:,} particles, box {' × '.join(f'{x:g}' for x in scene.lengths)}, "
                     f"slab axis {'xyz'[scene.axis]}, range {scene.range:g} → P_max = {scene.p_max()}; "
                     f"{scene.rebuild_rate:.3g} neighbour-list builds per step; "
                     f"ghosts/owned at 1 rank {scene.ghosts(1) / scene.owned(1):.2f}, "
                     f"at P_max {scene.ghosts(scene.p_max()) / scene.owned(scene.p_max()):.2f}.")
        if kf is None:
            lines.append(f"- **Its model kind, {scene.kind}, is not in the fit data** (fitted: "
                         f"{', '.join(fits) or 'none'}): no time is predicted. Measure a few runs of "
                         "this kind, or pass `--as-kind KIND` to borrow a fitted kind's costs at your risk.")
        else:
            if as_kind and as_kind != scene.kind:
                lines.append(f"- **Its model kind, {scene.kind}, is not in the fit data: the costs of "
                             f"{as_kind} are borrowed (`--as-kind`)**; expect errors of the order of the "
                             "difference in cost per pair between the models.")
            lines += ["", "| scene | cores | P × T | ms/step | speedup | efficiency | note |",
                      "|---|---|---|---|---|---|---|"]
            lines += prediction_rows(name, kf, scene, [c for c in cores_list], max_threads, False)
        lines.append("")
    return lines


def user_scene(path, particles, rebuild_every, runs):
    notes = []
    if path.endswith(".json"):
        with open(path) as f:
            s = json.load(f)
        r = run_from_summary(s, os.path.basename(os.path.dirname(os.path.abspath(path))))
        scene = r.scene
        if particles:
            scene.particles = particles
        notes.append(f"geometry and rebuild rate from the run {path} ({r.ranks} × {r.threads}, {r.steps} steps)")
    else:
        import tomllib
        with open(path, "rb") as f:
            case = tomllib.load(f)
        try:
            scene = scene_from_case(case, particles=particles)
        except KeyError as e:
            sys.exit(f"{path}: no {e} (pass the summary.json of a short run of the case instead: "
                     "it holds the fully resolved case)")
        same = [r.scene.rebuild_rate for r in runs if r.scene.kind == scene.kind]
        scene.rebuild_rate = float(np.median(same)) if same else 0.5
        notes.append(f"geometry from the case file {path}; the rebuild rate "
                     f"{'is the median of the measured runs of its kind' if same else 'is a guess (0.5 per step)'}"
                     " (pass a run's summary.json for the case's own)")
    if rebuild_every:
        scene.rebuild_rate = 1.0 / rebuild_every
    return scene, notes


# ---------------------------------------------------------------------------------------------
# Self-test: synthetic data from known coefficients
# ---------------------------------------------------------------------------------------------
def _synthetic_runs(coef, frac, steps=400, occ=("none", 0.0), wait=("none", 0.0)):
    """The node's measurement plan (scale.sh), with phase times from known coefficients."""
    dpd = {"dimension": 3, "box": {"lengths": [22.012848, 44.025696, 22.012848]},
           "fluid": {"kind": "dpd", "cutoff": 1.0}, "neighbour": {"skin": 0.5},
           "particles": {"lattice": "fcc", "density": 3.0, "temperature": 1.0},
           "integrator": {"kind": "groot_warren"}, "run": {"sample_every": 50}}
    weak = json.loads(json.dumps(dpd))
    weak["box"]["lengths"] = [17.610278] * 3
    coupled = {"dimension": 3, "box": {"lengths": [1.5, 3.5, 1.5], "shear_rate": 1.0},
               "fluid": {"kind": "sph", "kernel": "lucy", "smoothing_length": 0.1875,
                         "polymer": {"model": "dumbbells", "per_particle": 100}},
               "neighbour": {"skin": 0.01},
               "particles": {"lattice": "cubic", "density": 4096.0, "temperature": 0.0},
               "integrator": {"kind": "kick_drift_kick"}, "run": {"sample_every": 5}}
    plan = [("dpd_strong", dpd, 0.5, [(1, 1), (2, 1), (4, 1), (8, 1), (16, 1), (1, 16), (4, 4), (8, 2)], False),
            ("dpd_weak", weak, 0.5, [(1, 1), (2, 1), (4, 1), (8, 1), (16, 1)], True),
            ("coupled", coupled, 1.0, [(1, 1), (2, 1), (4, 1), (8, 1), (1, 16), (8, 2)], False)]
    runs = []
    for label, case, rate, layouts, is_weak in plan:
        base = scene_from_case(case)
        base.rebuild_rate = rate
        for P, T in layouts:
            sc = base.scaled_along_axis(P) if is_weak else replace(base)
            R = 1 + int(round(rate * steps))
            r = Run(label=label, scene=sc, ranks=P, threads=T, steps=steps, rebuilds=R, loop=0.0, phases={})
            kf = KindFit(sc.kind, coef=coef[sc.kind], frac=frac[sc.kind], occ_form=occ[0], kappa=occ[1],
                         wait_form=wait[0], jitter=wait[1])
            r.phases = predict(kf, sc, P, T, run_events(r, False))
            r.loop = predict_loop(kf, r)
            runs.append(r)
    return runs


def selftest():
    ok = True

    def check(cond, what):
        nonlocal ok
        print(f"  [{'ok' if cond else 'FAIL'}] {what}")
        ok = ok and bool(cond)

    rng = np.random.default_rng(42)
    kinds = ["dpd/3d", "sph+dumbbells/3d"]
    coef, frac = {}, {}
    for k in kinds:
        coef[k], frac[k] = {}, {}
        for p in PHASES:
            c = rng.uniform(0.5, 2.0, 3) * np.array([2e-9, 3e-9, 2e-5])
            if p in ("integrate", "particle_state"):
                c[1:] = 0.0
            if p == "neighbour":
                c[2] = 0.0
            if p in PAIR_PHASES:
                c[1] = c[0] * rng.uniform(0.05, 0.9)   # a ghost costs less than an owned particle
            if p == "diagnostics":
                c[1] = 0.0
            coef[k][p] = c
            frac[k][p] = float(rng.uniform(0.3, 0.95))
    runs = _synthetic_runs(coef, frac)
    items = parse_fit_spec("*:1,2,4")
    for r in runs:
        r.fit = in_fit_set(r, items)
    fits = fit(runs)
    worst_c = max(abs(fits[k].coef[p][i] - coef[k][p][i]) / max(abs(coef[k][p][i]), 1e-30)
                  for k in kinds for p in PHASES for i in range(3) if coef[k][p][i] > 0)
    zeros = max(abs(fits[k].coef[p][i]) / np.abs(coef[k][p]).max()
                for k in kinds for p in PHASES for i in range(3) if coef[k][p][i] == 0)
    worst_f = max(abs(fits[k].frac[p] - frac[k][p]) for k in kinds for p in PHASES)
    check(worst_c < 1e-6 and zeros < 1e-6, f"the fit recovers every coefficient (largest relative error {worst_c:.1e}, zeros {zeros:.1e})")
    check(worst_f < 1e-9, f"the fit recovers every thread fraction (largest error {worst_f:.1e})")
    held = [r for r in runs if not r.fit]
    worst_p = max(abs(predict_loop(fits[r.scene.kind], r) / r.loop - 1) for r in held)
    check(len(held) >= 8 and worst_p < 1e-6,
          f"{len(held)} held-out points (8, 16 ranks, 4 × 4, 8 × 2) predicted to {worst_p:.1e}")
    # Sensitivity: the same fit without the ghost term must miss the held-out points.
    fits_ng = fit(runs, terms=("owned", "message"))
    miss = max(abs(predict_loop(fits_ng[r.scene.kind], r) / r.loop - 1) for r in held)
    check(miss > 1e-2, f"dropping the ghost term is caught: held-out error {100 * miss:.1f} % (> 1 %)")
    fits_nm = fit(runs, terms=("owned", "ghost"))
    miss_m = max(abs(predict_loop(fits_nm[r.scene.kind], r) / r.loop - 1) for r in held)
    check(miss_m > 1e-2, f"dropping the message term is caught: held-out error {100 * miss_m:.1f} % (> 1 %)")
    # Node occupancy and the pass wait: a known κ (linear) and j (E max of P normals) come back.
    runs_ow = _synthetic_runs(coef, frac, occ=("linear", 0.03), wait=("emaxP", 0.15))
    for r in runs_ow:
        r.fit = in_fit_set(r, items)
    fits_ow = fit(runs_ow, occ_form="linear", wait_form="emaxP")
    dk = max(abs(kf.kappa - 0.03) for kf in fits_ow.values())
    dj = max(abs(kf.jitter - 0.15) for kf in fits_ow.values())
    held_ow = [r for r in runs_ow if not r.fit]
    worst_ow = max(abs(predict_loop(fits_ow[r.scene.kind], r) / r.loop - 1) for r in held_ow)
    check(dk < 1e-5 and dj < 1e-4 and worst_ow < 1e-4,
          f"occupancy κ and wait jitter j recovered (errors {dk:.1e}, {dj:.1e}); held-out points to {worst_ow:.1e}")
    miss_ow = max(abs(predict_loop(fit(runs_ow, wait_form="emaxP")[r.scene.kind], r) / r.loop - 1) for r in held_ow)
    check(miss_ow > 1e-2, f"leaving the occupancy out is caught: held-out error {100 * miss_ow:.1f} % (> 1 %)")
    # Geometry against the engine's own counts (`--log-level trace`, 2026-11-28, this machine).
    dpd = next(r.scene for r in runs if r.label == "dpd_strong")
    cpl = next(r.scene for r in runs if r.label == "coupled")
    g = dpd.ghosts(1)
    check(abs(g / 24240 - 1) < 0.01, f"DPD 64k ghosts on 1 rank: model {g:.0f}, engine 24 150–24 330 after melting")
    g2 = dpd.ghosts(2)
    check(abs(g2 / 14930 - 1) < 0.01, f"DPD 64k ghosts on 2 ranks: model {g2:.0f}, engine 14 870–15 010 (steps 20–60, both ranks)")
    cold = replace(cpl, shear_rate=0.0)
    check(round(cold.ghosts(1)) == 23544, f"cold cubic lattice (coupled, step 0): model {cold.ghosts(1):.0f}, engine 23 544")
    check(abs(cpl.ghosts(1) / 24100 - 1) < 0.01, f"coupled, sheared along x: model {cpl.ghosts(1):.0f}, engine 24 050–24 260")
    check(dpd.p_max() == 29 and cpl.p_max() == 17, f"slab caps: DPD 64k {dpd.p_max()} (44.03 / 1.5), coupled {cpl.p_max()} (3.5 / 0.1975)")
    # The loader, from a folder and a tarball laid out as scale.sh writes them.
    with tempfile.TemporaryDirectory() as tmp:
        r = runs[1]
        case = {"dimension": 3, "box": {"lengths": r.scene.lengths, "boundaries": None, "shear_rate": 0.0},
                "decomposition": {"axis": "y"}, "fluid": {"kind": "dpd", "cutoff": 1.0},
                "neighbour": {"skin": 0.5}, "integrator": {"kind": "groot_warren"},
                "particles": {"lattice": "fcc", "density": 3.0, "temperature": 1.0},
                "run": {"sample_every": 50}}
        g = r.scene.ghosts(r.ranks)
        s = {"load": {"owned": {"mean": r.scene.owned(r.ranks), "max": r.scene.owned(r.ranks)},
                      "ghosts": {"mean": g, "max": g}, "pairs": {"mean": 1.0, "max": 1.0}},
             "phase_seconds_over_ranks": {"mean": r.phases, "max": {k: 1.5 * v for k, v in r.phases.items()}},
             "case": case, "ranks": r.ranks, "threads": r.threads, "particles": r.scene.particles,
             "steps": r.steps, "loop_seconds": r.loop, "completed": True,
             "phase_seconds": dict(r.phases, rebuilds=r.rebuilds, snapshots=0.0, checkpoints=0.0,
                                   passes=[{"model": "dpd", "pass": "pair forces", "seconds": r.phases["forces"]}])}
        d = os.path.join(tmp, "runs", f"{r.label}-n{r.ranks}-t{r.threads}")
        os.makedirs(d)
        with open(os.path.join(d, "summary.json"), "w") as f:
            json.dump(s, f)
        tgz = os.path.join(tmp, "summaries.tgz")
        with tarfile.open(tgz, "w:gz") as tar:
            tar.add(os.path.join(d, "summary.json"), arcname=f"runs/{r.label}-n{r.ranks}-t{r.threads}/summary.json")
        a, _ = load_runs(tmp)
        b, _ = load_runs(tgz)
        same = (len(a) == len(b) == 1 and a[0].key == b[0].key == r.key
                and abs(predict_loop(KindFit(r.scene.kind, coef["dpd/3d"], frac["dpd/3d"]), a[0]) / r.loop - 1) < 1e-12)
        check(same, "summary.json from a folder and from a .tgz load as the run they were written from")
        table = "\n".join(engine_counts(a))
        check(f"| {g:.0f} | 1.000 |" in table and "| 1.50 | 1.50 |" in table,
              "the engine's counts (`load`, `phase_seconds_over_ranks`) are read and set beside the model")
    print("scale_model self-test:", "passed" if ok else "FAILED")
    return ok


# ---------------------------------------------------------------------------------------------
def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", help="folder holding runs/<label>-n<N>-t<T>/summary.json, or summaries.tgz")
    ap.add_argument("--fit", default="*:1,2,4",
                    help="fit set: 'LABEL:R1,R2;…' (LABEL a regex or *), one thread per rank; 1 × T runs "
                         "of a named label give the thread fractions (default '*:1,2,4')")
    ap.add_argument("--ranks", default="64,256,1024", help="core counts to predict (default 64,256,1024)")
    ap.add_argument("--max-threads", type=int, default=64, help="threads per rank at most (default 64)")
    ap.add_argument("--exclude", default="le_digest,smoke,smoke_c", help="labels (regexes) to leave out")
    ap.add_argument("--case", help="a user's case: a case file (.toml) or a run's summary.json")
    ap.add_argument("--particles", type=int, help="with --case: the particle count (else the lattice's)")
    ap.add_argument("--rebuild-every", type=float, help="with --case: steps per neighbour-list build")
    ap.add_argument("--as-kind", help="with --case: use this fitted kind's costs (e.g. dpd/3d)")
    ap.add_argument("--phases", action="store_true", help="also the per-phase validation table")
    ap.add_argument("--selftest", action="store_true", help="recover known coefficients from synthetic runs")
    ap.add_argument("--occupancy", default="auto", choices=("auto",) + OCC_FORMS,
                    help="node occupancy factor on the particle work (default: chosen on the fit set)")
    ap.add_argument("--wait", default="auto", choices=("auto",) + WAIT_FORMS,
                    help="growth g(P) of the pass wait (default: chosen on the fit set)")
    ap.add_argument("--node-cores", type=int, default=NODE_CORES,
                    help=f"cores per node: the occupancy saturates there (default {NODE_CORES})")
    ap.add_argument("--rank0", action="store_true",
                    help="fit rank 0's phase times instead of the mean over ranks")
    a = ap.parse_args(argv)
    if a.selftest:
        return 0 if selftest() else 1
    if not a.runs:
        ap.error("--runs DIR|summaries.tgz is needed (the output of ../shared/tools/devscale/scale.sh)")
    runs, skipped = load_runs(a.runs, [x for x in a.exclude.split(",") if x], a.rank0)
    if not runs:
        sys.exit(f"no runs/<label>-n<N>-t<T>/summary.json in {a.runs}")
    items = parse_fit_spec(a.fit)
    for r in runs:
        r.fit = in_fit_set(r, items)
    rows = compare_forms(runs, node_cores=a.node_cores)
    occ_form, wait_form, _best = choose_form(rows)
    occ_form = occ_form if a.occupancy == "auto" else a.occupancy
    wait_form = wait_form if a.wait == "auto" else a.wait
    fits = next(x["fits"] for x in rows if x["occ"] == occ_form and x["wait"] == wait_form)
    weak = weak_labels(runs)
    cores = [int(c) for c in a.ranks.split(",")]
    user = None
    if a.case:
        scene, notes = user_scene(a.case, a.particles, a.rebuild_every, runs)
        name = os.path.basename(a.case)
        if name == "summary.json":
            name = os.path.basename(os.path.dirname(os.path.abspath(a.case)))
        user = (scene, name, a.as_kind, notes)
    out = ["## Scaling model", "",
           f"Runs: {a.runs} ({len(runs)} runs, labels {', '.join(sorted({r.label for r in runs}))}; "
           f"weak scaling: {', '.join(sorted(weak)) or 'none'}). Fit set `{a.fit}`: "
           f"{sum(r.fit for r in runs)} runs. Phase times are "
           f"{'rank 0' if a.rank0 or not any(r.mean_phases for r in runs) else 'the mean over ranks (`phase_seconds_over_ranks`; rank 0'}"
           f"'s{'' if a.rank0 or not any(r.mean_phases for r in runs) else ' on one rank)'}. Model form: occupancy `{occ_form}`"
           f"{'' if a.occupancy == 'auto' else ' (--occupancy)'}, wait `{wait_form}`{'' if a.wait == 'auto' else ' (--wait)'}"
           f" (node of {a.node_cores} cores).", ""]
    out += [f"- skipped: {s}" for s in skipped]
    out += coefficient_table(fits)
    out += forms_table(rows, occ_form, wait_form)
    out += validation(runs, fits, weak, a.phases)
    out += limits(runs, fits, rows, weak, cores, a.max_threads)
    out += engine_counts(runs)
    out += predictions(runs, fits, weak, cores, a.max_threads, user)
    print("\n".join(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
