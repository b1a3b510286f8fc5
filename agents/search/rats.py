"""RATS, Risk-Averse Tree Search (Lecarpentier & Rachelson, NeurIPS 2019), on tabular models.

At each decision RATS plans a depth-``D`` max-min game in the stationary snapshot the agent is
handed: the agent picks actions, nature picks the outcome distribution of every chance node
within a Wasserstein-1 ball around the snapshot's, of radius ``k · L_p · τ`` at look-ahead
depth ``k`` (0 at the root: the first transition is evaluated under the snapshot)::

    value(decision n at depth d) = heuristic (0)        if d == D
                                   terminal value       if n ends the episode
                                   max_a value(chance(n, a))
    value(chance (s, a) at depth k) = γ · Σ_i w_i v_i + (R̄(s, a) - L_r · τ · k),
        v_i = value of child i (one per outcome of the table, probability-0 ones included),
        w   = worst_case(w0 = snapshot probabilities, v, ground distances, k · L_p · τ),
        R̄   = Σ_i w0_i r_i, the snapshot's expected reward.

Behaviours kept from the released implementations (Lecarpentier's and NS-Gym's), documented
here because they differ from the paper's pseudocode:

* a node at the depth limit is worth the heuristic (0) even when it is terminal: the depth
  test comes first;
* a terminal child is worth its reward, which the parent's ``R̄`` already counts (the reward of
  a terminal step is counted twice, once weighted by ``w0``, once by nature's ``w``);
* ``terminal_value="fl_hack"`` reproduces the paper-era NS-Gym FrozenLake edit: a terminal
  outcome paying 0 (a hole) counts as ``-1`` in ``R̄``, and terminal children are worth ``+1``
  if their reward is positive, else ``-1``;
* ties between root actions go to the lowest action index (exact comparison, as ``max``).

Nature's rule is ``worst_case`` (:mod:`ns_pz.agents.search.worst_case`): ``"dirac_support"``
(what the NS-Gym paper ran: the worst child, whatever the budget), ``"wasserstein_direct"``
(Lecarpentier's released "direct method") or ``"wasserstein_lp"`` (the exact minimum over the
ball). The ground metric is the Manhattan distance between grid cells (the family's ``nrow`` x
``ncol`` layout, state ``row * ncol + col``) unless ``distances`` is given.

Decision values depend only on (state, depth), so with ``memoise=True`` each is computed once:
the tree becomes a DAG with at most ``|S| · D`` decision nodes and the same values, bit for bit.
"""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np
from ns_pz.agents.search.types import SearchAgent, SearchResult
from ns_pz.agents.search.worst_case import WORST_CASES

TERMINAL_VALUES = ("env", "fl_hack")


def rats(
    model: Any,
    root_state: int,
    rng: np.random.Generator,
    *,
    depth: int = 3,
    gamma: float = 0.99,
    lipschitz_p: float = 1.0,
    lipschitz_r: float = 0.0,
    tau: float = 1.0,
    worst_case: str = "dirac_support",
    terminal_value: str = "env",
    memoise: bool = True,
    distances: np.ndarray | None = None,
) -> SearchResult:
    """One RATS decision from ``root_state`` in the tabular snapshot ``model``.

    Args:
        model: A tabular planning model (``model.outcomes``, ``model.family``); not stepped.
        root_state: The state to decide in.
        rng: Unused (RATS is deterministic); part of the search contract.
        depth: Look-ahead ``D >= 1`` in decisions (paper: 3).
        gamma: Discount in ``[0, 1]`` (paper: 0.99).
        lipschitz_p: ``L_p``, the transition kernel's Lipschitz constant in time (W1 per unit
            time).
        lipschitz_r: ``L_r``, the reward's Lipschitz constant in time.
        tau: ``τ``, the time between two decisions.
        worst_case: ``"dirac_support"``, ``"wasserstein_direct"`` or ``"wasserstein_lp"``.
        terminal_value: ``"env"`` (the table's rewards) or ``"fl_hack"`` (module docstring).
        memoise: Share decision values by (state, depth) (same result, far fewer nodes).
        distances: ``[num_states, num_states]`` ground metric replacing the grid's Manhattan
            distance.

    Returns:
        The decision; ``values`` are the root chance values, ``visits`` ones, ``stats`` counts
        ``decision_nodes`` and ``chance_nodes`` evaluated.

    Raises:
        TypeError / ValueError: A hyper-parameter is of the wrong type or out of range, the model
            is not tabular, ``root_state`` is not one of its states, or a Wasserstein rule has no
            ground metric.
    """
    config = check_config(
        depth=depth,
        gamma=gamma,
        lipschitz_p=lipschitz_p,
        lipschitz_r=lipschitz_r,
        tau=tau,
        worst_case=worst_case,
        terminal_value=terminal_value,
        memoise=memoise,
    )
    table = _table_of(model)
    num_states, num_actions, _ = table.probs.shape
    if isinstance(root_state, bool) or not isinstance(root_state, (int, np.integer)):
        raise TypeError(f"root_state={root_state!r} must be an int state index")
    if not 0 <= root_state < num_states:
        raise ValueError(f"root_state={root_state!r} is outside 0..{num_states - 1}")
    metric = None
    if worst_case != "dirac_support":
        metric = _metric(model.family, distances, num_states).tolist()
    search = _Search(table, config, metric)
    values = np.array([search.chance(int(root_state), a, 0) for a in range(num_actions)])
    return SearchResult(
        action=int(np.argmax(values)),
        values=values,
        visits=np.ones(num_actions, dtype=np.int64),
        stats={"decision_nodes": search.decision_nodes, "chance_nodes": search.chance_nodes},
    )


