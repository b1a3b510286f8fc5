"""The paper's benchmark, and how to read its tables
=================================================

``ns-pz bench run paper`` runs the NS-Gym paper's experiments from specs: small TOML files
naming the environment, θ_0, the change, the notification levels and the agents. This page
runs a tiny spec of the same form in this process and reads its tables; the command line does
the same with ``ns-pz bench run my-spec.toml --out results`` and
``ns-pz bench table results``. The :doc:`/benchmark` page lists the commands and the shipped
specs.
"""

# %%
# A spec
# ------
#
# FrozenLake, where the chance that a move goes where it was meant to drops from 0.7 to 0.4
# after the first decision epoch (``first_step = 1``), with and without notification; three
# agents; 20 episodes per cell at the ``quick`` size.

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

from ns_pz.experiments import LocalBackend, ResultStore, load_spec, run_spec
from ns_pz.experiments.optimum import optimum_for
from ns_pz.experiments.report import summarise, table

SPEC = """
version = 1
name = "frozenlake-tiny"
title = "FrozenLake 4x4: p 0.7 -> 0.4 after the first decision epoch"
env = "ns_pz/FrozenLake-v0"
params = { slip = 0.7 }
notifications = ["detailed", "none"]

[change]
kind = "single"
param = "slip"
first_step = 1
to = [0.4]

[sizes.quick]
episodes = 20
horizon = 100

[[agents]]
name = "random"

[[agents]]
name = "snapshot_vi"
label = "VI-snapshot"

[[agents]]
name = "mcts"
label = "MCTS"
params = { c = 1.4142135623730951, gamma = 0.99, iterations = 100, depth = 50 }
"""

work = Path(tempfile.mkdtemp())
(work / "frozenlake-tiny.toml").write_text(SPEC)
spec = load_spec(work / "frozenlake-tiny.toml", size="quick")
print(f"{len(spec.cells())} cells × {len(spec.agents)} agents × {spec.episodes} episodes")

# %%
# Run it
# ------
#
# Each trial (cell × agent × seed) is deterministic from its seed; ``LocalBackend(1)`` runs
# them in this process, a larger pool or Ray give identical rows. Rows are written as they
# finish, so an interrupted run resumes without repeating a trial.

summary = run_spec(spec, work / "results", LocalBackend(1))
print(summary)

# %%
# The tables
# ----------
#
# One column per setting and notification level, one row per agent: the mean episode return
# ± its standard error. For tabular environments the exact optimum (finite-horizon value
# iteration that knows the schedule) heads the columns and a second table gives each agent's
# regret to it: no agent can beat the optimum in expectation, so a regret well below zero
# would be a bug.

store = ResultStore(work / "results")
record = store.spec_record()["spec"]
optimum = optimum_for(record)
print(table(store.rows(), spec.title, "markdown", optimum, record))

# %%
# The same numbers as a figure, with the optimum as a line.

agents, columns, summaries = summarise(store.rows(), record)
fig, ax = plt.subplots(figsize=(6.5, 3.5))
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
ax.legend(fontsize="small")
fig.tight_layout()
