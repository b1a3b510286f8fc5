"""The learning agents as the catalog lists them: builder, hyper-parameters, artefacts needed.

Builders load trained networks from the artefact cache (training them first if missing);
``artefacts(env, hyper)`` names those networks without loading or training anything, so the
runner can train each missing one once before the trials and spec checks can skip them.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from ns_pz.agents.learning.alphazero_agent import build_alphazero
from ns_pz.agents.learning.config import AlphaZeroArgs, DDQNArgs, nested_args
from ns_pz.agents.learning.pamcts import build_pamcts, check_pamcts
from ns_pz.agents.learning.q_agent import build_ddqn, build_ddqn_wn, check_fine_tuning
from ns_pz.agents.learning.trained import Needed, alphazero_needed, ddqn_needed

from ns_pz.views import NSGymEnv


@dataclass(frozen=True)
class LearningEntry:
    """What :mod:`ns_pz.agents.catalog` needs to register one learning agent."""

    name: str
    build: Callable[..., Any]
    description: str
    signature_of: Callable[..., Any]
    artefacts: Callable[[NSGymEnv, Mapping[str, Any]], list[Needed]]
    levels: frozenset[str] | None = None


def _ddqn_artefacts(env: NSGymEnv, hyper: Mapping[str, Any]) -> list[Needed]:
    return [ddqn_needed(env, DDQNArgs(**hyper))]


def _pamcts_artefacts(env: NSGymEnv, hyper: Mapping[str, Any]) -> list[Needed]:
    """The stale DDQN; acting hyper-parameters checked as the agent would (builder defaults)."""
    acting = {**_defaults(build_pamcts), **hyper}
    check_pamcts(*(acting[name] for name in _PAMCTS_ACTING))
    return [ddqn_needed(env, nested_args(DDQNArgs, hyper.get("ddqn"), "ddqn"))]


_PAMCTS_ACTING = ("alpha", "normalise", "iterations", "depth", "c", "gamma", "backend")


def _ddqn_wn_artefacts(env: NSGymEnv, hyper: Mapping[str, Any]) -> list[Needed]:
    """The DDQN it fine-tunes; the fine-tuning budget checked as the agent would."""
    acting = {**_defaults(build_ddqn_wn), **hyper}
    check_fine_tuning(*(acting[name] for name in _DDQN_WN_ACTING))
    return [ddqn_needed(env, nested_args(DDQNArgs, hyper.get("ddqn"), "ddqn"))]


_DDQN_WN_ACTING = (
    "model_steps",
    "gradient_steps",
    "epsilon",
    "time_budget",
    "checks",
    "evaluation_episodes",
    "validate",
    "interval",
)


def _defaults(build: Callable[..., Any]) -> dict[str, Any]:
    """A builder's keyword defaults."""
    return {
        name: parameter.default
        for name, parameter in inspect.signature(build).parameters.items()
        if parameter.default is not inspect.Parameter.empty
    }


def _alphazero_artefacts(env: NSGymEnv, hyper: Mapping[str, Any]) -> list[Needed]:
    return [alphazero_needed(env, AlphaZeroArgs(**hyper))]


ENTRIES = (
    LearningEntry(
        "ddqn",
        build_ddqn,
        "Double DQN trained on θ_0, greedy (no fine-tuning after a change)",
        DDQNArgs,
        _ddqn_artefacts,
    ),
    LearningEntry(
        "ddqn_wn",
        build_ddqn_wn,
        "DDQN with notification: fine-tuned in the handed model (a step or time budget) on every "
        "notified change, keeping the pre-change network unless a candidate scores better",
        build_ddqn_wn,
        _ddqn_wn_artefacts,
        levels=frozenset({"detailed"}),
    ),
    LearningEntry(
        "pamcts",
        build_pamcts,
        "PA-MCTS: UCT in the handed model mixed at the root with the stale DDQN's Q (weight α)",
        build_pamcts,
        _pamcts_artefacts,
    ),
    LearningEntry(
        "alphazero",
        build_alphazero,
        "AlphaZero: PUCT in the handed model guided by a policy/value net trained by self-play "
        "on θ_0",
        AlphaZeroArgs,
        _alphazero_artefacts,
    ),
)
