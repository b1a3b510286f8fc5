r"""What the full paper costs, measured on a sample: the first K seeds of every cell, played.

``ns-pz bench estimate`` times each agent × cell for a second or two and projects an episode it
had to cut to the horizon: an upper bound, and a loose one where agents fail early (a CartPole
episode of an agent that drops the pole after 140 steps is projected to 2,500). This script
plays the first ``--seeds`` seeds of every cell to the end instead, through the runner and its
workers as ``ns-pz bench run`` does (networks trained first, cached), and scales each agent ×
cell's measured seconds by ``episodes / seeds``. The 95 % interval resamples the seeds of each
agent × cell (bootstrap), so it says how far the sample's own spread lets the total move; it
cannot see costs that none of the sampled seeds met. A worker's first trial of an agent also
pays that agent's first use (imports, loading compiled code), which the scaling counts
``episodes / seeds`` times: in two 5-seed samples of the paper, every first seed's excess over
the median of its cell's other seeds, scaled, summed to 0.13 and 0.18 h (a bound on that bias),
leaving out DDQN-WN's two continuous CartPole cells, whose first seeds were long episodes (2,500
and 713 steps).

Seconds are each trial's wall time in its worker (one thread each): CPU seconds when the
workers have a core each (``--workers`` at most the number of idle cores). Training is not in
the totals (``ns-pz bench estimate`` gives it; the runner prints each network's time).

Run (a throwaway cache trains the networks anew; 5 seeds of the full paper took 11 min 47 s on
two cores, training included)::

    NS_PZ_CACHE_DIR=/tmp/cache python benchmarks/bench_paper_sample.py --seeds 5 --workers 2 \
        --out /tmp/paper-sample
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

from ns_pz.experiments import LocalBackend, ResultStore, load_spec
from ns_pz.experiments.runner import run_spec
from ns_pz.experiments.spec import ExperimentSpec, shipped_specs


def sampled(spec: ExperimentSpec, seeds: int) -> ExperimentSpec:
    """``spec`` with only its first ``seeds`` episodes per cell.

    Raises:
        ValueError: ``seeds`` is below 1 or above the spec's episodes.
    """
    if not 1 <= seeds <= spec.episodes:
        raise ValueError(f"seeds={seeds!r} must lie in [1, {spec.episodes}] for {spec.name}")
    return dataclasses.replace(spec, episodes=seeds)


Groups = dict[tuple[str, ...], tuple[float, list[float]]]
"""Per agent × cell: ``(full episodes per sampled one, the sampled trials' seconds)``."""


def project(groups: Groups, draws: int, seed: int = 0) -> tuple[float, float, float]:
    """``(total, low, high)``: the sampled seconds, scaled, with a 95 % bootstrap interval.

    Args:
        groups: The sampled agent × cells.
        draws: Bootstrap resamples (seeds resampled within each agent × cell).
        seed: The bootstrap's generator seed.
    """
    rng = np.random.default_rng(seed)
    total = sum(scale * sum(values) for scale, values in groups.values())
    resampled = np.zeros(draws)
    for scale, values in groups.values():
        array = np.asarray(values)
        picks = rng.integers(0, len(array), size=(draws, len(array)))
        resampled += scale * array[picks].sum(axis=1)
    low, high = np.percentile(resampled, [2.5, 97.5])
    return total, float(low), float(high)


def measure(
    spec: ExperimentSpec, seeds: int, out: Path, backend: LocalBackend, resume: bool
) -> Groups:
    """Play the first ``seeds`` seeds of every cell of ``spec`` into ``out``; their groups."""
    sample = sampled(spec, seeds)
    run_spec(sample, out, backend, resume, sys.stderr)
    groups: Groups = {}
    scale = spec.episodes / sample.episodes
    for row in ResultStore(out).rows():
        if row["status"] != "ok":
            raise RuntimeError(f"{row['trial']} failed ({row['error']}): the sample is incomplete")
        key = (spec.name, row["setting"], row["notification"], row["agent"])
        groups.setdefault(key, (scale, []))[1].append(float(row["wall_time"]))
    return groups


def hours(seconds: float) -> str:
    """``seconds`` in hours, two decimals."""
    return f"{seconds / 3600:.2f} h"


def main() -> None:
    """Run the sample and print the projection, per spec and in total."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("specs", nargs="*", help="spec names or files (default: the paper's)")
    parser.add_argument("--size", default="full", choices=["quick", "full"])
    parser.add_argument("--seeds", type=int, default=5, help="seeds played per cell")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", required=True, help="results root (a folder per spec)")
    parser.add_argument("--resume", action="store_true", help="finish a sample in --out")
    parser.add_argument("--draws", type=int, default=2000, help="bootstrap resamples")
    args = parser.parse_args()
    specs = [load_spec(name, args.size) for name in args.specs or shipped_specs()]
    every: Groups = {}
    lines = []
    with LocalBackend(args.workers) as backend:
        for spec in specs:
            out = Path(args.out) / f"{spec.name}-{spec.size}"  # as ``ns-pz bench run`` names it
            groups = measure(spec, args.seeds, out, backend, args.resume)
            every.update(groups)
            total, low, high = project(groups, args.draws)
            by_agent: dict[str, float] = defaultdict(float)
            for key, (scale, values) in groups.items():
                by_agent[key[-1]] += scale * sum(values)
            top = sorted(by_agent.items(), key=lambda item: -item[1])[:3]
            sampled_seconds = sum(sum(values) for _, values in groups.values())
            lines.append(
                f"  {spec.name:24s} {sampled_seconds:8.1f} s -> {hours(total):>8s} "
                f"[{hours(low)}, {hours(high)}]  "
                + ", ".join(f"{agent} {hours(seconds)}" for agent, seconds in top)
            )
    total, low, high = project(every, args.draws)
    print(
        f"\nThe first {args.seeds} seeds of every cell ({args.size} size), played; each agent x "
        "cell's trial seconds scaled to its episodes, 95 % bootstrap interval over seeds:"
    )
    print("\n".join(lines))
    print(f"  {'all':24s} {'':10s} -> {hours(total):>8s} [{hours(low)}, {hours(high)}]")


if __name__ == "__main__":
    main()
