"""The agents an experiment can name: how to build each, its hyper-parameters, what it needs.

An entry's builder is ``build(env, *, hyper=default, ...)``: it receives the Gymnasium view the
agent will act in (for its action space and family) and the hyper-parameters as keyword
arguments. The keyword-only parameters of the builder *are* the agent's hyper-parameters: their
names are what a spec may set and their defaults are what it gets otherwise.
"""

from __future__ import annotations

import difflib
import importlib
import inspect
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from ns_pz.agents.base import Agent
from ns_pz.agents.baselines import RandomAgent
from ns_pz.agents.learning import entries as learning
from ns_pz.agents.planners import RandomShooting, SnapshotValueIteration
from ns_pz.agents.search.ada_mcts import ADAMCTS
from ns_pz.agents.search.mcts import MCTS
from ns_pz.agents.search.rats import check_config as check_rats_config
from ns_pz.agents.search.rats import rats_agent

from ns_pz.monitor.notification import NotificationLevel
from ns_pz.views import NSGymEnv

ALL_LEVELS = frozenset(level.value for level in NotificationLevel)


@dataclass(frozen=True)
class AgentEntry:
    """One agent of the catalog.

    Attributes:
        name: The name specs use.
        build: ``build(env, **hyper_parameters) -> Agent``.
        description: One line for listings.
        tabular_only: Needs the explicit outcome table (``model.outcomes``) of a tabular family.
        levels: Notification levels the agent is meant to run at (ADA-MCTS: ``none`` only).
        signature_of: The function whose keyword-only parameters are the hyper-parameters, when
            ``build`` forwards ``**hyper_parameters`` to it (default: ``build`` itself).
        artefacts: ``artefacts(env, hyper) -> [Needed, ...]``, the trained networks the agent
            loads (:mod:`ns_pz.agents.learning.trained`), for agents that need any: the runner
            trains what is missing once before the trials, and spec checks do not act with it.
    """

    name: str
    build: Callable[..., Agent]
    description: str
    tabular_only: bool = False
    levels: frozenset[str] = ALL_LEVELS
    signature_of: Callable[..., Any] | None = None
    artefacts: Callable[[NSGymEnv, Mapping[str, Any]], list[Any]] | None = None

    def defaults(self) -> dict[str, Any]:
        """Hyper-parameter names and their default values."""
        source = self.signature_of or self.build
        kinds = (inspect.Parameter.KEYWORD_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)
        return {
            p.name: p.default
            for p in inspect.signature(source).parameters.values()
            if p.kind in kinds and p.default is not inspect.Parameter.empty
        }

    def check_names(self, hyper: Mapping[str, Any]) -> None:
        """Refuse hyper-parameters the agent does not have.

        Raises:
            ValueError: An unknown name (the message lists the allowed ones).
        """
        allowed = self.defaults()
        for key in hyper:
            if key not in allowed:
                close = difflib.get_close_matches(key, allowed, n=1)
                hint = f" (did you mean {close[0]!r}?)" if close else ""
                raise ValueError(
                    f"agent {self.name!r} has no hyper-parameter {key!r}{hint}; "
                    f"allowed: {sorted(allowed) or 'none'}"
                )

    def make(self, env: NSGymEnv, hyper: Mapping[str, Any]) -> Agent:
        """Build the agent for ``env`` (hyper-parameters not given take their defaults)."""
        self.check_names(hyper)
        return self.build(env, **hyper)


def is_tabular(family: object) -> bool:
    """Whether a family (instance or class) hands out explicit outcome tables."""
    return callable(getattr(family, "outcomes", None))


def _random(env: NSGymEnv) -> Agent:
    return RandomAgent(env.family.action_space)


def _value_iteration(env: NSGymEnv, *, gamma: float = 0.99) -> Agent:
    return SnapshotValueIteration(gamma=gamma)


def _snapshot_vi(env: NSGymEnv) -> Agent:
    horizon = env.max_episode_steps
    if horizon is None:
        raise ValueError(f"{env!r} has no time limit; snapshot_vi needs a finite horizon")
    return SnapshotValueIteration(gamma=1.0, horizon=horizon)


