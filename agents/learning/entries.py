"""The learning agents as the catalog lists them: builder, hyper-parameters, artefacts needed.

Builders load trained networks from the artefact cache (training them first if missing);
``artefacts(env, hyper)`` names those networks without loading or training anything, so the
runner can train each missing one once before the trials and spec checks can skip them.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from ns_pz.agents.learning.alphazero_agent import build_alphazero
from ns_pz.agents.learning.config import AlphaZeroArgs, DDQNArgs
from ns_pz.agents.learning.pamcts import build_pamcts, check_alpha
from ns_pz.agents.learning.q_agent import build_ddqn, build_ddqn_wn
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
    check_alpha(hyper.get("alpha", 0.5))
    return [ddqn_needed(env, DDQNArgs(**dict(hyper.get("ddqn") or {})))]


def _ddqn_wn_artefacts(env: NSGymEnv, hyper: Mapping[str, Any]) -> list[Needed]:
    for name in ("model_steps", "gradient_steps"):
        value = hyper.get(name, 0)
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise ValueError(f"{name}={value!r} must be an integer >= 0")
    return [ddqn_needed(env, DDQNArgs(**dict(hyper.get("ddqn") or {})))]


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
        "DDQN with notification: fine-tuned in the handed model (fixed step budget) on every "
        "notified change",
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
