"""ADA-MCTS, "Act as you learn" (Luo et al., AAMAS 2024), with a Dirichlet learner (§5).

After an unknown change the agent learns the new dynamics from its own transitions and is
pessimistic only where that learned model is not yet trustworthy. Two models:

* M0, the base model: the kernel T0 of the tabular planning model handed over at each step
  (WON: θ_0), seen as a Dirichlet of concentration ``base_concentration`` on T0;
* M1, the learned model: a :class:`~ns_pz.agents.search.dirichlet.DirichletLearner` over the
  same structural support, updated after every real step (:meth:`ADAMCTS.observe`) and cleared
  at every episode start.

At each decision it builds one sampling kernel over the table's outcome slots and runs UCT on
it (tree: decision nodes and chance nodes keyed by the sampled next state; action: most visited):

* pessimistic base kernel P̃0(s, a): T0 if no outcome with T0 > 0 has a negative value;
  otherwise the Dirac on the worst outcome (lowest value, first on ties) when the real current
  state is not in danger, or, when it is, ``(1 - λ) T0 + λ Dirac`` with
  ``λ = min(1, radius / W1(T0, Dirac))``, W1 under the Manhattan metric between the cells the
  outcomes' moves enter (the table's ``landing_cells``: on CliffWalking the cliff cell, not the
  start it teleports the agent to, so a cliff next to the agent is near wherever the start is).
  The state is in danger when at least ``danger_threshold`` (action, landing cell) pairs of its
  support have a negative value. An outcome's value is its reward (``failure_reward``, if set,
  replaces the reward of terminal outcomes with reward <= 0, e.g. -1 for FrozenLake's holes as
  in the original code);
* phase 1, before ``warmup`` real transitions or where ``EU_1(s, a) > EU_0(s, a) + delta``:
  sample from P̃0;
* phase 2 where the new world looks noisier (``AU_0 < AU_1``): sample from T1 (the posterior
  mean) with probability ``exp(-kappa (AU_1 - AU_0))``, else from P̃0; otherwise from T1.

AU is the mean entropy over the (s, a) pairs the agent has visited (the original averages its
BNN's noise over all pairs; unvisited pairs of a Dirichlet carry only the prior). The
per-step choice between kernels is folded into one mixture kernel per (s, a), which samples
the same distribution with one draw.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from numbers import Integral, Real
from typing import Any

import numpy as np
from ns_pz.agents.base import Agent
from ns_pz.agents.search.compiled import BACKENDS
from ns_pz.agents.search.dirichlet import (
    POOLINGS,
    DirichletLearner,
    aggregate,
    entropy,
    epistemic,
)
from ns_pz.agents.search.mcts import check_uct_params, result_of, uct_tree
from ns_pz.agents.search.table_model import OutcomeTableModel
from ns_pz.agents.search.types import SearchResult

from ns_pz.planning import TabularOutcomes

Distance = Callable[[np.ndarray, np.ndarray], np.ndarray]


def manhattan(ncol: int) -> Distance:
    """Manhattan distance between grid cells ``row * ncol + col`` (elementwise on arrays)."""

    def distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        a_row, a_col = np.divmod(a, ncol)
        b_row, b_col = np.divmod(b, ncol)
        return np.abs(a_row - b_row) + np.abs(a_col - b_col)

    return distance


def pessimistic_kernel(
    probs: np.ndarray,
    cells: np.ndarray,
    values: np.ndarray,
    danger: bool,
    radius: float,
    distance: Distance | None,
) -> np.ndarray:
    """P̃0 for every (s, a): ``[S, A, K]`` (see the module docstring).

    Args:
        probs: ``[S, A, K]`` the base kernel T0.
        cells: ``[S, A, K]`` the cell each outcome lands on, between which ``distance``
            measures (:attr:`TabularOutcomes.cells`).
        values: ``[S, A, K]`` each outcome's value.
        danger: Whether the real current state is in danger (mixture instead of Dirac).
        radius: The W1 budget of the mixture.
        distance: Ground metric between cells (needed when ``danger``).

    Raises:
        ValueError: ``danger`` needs a ground metric and ``distance`` is None.
    """
    num_outcomes = probs.shape[2]
    worst = values.argmin(axis=2)
    dirac = (np.arange(num_outcomes) == worst[..., None]).astype(np.float64)
    if danger:
        if distance is None:
            raise ValueError(
                "ADA-MCTS needs a ground metric for the W1 pessimism: the model's family has no "
                "`ncol` (grid width); pass distance=f(cells_a, cells_b)"
            )
        worst_cell = np.take_along_axis(cells, worst[..., None], axis=2)
        w1 = (probs * distance(cells, worst_cell)).sum(axis=2)
        ratio = np.divide(radius, w1, out=np.ones_like(w1), where=w1 > 0)
        lam = np.minimum(1.0, ratio)[..., None]
        pessimistic = (1.0 - lam) * probs + lam * dirac
    else:
        pessimistic = dirac
    threatened = np.any((probs > 0) & (values < 0), axis=2)
    return np.where(threatened[..., None], pessimistic, probs)


class ADAMCTS(Agent):
    """ADA-MCTS with a Dirichlet transition learner; tabular planning models only.

    Args:
        iterations: UCT simulations per decision (paper: FrozenLake 100, Bridge/CliffWalking
            3000).
        depth: Rollout cap (the original rolls out to a terminal; 100 by default here).
        c: UCB exploration constant (sqrt(2)).
        gamma: Discount (paper: 0.99).
        delta: δ, how much more epistemic uncertainty M1 may have than M0 in phase 2 (0.02).
        kappa: κ, how sharply a noisier new world turns back to P̃0 (1e4).
        radius: c of the paper, the W1 budget of the pessimistic mixture (1).
        warmup: Real transitions before M1 is used at all (50).
        danger_threshold: Negative-valued (action, next state) pairs at the current state that
            make it "in danger" (4).
        base_concentration: Concentration of M0's Dirichlet on T0 (1000): EU_0 = Σ Var.
        prior: Prior concentration of M1 (per atom, or per slot when shared).
        pooling: ``"state_action"`` (one Dirichlet per (s, a)) or ``"shared"`` (one over the
            slip outcomes, for families with one global slip vector).
        failure_reward: If set, the value of terminal outcomes with reward <= 0 (e.g. -1).
        distance: Ground metric between cells (default: Manhattan on the family's grid).
        backend: ``"auto"``, ``"compiled"`` or ``"python"`` (as :func:`~.mcts.uct`).

    Raises:
        TypeError, ValueError: A hyper-parameter is out of range.
    """

    def __init__(
        self,
        iterations: int = 100,
        depth: int = 100,
        c: float = math.sqrt(2),
        gamma: float = 0.99,
        delta: float = 0.02,
        kappa: float = 1e4,
        radius: float = 1.0,
        warmup: int = 50,
        danger_threshold: int = 4,
        base_concentration: float = 1000.0,
        prior: float = 1.0,
        pooling: str = "state_action",
        failure_reward: float | None = None,
        distance: Distance | None = None,
        backend: str = "auto",
    ) -> None:
        check_uct_params(iterations, depth, c, gamma)
        for name, value, low in (
            ("delta", delta, 0.0),
            ("kappa", kappa, 0.0),
            ("radius", radius, 0.0),
        ):
            if isinstance(value, bool) or not isinstance(value, Real) or not math.isfinite(value):
                raise TypeError(f"{name}={value!r} must be a finite number")
            if value < low:
                raise ValueError(f"{name}={value!r} must be >= {low}")
        for name, value in (("warmup", warmup), ("danger_threshold", danger_threshold)):
            if isinstance(value, bool) or not isinstance(value, Integral):  # 2.5 was truncated
                raise TypeError(f"{name}={value!r} must be an int >= 0")
            if value < 0:
                raise ValueError(f"{name}={value!r} must be >= 0")
        if (
            isinstance(base_concentration, bool)
            or not isinstance(base_concentration, Real)
            or not 0 < base_concentration < math.inf
        ):
            raise ValueError(f"base_concentration={base_concentration!r} must be finite and > 0")
        if isinstance(prior, bool) or not (isinstance(prior, Real) and 0 < prior < math.inf):
            raise ValueError(f"prior={prior!r} must be finite and > 0")
        if backend not in BACKENDS:
            raise ValueError(f"backend={backend!r} is not a backend; allowed: {list(BACKENDS)}")
        if pooling not in POOLINGS:
            raise ValueError(f"pooling={pooling!r} is not a pooling; allowed: {list(POOLINGS)}")
        if failure_reward is not None and (
            isinstance(failure_reward, bool)
            or not isinstance(failure_reward, Real)
            or not math.isfinite(failure_reward)
        ):
            raise TypeError(f"failure_reward={failure_reward!r} must be a finite number or None")
        if distance is not None and not callable(distance):
            raise TypeError(f"distance={distance!r} must be callable or None")
        self.iterations: int = int(iterations)
        self.depth: int = int(depth)
        self.c: float = float(c)
        self.gamma: float = float(gamma)
        self.delta: float = float(delta)
        self.kappa: float = float(kappa)
        self.radius: float = float(radius)
        self.warmup: int = int(warmup)
        self.danger_threshold: int = int(danger_threshold)
        self.base_concentration: float = float(base_concentration)
        self.prior: float = float(prior)
        self.pooling: str = pooling
        self.failure_reward: float | None = (
            None if failure_reward is None else float(failure_reward)
        )
        self.distance: Distance | None = distance
        self.backend: str = backend
        self.learner: DirichletLearner | None = None
        self.transitions: int = 0
        self.last_result: SearchResult | None = None
        self.last_kernel: np.ndarray | None = None
        self._structure: tuple[np.ndarray, ...] | None = None

    @property
    def needs_model(self) -> bool:
        """It plans on the handed (θ_0) model at every step."""
        return True

    @property
    def learning_started(self) -> bool:
        """Whether M1 has seen ``warmup`` real transitions this episode."""
        return self.transitions >= self.warmup

    def reset(self, rng: np.random.Generator) -> None:
        """Start an episode: forget M1 and the transitions seen."""
        super().reset(rng)
        self.learner = None
        self.transitions = 0
        self.last_result = None
        self.last_kernel = None

    def act(self, observation: Any, model: Any | None = None) -> int:
        """Plan with the current sampling kernel from the model's state; most visited action.

        Raises:
            ValueError: ``model`` is None or not tabular (no ``outcomes`` table).
        """
        table = getattr(model, "outcomes", None)
        if model is None or not isinstance(table, TabularOutcomes):
            raise ValueError(
                f"ADA-MCTS needs a tabular planning model (with an `outcomes` table), got "
                f"{type(model).__name__}; it runs on FrozenLake, CliffWalking, Bridge and other "
                "tabular families"
            )
        learner = self._learner_for(table)
        state = int(model.get_state())
        kernel = self.sampling_kernel(table, learner, state, self._distance_for(model))
        values = self._values(table)
        planning = OutcomeTableModel(
            TabularOutcomes(kernel, table.next_states, values, table.terminals), state, model.rng
        )
        tree = uct_tree(
            planning,
            state,
            self.rng,
            iterations=self.iterations,
            depth=self.depth,
            c=self.c,
            gamma=self.gamma,
            backend=self.backend,
        )
        self.last_kernel = kernel
        self.last_result = result_of(tree, "visits", self.rng, self.iterations)
        return int(self.last_result.action)

    def observe(
        self,
        observation: Any,
        action: Any,
        reward: float,
        next_observation: Any,
        terminated: bool,
    ) -> None:
        """Count the real transition in M1."""
        if self.learner is None:
            return  # nothing planned yet this episode: the structure is unknown
        if self.learner.update(
            _state_of(observation),
            int(action),
            _state_of(next_observation),
            float(reward),
            bool(terminated),
        ):
            self.transitions += 1

    # -- the sampling kernel -------------------------------------------------------------------
    def sampling_kernel(
        self,
        table: TabularOutcomes,
        learner: DirichletLearner,
        state: int,
        distance: Distance | None,
    ) -> np.ndarray:
        """``[S, A, K]`` the kernel UCT samples from this decision (see the module docstring)."""
        base = np.asarray(table.probs, dtype=np.float64)
        values = self._values(table)
        pessimistic = pessimistic_kernel(
            base,
            table.cells,
            values,
            self.in_danger(values, table, state),
            self.radius,
            distance,
        )
        if not self.learning_started:
            return pessimistic
        atoms = learner.atoms
        base_atoms = aggregate(base, atoms)
        eu_0 = epistemic(self.base_concentration * base_atoms)  # M0: Dirichlet(c · T0)
        eu_1 = learner.epistemic()
        learned = learner.mean()
        visited = learner.visits > 0
        au_0 = float(entropy(base_atoms)[visited].mean()) if visited.any() else 0.0
        au_1 = float(learner.aleatoric()[visited].mean()) if visited.any() else 0.0
        if au_0 < au_1:
            trust = math.exp(-self.kappa * (au_1 - au_0))
            phase_two = trust * learned + (1.0 - trust) * pessimistic
        else:
            phase_two = learned
        unsure = (eu_0 + self.delta < eu_1)[..., None]
        return np.where(unsure, pessimistic, phase_two)

    def in_danger(self, values: np.ndarray, table: TabularOutcomes, state: int) -> bool:
        """Whether ``state`` has ``danger_threshold`` negative (action, landing cell) pairs."""
        negative = values[state] < 0
        pairs = {
            (a, int(table.cells[state, a, k])) for a, k in zip(*np.nonzero(negative), strict=True)
        }
        return len(pairs) >= self.danger_threshold

    def _values(self, table: TabularOutcomes) -> np.ndarray:
        rewards = np.asarray(table.rewards, dtype=np.float64)
        if self.failure_reward is None:
            return rewards
        failed = np.asarray(table.terminals) & (rewards <= 0)
        return np.where(failed, float(self.failure_reward), rewards)

    def _learner_for(self, table: TabularOutcomes) -> DirichletLearner:
        structure = (table.next_states, table.rewards, table.terminals)
        same = self._structure is not None and all(
            np.array_equal(a, b) for a, b in zip(structure, self._structure, strict=True)
        )
        if self.learner is None or not same:
            self.learner = DirichletLearner(*structure, pooling=self.pooling, prior=self.prior)
            self._structure = structure
            self.transitions = 0
        return self.learner

    def _distance_for(self, model: Any) -> Distance | None:
        if self.distance is not None:
            return self.distance
        ncol = getattr(getattr(model, "family", None), "ncol", None)
        return manhattan(int(ncol)) if ncol is not None else None

    def __repr__(self) -> str:
        return (
            f"ADAMCTS(iterations={self.iterations}, depth={self.depth}, pooling={self.pooling!r}, "
            f"warmup={self.warmup})"
        )


def _state_of(observation: Any) -> int:
    if isinstance(observation, Mapping):
        observation = observation["state"]
    return int(observation)
