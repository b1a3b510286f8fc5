"""Hyper-parameters of the learners (numpy-free of torch: specs and the catalog check them).

Each learner's settings are one frozen ``Args`` dataclass with a docstring per field, as in
cleanrl. Fields left ``None`` take the paper's value for the environment family (the NS-Gym
paper's appendix tables) when the learner is bound to an environment (:meth:`for_family`).
Defaults are the quick size (seconds of training on two cores); the shipped specs' ``full``
size sets the paper-sized budgets.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from numbers import Integral, Real
from typing import Any

from ns_pz.agents.learning.puct import PUCTSettings

from ns_pz.checks import flag

#: The paper's DQN hidden widths per family (NS-Gym "layers" count ``Linear`` layers).
DDQN_HIDDEN = {
    "FrozenLakeFamily": (64,),
    "CliffWalkingFamily": (128,),
    "BridgeFamily": (64, 64),
    "CartPoleFamily": (64,),
}

#: AlphaZero's trunk widths and search constants per family (the NS-Gym paper's appendix):
#: ``(hidden, c, gamma, dirichlet_alpha, noise)``.
ALPHAZERO_PAPER = {
    "FrozenLakeFamily": ((64, 64, 64), 1.44, 0.999, 1.0, 0.0),
    "CliffWalkingFamily": ((64, 64, 64), 1.44, 0.999, 5.0, 0.75),
    "BridgeFamily": ((64, 64, 64), math.sqrt(2), 0.99, 1.0, 0.0),
    "CartPoleFamily": ((128, 128), math.sqrt(2), 1.0, 1.0, 0.0),
}

VALUE_TARGETS = ("return", "root_q")


def paper_entry(table: Mapping[str, Any], family: object) -> Any:
    """The row of ``table`` for ``family``'s class or its nearest listed base class.

    Raises:
        ValueError: No base class of the family is listed (the message lists those that are).
    """
    for cls in type(family).__mro__:
        if cls.__name__ in table:
            return table[cls.__name__]
    raise ValueError(
        f"no paper setting for {family!r}; set every hyper-parameter left None "
        f"(families with defaults: {sorted(table)})"
    )


def nested_args(cls: type[Any], values: Any, where: str) -> Any:
    """``cls(**values)`` for a table of settings nested in an agent's (PA-MCTS's ``ddqn``).

    ``None`` gives the defaults.

    Raises:
        TypeError: ``values`` is not a mapping.
        ValueError: A name ``cls`` does not have (the message lists the allowed ones), or a
            value ``cls`` refuses.
    """
    if values is None:
        return cls()
    if not isinstance(values, Mapping):
        raise TypeError(f"{where}={values!r} must be a table of {cls.__name__} settings")
    allowed = [f.name for f in dataclasses.fields(cls)]
    for key in values:
        if key not in allowed:
            close = difflib.get_close_matches(str(key), allowed, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise ValueError(f"{where} has no setting {key!r}{hint}; allowed: {allowed}")
    return cls(**values)


def _integer(name: str, value: Any, low: int) -> None:
    if isinstance(value, bool) or not isinstance(value, Integral):
        raise TypeError(f"{name}={value!r} must be an integer >= {low}")
    if value < low:
        raise ValueError(f"{name}={value!r} must be >= {low}")


def _real(name: str, value: Any, low: float, high: float = math.inf) -> None:
    if isinstance(value, bool) or not isinstance(value, Real):
        raise TypeError(f"{name}={value!r} must be a real number in [{low}, {high}]")
    if not low <= float(value) <= high or math.isnan(float(value)):
        raise ValueError(f"{name}={value!r} must lie in [{low}, {high}]")


def _widths(name: str, value: Any) -> tuple[int, ...] | None:
    if value is None:
        return None
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence) or not value:
        raise TypeError(f"{name}={value!r} must be a non-empty list of layer widths")
    for width in value:
        _integer(name, width, 1)
    return tuple(int(w) for w in value)


@dataclass(frozen=True)
class DDQNArgs:
    """Double-DQN training on θ_0 (NS-Gym's defaults unless noted).

    Raises:
        TypeError, ValueError: A field of the wrong type or out of range (named in the message).
    """

    hidden: tuple[int, ...] | None = None
    """Hidden-layer widths; None: the paper's for the family (FrozenLake/CartPole (64,),
    CliffWalking (128,), Bridge (64, 64))."""
    total_steps: int = 20_000
    """Environment steps of training (quick size; the full specs set the paper's budget)."""
    learning_rate: float = 1e-3
    """Adam step size."""
    weight_decay: float = 1e-5
    """Adam weight decay."""
    buffer_size: int = 100_000
    """Replay capacity in transitions."""
    batch_size: int = 64
    """Transitions per gradient step."""
    gamma: float = 0.99
    """Discount of the Q-learning target."""
    train_every: int = 4
    """Environment steps between gradient steps."""
    learning_starts: int = 500
    """Environment steps before the first gradient step."""
    tau: float = 0.005
    """Soft target-network update rate per gradient step (NS-Gym: 1e-3, slow for short runs)."""
    epsilon_start: float = 1.0
    """Initial ε of ε-greedy exploration."""
    epsilon_end: float = 0.01
    """Final ε."""
    exploration_fraction: float = 0.5
    """Fraction of ``total_steps`` over which ε decays linearly to ``epsilon_end``."""
    max_episode_steps: int = 200
    """Truncation of training episodes (NS-Gym: 200)."""
    seed: int = 0
    """Training seed (env episodes, exploration, replay sampling, initialisation)."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "hidden", _widths("hidden", self.hidden))
        for name in (
            "total_steps",
            "buffer_size",
            "batch_size",
            "train_every",
            "max_episode_steps",
        ):
            _integer(name, getattr(self, name), 1)
        _integer("learning_starts", self.learning_starts, 0)
        _integer("seed", self.seed, 0)
        _real("learning_rate", self.learning_rate, 0.0)
        _real("weight_decay", self.weight_decay, 0.0)
        for name in ("gamma", "tau", "epsilon_start", "epsilon_end", "exploration_fraction"):
            _real(name, getattr(self, name), 0.0, 1.0)

    def for_family(self, family: object) -> DDQNArgs:
        """These settings with the paper's widths filled in for ``family`` where None."""
        if self.hidden is not None:
            return self
        return dataclasses.replace(self, hidden=paper_entry(DDQN_HIDDEN, family))


@dataclass(frozen=True)
class AlphaZeroArgs:
    """AlphaZero self-play training on θ_0.

    Raises:
        TypeError, ValueError: A field of the wrong type or out of range (named in the message).
    """

    hidden: tuple[int, ...] | None = None
    """Trunk widths; None: the paper's (grids (64, 64, 64), CartPole (128, 128))."""
    episodes: int = 40
    """Self-play episodes (quick size)."""
    iterations: int = 25
    """PUCT simulations per self-play move."""
    depth: int = 100
    """Most tree levels a simulation descends (NS-Gym's scripts: 100)."""
    c: float | None = None
    """PUCT exploration constant; None: the paper's (1.44 grids, √2 Bridge and CartPole)."""
    gamma: float | None = None
    """Discount of the search; None: the paper's (0.999 FrozenLake/CliffWalking, 0.99 Bridge,
    1 CartPole)."""
    dirichlet_alpha: float | None = None
    """Root-noise concentration; None: the paper's (5 CliffWalking, else 1)."""
    noise: float | None = None
    """Root-noise weight ε; None: the paper's (0.75 CliffWalking, else 0)."""
    normalise_q: bool = True
    """Min-max scale Q in PUCT's selection by the values seen in the tree (MuZero), so ``c``
    works at any reward scale; False: raw Q as NS-Gym."""
    temperature_start: float = 2.0
    """Visit-count temperature of the first episode."""
    temperature_decay: float = 0.95
    """Factor applied to the temperature after every episode."""
    temperature_min: float = 0.8
    """Floor of the temperature."""
    learning_rate: float = 1e-3
    """Adam step size."""
    weight_decay: float = 1e-4
    """Adam weight decay (L2 regularisation of the loss)."""
    epochs: int = 10
    """Full-batch gradient steps after every episode."""
    window: int = 2000
    """Most recent self-play samples trained on (NS-Gym: the last episode only)."""
    value_target: str = "return"
    """``"return"``: the discounted return from the move on (AlphaZero's z); ``"root_q"``: the
    visit-weighted root Q of the move's search (NS-Gym)."""
    evaluate_every: int = 10
    """Episodes between evaluations of the network (also after the last); the best evaluated
    network is kept (the paper: the best 100-episode moving average of self-play returns)."""
    evaluation_episodes: int = 4
    """Held-out episodes per evaluation, played as the agent acts (PUCT, most visited action)."""
    max_episode_steps: int = 100
    """Truncation of self-play episodes."""
    exploring_starts: float = 0.0
    """Fraction of self-play episodes that start from a state drawn uniformly from those an
    episode can be in, rather than from the environment's start (tabular families only)."""
    seed: int = 0
    """Training seed (episodes, search, sampling of moves, initialisation)."""
    search_iterations: int | None = None
    """PUCT simulations per decision when acting; None: ``iterations``. Not part of training,
    so not of the artefact's key."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "hidden", _widths("hidden", self.hidden))
        if self.value_target not in VALUE_TARGETS:
            raise ValueError(
                f"value_target={self.value_target!r} is not allowed; allowed: {list(VALUE_TARGETS)}"
            )
        if self.search_iterations is not None:
            _integer("search_iterations", self.search_iterations, 1)
        for name in (
            "episodes",
            "iterations",
            "epochs",
            "window",
            "max_episode_steps",
            "evaluate_every",
            "evaluation_episodes",
        ):
            _integer(name, getattr(self, name), 1)
        _integer("depth", self.depth, 0)
        _integer("seed", self.seed, 0)
        for name in ("c", "dirichlet_alpha"):
            if getattr(self, name) is not None:
                _real(name, getattr(self, name), 0.0)
        _real("exploring_starts", self.exploring_starts, 0.0, 1.0)
        for name in ("gamma", "noise"):
            if getattr(self, name) is not None:
                _real(name, getattr(self, name), 0.0, 1.0)
        _real("temperature_start", self.temperature_start, 1e-3)
        _real("temperature_min", self.temperature_min, 1e-3)
        _real("temperature_decay", self.temperature_decay, 0.0, 1.0)
        _real("learning_rate", self.learning_rate, 0.0)
        _real("weight_decay", self.weight_decay, 0.0)
        flag("normalise_q", self.normalise_q)  # "false" would count as True

    def puct_settings(self) -> PUCTSettings:
        """The search settings of self-play (call on the result of :meth:`for_family`).

        Raises:
            ValueError: ``c`` or ``gamma`` is still None.
        """
        if self.c is None or self.gamma is None:
            raise ValueError(f"c={self.c!r} and gamma={self.gamma!r} must be set (for_family)")
        return PUCTSettings(
            iterations=self.iterations,
            depth=self.depth,
            c=self.c,
            gamma=self.gamma,
            dirichlet_alpha=self.dirichlet_alpha if self.dirichlet_alpha is not None else 1.0,
            noise=self.noise or 0.0,
            normalise_q=self.normalise_q,
        )

    def for_family(self, family: object) -> AlphaZeroArgs:
        """These settings with the paper's values filled in for ``family`` where None.

        Raises:
            ValueError: ``exploring_starts`` above 0 for a family without an outcome table.
        """
        hidden, c, gamma, alpha, noise = paper_entry(ALPHAZERO_PAPER, family)
        if self.exploring_starts > 0.0 and not hasattr(family, "outcomes"):
            raise ValueError(
                f"exploring_starts={self.exploring_starts!r} needs a tabular family (one with an "
                f"outcome table); {type(family).__name__} has none: use 0"
            )
        return dataclasses.replace(
            self,
            hidden=self.hidden if self.hidden is not None else hidden,
            c=self.c if self.c is not None else c,
            gamma=self.gamma if self.gamma is not None else gamma,
            dirichlet_alpha=self.dirichlet_alpha if self.dirichlet_alpha is not None else alpha,
            noise=self.noise if self.noise is not None else noise,
        )
