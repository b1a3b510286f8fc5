#!/bin/bash
# The FrozenLake single table on 1, 2, 4, 8 and 16 workers of a 16-core machine (full size) and on
# 1 and 16 (quick), each run from an empty network cache with the compiled kernels already cached
# (a first quick run on 16 workers compiles them). The 16-worker runs go alone; the others run
# side by side, each pinned to cores of its own, so the sweep takes about as long as its
# one-worker run, which also projects 16 workers from its own times (--project 16). Each run's
# log lands in OUT/full/N.log or OUT/quick/N.log and its wall and CPU seconds in OUT/sweep.txt.
# Usage, from the repository root:
#
#     bash benchmarks/scaling_sweep.sh [OUT]        # default OUT: scaling-sweep
set -u
OUT=${1:-scaling-sweep}
PY=${PY:-python3}
T0=$SECONDS
CACHE=$(mktemp -d)
mkdir -p "$OUT/full" "$OUT/quick"
{ nproc; uptime; } > "$OUT/sweep.txt"
NS_PZ_CACHE_DIR=$CACHE/warm $PY -m ns_pz.cli bench run frozenlake-single --size quick --workers 16 \
  --out "$CACHE/warm-run" > /dev/null 2>&1
sweep() {  # size workers cores [options of bench_scaling.py]
  local size=$1 workers=$2 cores=$3
  shift 3
  mkdir -p "$CACHE/$size$workers" && cp -r "$CACHE/warm/numba" "$CACHE/$size$workers/"
  echo "start $size $workers workers at $((SECONDS - T0)) s, load $(cut -d' ' -f1 /proc/loadavg)" \
    >> "$OUT/sweep.txt"
  taskset -c "$cores" $PY benchmarks/bench_scaling.py --size "$size" --workers "$workers" \
    --cache "$CACHE/$size$workers" --log-dir "$OUT/$size" "$@" >> "$OUT/sweep.txt" 2>&1
}
sweep quick 16 0-15
sweep full 16 0-15
sweep full 1 15 --project 16 &  # the projection, to check against the 16-worker run
sweep quick 1 14 &
sweep full 2 0-1 &
sweep full 4 2-5 &
sweep full 8 6-13 &
wait
rm -rf "$CACHE"