def _forwarding(factory: Callable[..., Agent]) -> Callable[..., Agent]:
    """A builder that ignores the env and hands the hyper-parameters to ``factory``."""

    def build(env: NSGymEnv, **hyper_parameters: Any) -> Agent:
        return factory(**hyper_parameters)

    return build


def _random_shooting(
    env: NSGymEnv, *, num_rollouts: int = 8, depth: int = 30, gamma: float = 0.99
) -> Agent:
    return RandomShooting(num_rollouts=num_rollouts, depth=depth, gamma=gamma)


_CATALOG: dict[str, AgentEntry] = {}


def register_agent(entry: AgentEntry) -> None:
    """Add an agent to the catalog (a name may be registered once)."""
    if entry.name in _CATALOG:
        raise ValueError(f"an agent named {entry.name!r} is already in the catalog")
    _CATALOG[entry.name] = entry


def agent_entry(name: str) -> AgentEntry:
    """The catalog entry called ``name``, or a user's agent named ``"module:builder"``.

    A ``"module:builder"`` name imports ``builder`` from ``module``: either an
    :class:`AgentEntry` or a builder function ``build(env, *, hyper=default, ...) -> Agent``.
    That is how a spec benchmarks an agent that is not part of ns_pz (the module must be
    importable by every worker).

    Raises:
        ValueError: No such agent (the message suggests close names and lists all), or a
            ``module:builder`` that cannot be imported.
    """
    if ":" in name:
        return _imported_entry(name)
    try:
        return _CATALOG[name]
    except KeyError:
        close = difflib.get_close_matches(name, _CATALOG, n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise ValueError(
            f"no agent {name!r} in the catalog{hint}; available: {', '.join(sorted(_CATALOG))}"
        ) from None


def _imported_entry(name: str) -> AgentEntry:
    module_name, _, attribute = name.partition(":")
    try:
        found = getattr(importlib.import_module(module_name), attribute)
    except (ImportError, AttributeError) as error:
        raise ValueError(f"agent {name!r} cannot be imported: {error}") from None
    if isinstance(found, AgentEntry):
        return found
    if not callable(found):
        raise ValueError(f"agent {name!r} is {found!r}, not an AgentEntry or a builder function")
    doc = (inspect.getdoc(found) or name).splitlines()[0]
    return AgentEntry(name, found, doc)


def agent_names() -> tuple[str, ...]:
    """Names of every catalogued agent, sorted."""
    return tuple(sorted(_CATALOG))


register_agent(AgentEntry("random", _random, "uniformly random actions"))
register_agent(
    AgentEntry(
        "value_iteration",
        _value_iteration,
        "greedy on discounted value iteration of the handed snapshot (perfect snapshot planner)",
        tabular_only=True,
    )
)
register_agent(
    AgentEntry(
        "snapshot_vi",
        _snapshot_vi,
        "exact finite-horizon optimum of the handed snapshot, replanned each step: the perfect "
        "planner (snapshot replanning with notification, the stale θ_0 policy without)",
        tabular_only=True,
    )
)
register_agent(
    AgentEntry(
        "mcts",
        _forwarding(MCTS),
        "UCT with random rollouts in the handed model (compiled with numba when installed)",
        signature_of=MCTS,
    )
)
register_agent(
    AgentEntry(
        "ada_mcts",
        _forwarding(ADAMCTS),
        "ADA-MCTS: learns the changed kernel online (Dirichlet), pessimistic where unsure",
        tabular_only=True,
        levels=frozenset({"none"}),
        signature_of=ADAMCTS,
    )
)
register_agent(
    AgentEntry(
        "rats",
        _forwarding(rats_agent),
        "risk-averse tree search against a worst-case nature (Lecarpentier & Rachelson 2019)",
        tabular_only=True,
        signature_of=check_rats_config,
    )
)
register_agent(
    AgentEntry(
        "random_shooting",
        _random_shooting,
        "best first action by random rollouts in the handed model",
    )
)
for _entry in learning.ENTRIES:
    register_agent(
        AgentEntry(
            _entry.name,
            _entry.build,
            _entry.description,
            signature_of=_entry.signature_of,
            artefacts=_entry.artefacts,
            levels=_entry.levels or ALL_LEVELS,
        )
    )
