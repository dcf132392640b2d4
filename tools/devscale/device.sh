#!/usr/bin/env bash
# One device call of issue #42's measurements, from the repository root (devscale/ carried):
#   bash tools/devscale/device.sh 1   scale.sh all, compare.sh (baseline vs changed), sph.sh
#   bash tools/devscale/device.sh 2   lammps.sh (LAMMPS strong/weak + mesorheo ratio points), contention.sh
# Everything lands in one archive, $OUT/partN.tgz (the device tool returns at most 8 files).
set -u
PART=${1:?part 1 or 2}
D=$PWD/devscale
cp tools/devscale/compare.sh "$D/"
FINAL=${OUT:-/tmp/final}; R=/tmp/devres$PART; rm -rf "$R"; mkdir -p "$R" "$FINAL"
export OUT=$R
(nproc; lscpu | grep -i "model name\|^CPU(s)\|Thread\|Socket\|NUMA"; date -u) > "$R/node.txt"
t0=$(date +%s)
if [ "$PART" = 1 ]; then
  bash "$D/scale.sh" all > "$R/scale_stdout.txt" 2>&1; echo "scale done $(( $(date +%s) - t0 )) s"; tar czf "$FINAL/part$PART.tgz" -C "$R" .
  bash "$D/compare.sh" > "$R/compare_stdout.txt" 2>&1; echo "compare done $(( $(date +%s) - t0 )) s"; tar czf "$FINAL/part$PART.tgz" -C "$R" .
  bash "$D/sph.sh" > "$R/sph_stdout.txt" 2>&1; echo "sph done $(( $(date +%s) - t0 )) s"
else
  bash "$D/lammps.sh" > "$R/lammps_stdout.txt" 2>&1; echo "lammps done $(( $(date +%s) - t0 )) s"; tar czf "$FINAL/part$PART.tgz" -C "$R" .
  bash "$D/contention.sh" > "$R/contention_stdout.txt" 2>&1; echo "contention done $(( $(date +%s) - t0 )) s"
fi
cat "$R"/*.csv
tar czf "$FINAL/part$PART.tgz" -C "$R" .