def rats_agent(name: str | None = None, **hyper_parameters: Any) -> SearchAgent:
    """A :class:`SearchAgent` running :func:`rats` with ``hyper_parameters`` (checked now)."""
    check_config(**hyper_parameters)
    search = functools.partial(rats, **hyper_parameters)
    label = name or f"RATS({hyper_parameters.get('worst_case', 'dirac_support')})"
    return SearchAgent(search, name=label)


def check_config(
    *,
    depth: int = 3,
    gamma: float = 0.99,
    lipschitz_p: float = 1.0,
    lipschitz_r: float = 0.0,
    tau: float = 1.0,
    worst_case: str = "dirac_support",
    terminal_value: str = "env",
    memoise: bool = True,
    distances: np.ndarray | None = None,
) -> dict[str, Any]:
    """Validate RATS's hyper-parameters; return them as a dict.

    Raises:
        TypeError / ValueError: The first bad one, named with its value and what is allowed.
    """
    if isinstance(depth, bool) or not isinstance(depth, int):
        raise TypeError(f"depth={depth!r} must be an int >= 1")
    if depth < 1:
        raise ValueError(f"depth={depth!r} must be >= 1")
    numbers = {"gamma": gamma, "lipschitz_p": lipschitz_p, "lipschitz_r": lipschitz_r, "tau": tau}
    for key, value in numbers.items():
        if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
            raise TypeError(f"{key}={value!r} must be a real number")
        if not (math.isfinite(value) and value >= 0.0):
            raise ValueError(f"{key}={value!r} must be finite and >= 0")
    if gamma > 1.0:
        raise ValueError(f"gamma={gamma!r} must lie in [0, 1]")
    if worst_case not in WORST_CASES:
        raise ValueError(f"worst_case={worst_case!r} is not one of {sorted(WORST_CASES)}")
    if terminal_value not in TERMINAL_VALUES:
        raise ValueError(f"terminal_value={terminal_value!r} is not one of {list(TERMINAL_VALUES)}")
    if not isinstance(memoise, bool):
        raise TypeError(f"memoise={memoise!r} must be a bool")
    return {
        "depth": depth,
        "gamma": float(gamma),
        "budget_per_depth": float(lipschitz_p) * float(tau),
        "reward_drift_per_depth": float(lipschitz_r) * float(tau),
        "worst_case": worst_case,
        "terminal_value": terminal_value,
        "memoise": memoise,
    }


