"""The paper's benchmark, and how to read its tables
=================================================

``ns-pz bench run paper`` runs the NS-Gym paper's experiments from specs: small TOML files
naming the environment, θ_0, the change, the notification levels and the agents. This page
runs one of the shipped specs, shrunk, and reads its tables; on the command
line the same is ``ns-pz bench run frozenlake-single --out results`` and
``ns-pz bench table results``. The :doc:`/benchmark` page lists the commands and the shipped
specs.
"""

# %%
# A spec
# ------
#
# The shipped spec of the paper's FrozenLake table: the chance that a move goes where it was
# meant to drops from 0.7 to 0.4, 0.6 or 0.8 after the first decision epoch
# (``first_step = 1``), with and without notification.

import dataclasses
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

from ns_pz.experiments import LocalBackend, ResultStore, load_spec, run_spec, shipped_specs
from ns_pz.experiments.optimum import optimum_for
from ns_pz.experiments.report import summarise, table

print(shipped_specs()["frozenlake-single"].read_text())

# %%
# To keep the build short, this page keeps one setting and four agents of the ``quick`` size,
# with the paper's 100 episodes per cell: enough that the agents' means separate by more than
# their standard errors. A spec is a frozen value, so shrinking it is
# ``dataclasses.replace``.

spec = load_spec("frozenlake-single", size="quick")
spec = dataclasses.replace(
    spec,
    change=dataclasses.replace(spec.change, to=(0.4,)),
    agents=tuple(a for a in spec.agents if a.label in ("random", "VI-snapshot", "RATS", "MCTS")),
    episodes=100,
    title="FrozenLake 4x4: p 0.7 -> 0.4 after the first decision epoch",
)
work = Path(tempfile.mkdtemp())
print(f"{len(spec.cells())} cells × {len(spec.agents)} agents × {spec.episodes} episodes")

# %%
# Run it
# ------
#
# Each trial (cell × agent × seed) is deterministic from its seed; ``LocalBackend(1)`` runs
# them one at a time in a worker process (so a trial that crashes its process is recorded as
# an error instead of ending the run), a larger pool or Ray give identical rows. Rows are
# written as they finish, so an interrupted run resumes without repeating a trial. A script
# that calls ``run_spec`` does so under ``if __name__ == "__main__":``, as for any process
# pool started with spawn.

summary = run_spec(spec, work / "results", LocalBackend(1))
print(summary)

# %%
# The tables
# ----------
#
# One column per setting and notification level, one row per agent: the mean episode return
# ± its standard error. For tabular environments the exact optimum (finite-horizon value
# iteration that knows the schedule) heads the columns and a second table gives each agent's
# regret to it. No agent can beat the optimum in expectation: over 100 episodes a regret
# slightly below zero is noise (compare the standard error), one far below it would be a bug.
# Told of the change (WN), VI-snapshot replans with the new θ and comes close to the optimum;
# not told (WON), it keeps planning for θ_0 and loses a good part of it.

store = ResultStore(work / "results")
record = store.spec_record()["spec"]
optimum = optimum_for(record)
print(table(store.rows(), spec.title, "markdown", optimum, record))

# %%
# The same numbers as a figure, with the optimum as a line (each bar is a mean over 100
# episodes; its error bar, one standard error, may reach above the line).

agents, columns, summaries = summarise(store.rows(), record)
fig, ax = plt.subplots(figsize=(7.5, 3.5))
width = 0.8 / len(agents)
for i, agent in enumerate(agents):
    xs = [j + (i - (len(agents) - 1) / 2) * width for j in range(len(columns))]
    means = [summaries[(agent, column)].mean for column in columns]
    errors = [summaries[(agent, column)].error for column in columns]
    ax.bar(xs, means, width, yerr=errors, capsize=3, label=agent)
for j, column in enumerate(columns):
    setting, notification = column.rsplit(" ", 1)
    best = optimum(setting, notification)
    ax.hlines(
        best,
        j - 0.45,
        j + 0.45,
        colors="black",
        linestyles="--",
        label="exact optimum" if j == 0 else None,
    )
ax.set_xticks(range(len(columns)), columns)
ax.set_ylabel("success rate (mean ± SE)")
ax.set_title(spec.title, fontsize="small")
ax.legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
fig.tight_layout()
