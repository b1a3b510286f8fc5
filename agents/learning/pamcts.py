"""PA-MCTS (Pettet et al., AAMAS 2024): UCT under the current model, mixed with a stale Q.

UCT (:func:`ns_pz.agents.search.mcts.uct_tree`, compiled where MCTS is) runs in the planning
model handed over; at the root its action values ``G`` are combined with the frozen
Q-network of the base environment: ``argmax_a α q(a) + (1 - α) G(a)``. α is the weight of the
stale policy: α = 0 is MCTS, α = 1 the stale DDQN. With ``normalise`` (NS-Gym's HEAD)
both vectors are first min-max scaled to [0, 1] with a ``1e-8`` guard (the paper-era code
divided by zero when all values were equal and then played action 0). Root actions the search
never tried are not played unless α = 1. Ties are broken uniformly with the search generator.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
from ns_pz.agents.learning.config import DDQNArgs, nested_args
from ns_pz.agents.learning.q_agent import QNetwork, ddqn_q_network
from ns_pz.agents.search.compiled import BACKENDS
from ns_pz.agents.search.mcts import check_uct_params, uct_tree, uniform_index
from ns_pz.agents.search.types import SearchAgent, SearchResult

from ns_pz.checks import flag
from ns_pz.views import NSGymEnv

QFunction = Callable[[Any], np.ndarray]


def _min_max(values: np.ndarray) -> np.ndarray:
    return (values - values.min()) / (values.max() - values.min() + 1e-8)


def mix(
    search_values: np.ndarray, q_values: np.ndarray, alpha: float, normalise: bool
) -> np.ndarray:
    """``[num_actions]`` scores ``α q + (1 - α) G``; untried actions (NaN in G) score -inf.

    At α = 1 the search is ignored entirely (untried actions included).
    """
    q = _min_max(q_values) if normalise else q_values
    if alpha == 1.0:
        return q.astype(np.float64)
    tried = ~np.isnan(search_values)
    g = np.zeros_like(search_values)
    g[tried] = _min_max(search_values[tried]) if normalise else search_values[tried]
    return np.where(tried, alpha * q + (1.0 - alpha) * g, -np.inf)


def pamcts(
    model: Any,
    root_state: Any,
    rng: np.random.Generator,
    *,
    q_fn: QFunction,
    alpha: float = 0.5,
    normalise: bool = True,
    iterations: int = 1000,
    depth: int = 500,
    c: float = math.sqrt(2),
    gamma: float = 0.99,
    backend: str = "auto",
) -> SearchResult:
    """One PA-MCTS decision from ``root_state`` (see the module docstring).

    Args:
        model: The planning model handed over (as for :func:`ns_pz.agents.search.mcts.uct`).
        root_state: The state to decide in.
        rng: The search generator (UCT's choices, then the final tie-break).
        q_fn: ``q_fn(state) -> [num_actions]`` stale action values of a model state.
        alpha: Weight of the stale Q in [0, 1].
        normalise: Min-max scale both vectors before mixing.
        iterations: UCT's m.
        depth: UCT's rollout cap d.
        c: UCT's exploration constant.
        gamma: UCT's discount.
        backend: UCT's backend (see :func:`ns_pz.agents.search.mcts.uct`).

    Returns:
        The action; ``values`` are the mixed scores, ``visits`` UCT's root visit counts.
    """
    tree = uct_tree(
        model,
        root_state,
        rng,
        iterations=iterations,
        depth=depth,
        c=c,
        gamma=gamma,
        backend=backend,
    )
    visits = tree.visits[0].copy()
    search_values = np.where(visits > 0, tree.q[0], np.nan)
    scores = mix(search_values, np.asarray(q_fn(root_state), dtype=np.float64), alpha, normalise)
    best = np.flatnonzero(scores == scores.max())
    action = int(best[0] if len(best) == 1 else best[uniform_index(rng, len(best))])
    stats = {
        "iterations": float(iterations),
        "nodes": float(tree.num_nodes),
        "simulated_steps": float(tree.simulated_steps),
    }
    return SearchResult(action, scores, visits, stats)


def check_alpha(alpha: Any) -> float:
    """``alpha`` as a float in [0, 1].

    Raises:
        TypeError, ValueError: Not a real number in [0, 1].
    """
    if isinstance(alpha, bool) or not isinstance(alpha, (int, float)):
        raise TypeError(f"alpha={alpha!r} must be a real number in [0, 1]")
    if not 0.0 <= alpha <= 1.0:
        raise ValueError(f"alpha={alpha!r} must lie in [0, 1]")
    return float(alpha)


class PAMCTS(SearchAgent):
    """The PA-MCTS agent: :func:`pamcts` on the model handed over at every step.

    Args:
        q_network: The stale Q-network (DDQN trained on θ_0).
        alpha: Weight of the stale Q (paper: 0.25, 0.5, 0.75).
        normalise: Min-max scale both value vectors first.
        iterations, depth, c, gamma, backend: UCT's (paper: m 1000 FrozenLake/CliffWalking,
            500 Bridge, 300 CartPole; d 500, 200, 200, 500; c √2; γ 0.99, 0.999, 0.99, 1).

    Raises:
        TypeError, ValueError: A hyper-parameter out of range.
    """

    def __init__(
        self,
        q_network: QNetwork,
        alpha: float = 0.5,
        normalise: bool = True,
        iterations: int = 1000,
        depth: int = 500,
        c: float = math.sqrt(2),
        gamma: float = 0.99,
        backend: str = "auto",
    ) -> None:
        alpha = check_pamcts(alpha, normalise, iterations, depth, c, gamma, backend)
        self._observe: Callable[[Any], Any] | None = None
        search = functools.partial(
            pamcts,
            q_fn=self._q_of_state,
            alpha=alpha,
            normalise=normalise,
            iterations=iterations,
            depth=depth,
            c=c,
            gamma=gamma,
            backend=backend,
        )
        self.q_network = q_network
        self.alpha = alpha
        super().__init__(search, name=f"PA-MCTS(alpha={alpha}, m={iterations}, d={depth})")

    def act(self, observation: dict[str, Any], model: Any | None = None) -> Any:
        """Search the handed model and mix with the stale Q at the root."""
        self._observe = getattr(getattr(model, "family", None), "observe", None)
        return super().act(observation, model)

    def _q_of_state(self, state: Any) -> np.ndarray:
        observation = self._observe(state) if self._observe is not None else state
        return self.q_network(observation)

    def __repr__(self) -> str:
        return f"PAMCTS(alpha={self.alpha})"


def check_pamcts(
    alpha: Any, normalise: Any, iterations: Any, depth: Any, c: Any, gamma: Any, backend: Any
) -> float:
    """Validate PA-MCTS's acting hyper-parameters (without its network); returns α.

    Raises:
        TypeError, ValueError: A hyper-parameter out of range (a string ``"false"`` is no bool).
    """
    alpha = check_alpha(alpha)
    check_uct_params(iterations, depth, c, gamma)
    flag("normalise", normalise)
    if backend not in BACKENDS:
        raise ValueError(f"backend={backend!r} is not a backend; allowed: {list(BACKENDS)}")
    return alpha


def build_pamcts(
    env: NSGymEnv,
    *,
    alpha: float = 0.5,
    normalise: bool = True,
    iterations: int = 1000,
    depth: int = 500,
    c: float = math.sqrt(2),
    gamma: float = 0.99,
    backend: str = "auto",
    ddqn: Mapping[str, Any] | None = None,
) -> PAMCTS:
    """PA-MCTS for ``env`` (the UCT settings as :class:`PAMCTS`).

    ``ddqn`` are the :class:`DDQNArgs` of its stale Q-network: the same as the ``ddqn`` agent's,
    so both share one trained artefact.
    """
    q_network = ddqn_q_network(env, nested_args(DDQNArgs, ddqn, "ddqn"))
    return PAMCTS(q_network, alpha, normalise, iterations, depth, c, gamma, backend)