def grid_distances(family: Any) -> np.ndarray:
    """``[S, S]`` Manhattan distances between the cells of a grid family (``nrow`` x ``ncol``).

    Raises:
        ValueError: The family has no grid layout.
    """
    nrow, ncol = getattr(family, "nrow", None), getattr(family, "ncol", None)
    if not isinstance(nrow, int) or not isinstance(ncol, int):
        raise ValueError(
            f"family={family!r} has no grid layout (nrow/ncol) for the Manhattan ground metric; "
            "pass distances= (a [num_states, num_states] array)"
        )
    rows, cols = np.divmod(np.arange(nrow * ncol), ncol)
    manhattan = np.abs(rows[:, None] - rows[None, :]) + np.abs(cols[:, None] - cols[None, :])
    return manhattan.astype(np.float64)


class _Search:
    """The recursion, over Python lists (a few thousand tiny nodes: no numpy per node)."""

    def __init__(self, table: Any, config: dict[str, Any], metric: list | None) -> None:
        self.probs = table.probs.tolist()
        self.next_states = table.next_states.tolist()
        self.terminals = table.terminals.tolist()
        rewards = table.rewards.tolist()
        if config["terminal_value"] == "fl_hack":
            self.planner_rewards = [
                [
                    [-1.0 if t and r == 0.0 else r for r, t in zip(rs, ts, strict=True)]
                    for rs, ts in zip(by_s, t_s, strict=True)
                ]
                for by_s, t_s in zip(rewards, self.terminals, strict=True)
            ]
            self.terminal_values = [
                [[1.0 if r > 0.0 else -1.0 for r in rs] for rs in by_s] for by_s in rewards
            ]
        else:
            self.planner_rewards = rewards
            self.terminal_values = rewards
        self.metric = metric
        self.depth = config["depth"]
        self.gamma = config["gamma"]
        self.budget_per_depth = config["budget_per_depth"]
        self.drift = config["reward_drift_per_depth"]
        self.worst_case = WORST_CASES[config["worst_case"]]
        self.memo: dict[tuple[int, int], float] | None = {} if config["memoise"] else None
        self.decision_nodes = 0
        self.chance_nodes = 0

    def decision(self, state: int, depth: int) -> float:
        """Value of a non-terminal decision node above the depth limit."""
        memo = self.memo
        if memo is not None:
            cached = memo.get((state, depth))
            if cached is not None:
                return cached
        self.decision_nodes += 1
        best = -math.inf
        for action in range(len(self.probs[state])):
            best = max(best, self.chance(state, action, depth))
        if memo is not None:
            memo[(state, depth)] = best
        return best

    def chance(self, state: int, action: int, depth: int) -> float:
        """Value of taking ``action`` in ``state`` at look-ahead ``depth``."""
        self.chance_nodes += 1
        w0 = self.probs[state][action]
        next_states = self.next_states[state][action]
        terminals = self.terminals[state][action]
        child_depth = depth + 1
        if child_depth == self.depth:
            values = [0.0] * len(w0)
        else:
            values = [
                self.terminal_values[state][action][i]
                if terminals[i]
                else self.decision(next_states[i], child_depth)
                for i in range(len(w0))
            ]
        metric = self.metric
        distances = None
        if metric is not None:
            distances = [[metric[a][b] for b in next_states] for a in next_states]
        w = self.worst_case(w0, values, distances, depth * self.budget_per_depth)
        expected = 0.0
        for weight, value in zip(w, values, strict=True):
            expected += weight * value
        reward = 0.0
        for r, p in zip(self.planner_rewards[state][action], w0, strict=True):
            reward += r * p
        return self.gamma * expected + (reward - self.drift * depth)


def _table_of(model: Any) -> Any:
    table = getattr(model, "outcomes", None)
    if table is None or not hasattr(table, "probs"):
        raise TypeError(
            f"RATS needs a tabular planning model with an outcome table (model.outcomes); "
            f"got {model!r}"
        )
    return table


def _metric(family: Any, distances: np.ndarray | None, num_states: int) -> np.ndarray:
    if distances is None:
        return grid_distances(family)
    metric = np.asarray(distances, dtype=np.float64)
    if metric.shape != (num_states, num_states) or not np.isfinite(metric).all():
        raise ValueError(
            f"distances has shape {metric.shape}; expected a finite ({num_states}, {num_states}) "
            "array"
        )
    if (metric < 0).any():
        raise ValueError("distances has negative entries; a ground metric is >= 0")
    return metric
