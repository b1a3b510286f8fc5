"""Trials: one agent, one cell, one seed — the unit the runner distributes.

A trial is deterministic from its seed: the environment (and with it nature, the monitor and
every planning model) is reset with the seed, the agent with a generator derived from it. Which
worker runs it, and in what order, changes nothing but the wall time.
"""

from __future__ import annotations

import json
import time
import traceback
from dataclasses import dataclass
from typing import Any

from ns_pz.agents.catalog import agent_entry
from ns_pz.agents.evaluation import run_episode
from ns_pz.experiments.spec import (
    LEVEL_LABELS,
    MAX_TRIALS,
    AgentSpec,
    Cell,
    ExperimentSpec,
    SpecError,
    slug,
)

#: Columns of a result row, in order.
COLUMNS = (
    "trial",
    "spec",
    "spec_hash",
    "size",
    "env",
    "setting",
    "notification",
    "agent",
    "hyperparameters",
    "seed",
    "return",
    "length",
    "wall_time",
    "change_times",
    "alarm_times",
    "status",
    "error",
)


@dataclass(frozen=True)
class Trial:
    """One episode to run: which cell, which agent, which seed."""

    key: str
    cell: Cell
    agent: AgentSpec
    seed: int


def expand(spec: ExperimentSpec) -> list[Trial]:
    """Every trial of ``spec``: cell × agent (at the levels it runs at) × seed, in table order.

    Raises:
        SpecError: More than :data:`~ns_pz.experiments.spec.MAX_TRIALS` trials (checked before
            any is built; :func:`~ns_pz.experiments.spec.load_spec` refuses such a spec too).
    """
    count = spec.trial_count()
    if count > MAX_TRIALS:
        raise SpecError(
            f"{spec.name} at size {spec.size!r} holds {count} trials (episodes={spec.episodes}); "
            f"a run takes at most {MAX_TRIALS}"
        )
    trials = []
    for cell in spec.cells():
        for agent in spec.agents:
            if cell.notification not in agent.notifications:
                continue
            for seed in spec.seeds():
                key = f"{cell.index:02d}-{slug(cell.setting)}-{cell.notification}-"
                key += f"{slug(agent.label)}-s{seed}"
                trials.append(Trial(key, cell, agent, seed))
    return trials


def new_row(spec: ExperimentSpec, trial: Trial) -> dict[str, Any]:
    """The row of ``trial`` before it runs: identity filled in, results empty."""
    return {
        "trial": trial.key,
        "spec": spec.name,
        "spec_hash": spec.digest(),
        "size": spec.size,
        "env": spec.env,
        "setting": trial.cell.setting,
        "notification": LEVEL_LABELS[trial.cell.notification],
        "agent": trial.agent.label,
        "hyperparameters": json.dumps(dict(trial.agent.hyper), sort_keys=True),
        "seed": trial.seed,
        "return": None,
        "length": None,
        "wall_time": None,
        "change_times": None,
        "alarm_times": None,
        "status": "ok",
        "error": "",
    }


def error_row(spec: ExperimentSpec, trial: Trial, message: str) -> dict[str, Any]:
    """The row of a trial that failed, or whose worker was lost before it could report."""
    return {**new_row(spec, trial), "status": "error", "error": message}


def run_trial(spec: ExperimentSpec, trial: Trial) -> dict[str, Any]:
    """Play the trial's episode and return its result row; an exception becomes an error row."""
    row = new_row(spec, trial)
    start = time.perf_counter()
    try:
        env = spec.make_env(trial.cell)
        agent = agent_entry(trial.agent.name).make(env, trial.agent.hyper)
        episode = run_episode(env, agent, trial.seed)
    except KeyboardInterrupt:
        raise
    except BaseException as error:  # noqa: BLE001 - SystemExit too: recorded, the run goes on
        message = "".join(traceback.format_exception_only(error)).strip()
        return {
            **error_row(spec, trial, message),
            "wall_time": time.perf_counter() - start,
            "traceback": traceback.format_exc(),  # kept in the trial file, not in the CSV
        }
    row["return"] = episode.episode_return
    row["length"] = episode.length
    row["wall_time"] = time.perf_counter() - start
    row["change_times"] = json.dumps(list(episode.change_times))
    row["alarm_times"] = json.dumps(list(episode.alarm_times))
    return row
