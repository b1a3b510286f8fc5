#!/bin/bash
# The FrozenLake single table on 1, 2, 4, 8 and 16 workers of a 16-core machine (full size) and on
# 1 and 16 (quick), each run from an empty network cache with the compiled kernels already cached
# (a first quick run on 16 workers compiles them). The 16-worker runs go alone; the others run
# side by side, each pinned to cores of its own, so the sweep takes about as long as its
# one-worker run. Each run's log lands in OUT/full/N.log or OUT/quick/N.log and its wall and CPU
# seconds in OUT/sweep.txt. Usage, from the repository root:
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
sweep() {  # size workers cores
  mkdir -p "$CACHE/$1$2" && cp -r "$CACHE/warm/numba" "$CACHE/$1$2/"
  echo "start $1 $2 workers at $((SECONDS - T0)) s, load $(cut -d' ' -f1 /proc/loadavg)" >> "$OUT/sweep.txt"
  taskset -c "$3" $PY benchmarks/bench_scaling.py --size "$1" --workers "$2" --cache "$CACHE/$1$2" \
    --log-dir "$OUT/$1" >> "$OUT/sweep.txt" 2>&1
}
sweep quick 16 0-15
sweep full 16 0-15
sweep full 1 15 &
sweep quick 1 14 &
sweep full 2 0-1 &
sweep full 4 2-5 &
sweep full 8 6-13 &
wait
rm -rf "$CACHE"
