#!/usr/bin/env bash
# Interleaved rounds of {OLD binary, NEW binary, LAMMPS} on LAMMPS's in.dpd
# (cases/bench_dpd_32k.toml), 1 rank × 1 thread, one run each per round; prints the loop times,
# the per-round throughput ratios NEW/OLD and LAMMPS/NEW, and their medians.
#
#   tools/ab_lammps.sh OLD_BIN NEW_BIN [ROUNDS]      (default 7 rounds)
#   BENCH=sph tools/ab_lammps.sh OLD_BIN NEW_BIN     the SPH benchmark (cases/bench_sph_2d.toml
#                                                    against benches/lammps/in.sph)
#
# LAMMPS comes from benches/lammps/run_lammps.sh (installed on first use, outside the project's
# dependencies). Run with nothing else on the machine; quote the medians.
set -euo pipefail
cd "$(dirname "$0")/.."
OLD=$(realpath "$1"); NEW=$(realpath "$2"); ROUNDS=${3:-7}
case "${BENCH:-dpd}" in
  dpd) CASE=cases/bench_dpd_32k.toml; export INPUT=in.dpd THERMO_COL=Press ;;
  sph) CASE=cases/bench_sph_2d.toml; export INPUT=in.sph THERMO_COL=KinEng ;;
  *) echo "BENCH is dpd or sph" >&2; exit 2 ;;
esac
tmp=$(mktemp -d)
for r in $(seq 1 "$ROUNDS"); do
  for b in old new; do
    bin=$OLD; [[ $b == new ]] && bin=$NEW
    rm -rf "$tmp/$b"
    "$bin" run "$CASE" --out "$tmp/$b" -t 1 -q 2>/dev/null
    python3 -c "import json;s=json.load(open('$tmp/$b/summary.json'));print('$r $b',s['loop_seconds'],s['state_digest'])"
  done
  RANKS=1 REPEATS=1 benches/lammps/run_lammps.sh 2>/dev/null | grep "^lammps ranks" | sed "s/^/$r /" || true
done | tee "$tmp/rounds.txt"
python3 - "$tmp/rounds.txt" <<'PY'
import re, statistics, sys
rows = {}
for line in open(sys.argv[1]):
    p = line.split()
    if p[1] in ("old", "new"):
        rows.setdefault(int(p[0]), {})[p[1]] = float(p[2])
    else:
        rows.setdefault(int(p[0]), {})["lammps"] = float(re.search(r"loop_s=([\d.]+)", line).group(1))
ab = [v["old"] / v["new"] for v in rows.values()]
lm = [v["lammps"] / v["new"] for v in rows.values() if "lammps" in v]
print("throughput NEW/OLD per round:", " / ".join(f"{x:.3f}" for x in ab), f"median {statistics.median(ab):.3f}")
if lm:
    print("LAMMPS/NEW per round:", " / ".join(f"{x:.2f}" for x in lm), f"median {statistics.median(lm):.2f}")
PY
rm -rf "$tmp"
