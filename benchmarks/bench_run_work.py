r"""What a finished run's trials cost: their seconds, summed per table and per agent.

``bench_paper_sample.py`` projects the full paper from a few seeds per cell; this script reads
the rows of a run that played every trial (``ns-pz bench run paper --size full --out DIR``)
and adds up what each trial took in its worker (its ``wall_time``: CPU seconds where the
workers had a core each). Training is not in the rows, so not in the sums. A worker's first
trial of an agent also pays that agent's first use in the process (imports, loading compiled
code), once per worker, as in any run.

Run::

    python benchmarks/bench_run_work.py DIR     # DIR: the run's --out (a folder per table)
"""

from __future__ import annotations

import argparse
from collections import defaultdict
from pathlib import Path

from ns_pz.experiments import ResultStore


def hours(seconds: float) -> str:
    """``seconds`` in hours, two decimals."""
    return f"{seconds / 3600:.2f} h"


def main() -> None:
    """Print each table's trial hours (with its three dearest agents), then each agent's."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("root", help="the run's results root (its --out)")
    args = parser.parse_args()
    tables = sorted(path.parent for path in Path(args.root).glob("*/trials.jsonl"))
    if not tables:
        raise SystemExit(f"{args.root}: no table's trials.jsonl below it")
    by_agent: dict[str, float] = defaultdict(float)
    total = 0.0
    for folder in tables:
        rows = ResultStore(folder).rows()
        seconds: dict[str, float] = defaultdict(float)
        for row in rows:
            seconds[row["agent"]] += float(row["wall_time"] or 0.0)
        failed = sum(row["status"] != "ok" for row in rows)
        table = sum(seconds.values())
        total += table
        for agent, value in seconds.items():
            by_agent[agent] += value
        top = sorted(seconds.items(), key=lambda item: -item[1])[:3]
        print(
            f"{folder.name:30s} {len(rows):6d} trials ({failed} failed) {hours(table):>8s}  "
            + ", ".join(f"{agent} {hours(value)}" for agent, value in top)
        )
    print(f"{'all':30s} {'':22s} {hours(total):>8s}")
    for agent, value in sorted(by_agent.items(), key=lambda item: -item[1]):
        print(f"  {agent:40s} {hours(value):>8s}")


if __name__ == "__main__":
    main()
