#!/usr/bin/env bash
# The same points with the baseline binary (base/mesorheo) and the changed one (bin/mesorheo),
# interleaved run by run on the same node: loop seconds, phases and digests side by side.
# Writes $OUT/compare.csv and the summaries under $OUT/cmp/. Run from the devscale folder.
set -u
D=$(cd "$(dirname "$0")" && pwd)
export LD_LIBRARY_PATH="$D/mpich/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}" PATH="$D/mpich/bin:$PATH"
OUT=${OUT:-/tmp/scaleout}; mkdir -p "$OUT/cmp"
CSV="$OUT/compare.csv"
echo "binary,label,ranks,threads,loop_s,neighbour_s,rebuild_comm_s,forces_s,halo_s,integrate_s,digest" > "$CSV"
run() { # binary label ranks threads case [args]
  local which=$1 label=$2 n=$3 t=$4 c=$5; shift 5
  local o="$OUT/cmp/$which-$label-n$n-t$t"; rm -rf "$o"
  timeout 150 mpiexec -n "$n" -bind-to none "$D/$which/mesorheo" run "$D/cases/$c" --out "$o" -t "$t" -q "$@" > "$o.log" 2>&1
  python3 - "$o/summary.json" "$which" "$label" "$n" "$t" >> "$CSV" <<'PY'
import json, sys
p, which, label, n, t = sys.argv[1:]
try:
    s = json.load(open(p)); ph = s["phase_seconds"]
    print(f"{which},{label},{n},{t},{s['loop_seconds']:.4f},{ph['neighbour']:.4f},{ph['rebuild_comm']:.4f},"
          f"{ph['forces']:.4f},{ph['halo']:.4f},{ph['integrate']:.4f},{s['state_digest']}")
except Exception as e:
    print(f"{which},{label},{n},{t},,,,,,,FAILED {type(e).__name__}")
PY
  tail -1 "$CSV"
}
both() { run base "$@"; run bin "$@"; }
both dpd 1 1 dpd_strong.toml
both dpd 1 16 dpd_strong.toml
both dpd 16 1 dpd_strong.toml
both dpd 4 4 dpd_strong.toml
both coupled 1 16 coupled_3d.toml
both coupled 8 2 coupled_3d.toml
both coupled 8 1 coupled_3d.toml
both sph 1 16 sph_bench.toml --steps 400 --set run.sample_every=20
both sph 1 1 sph_bench.toml --steps 400 --set run.sample_every=20
