"""The AlphaZero agent: PUCT on the handed planning model, guided by a network frozen at θ_0.

The network is trained once by self-play on the base environment (:mod:`.alphazero`) and never
updated while acting; what changes with the notification level is only the planning model the
search runs in (θ_0 without notification, the current θ with). Acting needs numpy only.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from ns_pz.agents.learning.config import AlphaZeroArgs
from ns_pz.agents.learning.puct import PolicyValueFunction, model_evaluation, puct
from ns_pz.agents.learning.trained import alphazero_needed, obtain
from ns_pz.agents.search.types import SearchAgent, SearchResult

from ns_pz.views import NSGymEnv


class AlphaZeroAgent(SearchAgent):
    """PUCT (:func:`ns_pz.agents.learning.puct.puct`) with a trained policy/value network.

    Args:
        function: The trained network.
        iterations: Simulations per decision.
        depth: Most levels a simulation descends.
        c: Exploration constant.
        gamma: Discount.
        dirichlet_alpha: Root-noise concentration.
        noise: Root-noise weight ε (the paper's CliffWalking: 0.75).
        normalise_q: Min-max scale Q in the selection (see :func:`puct_tree`).
    """

    def __init__(
        self,
        function: PolicyValueFunction,
        *,
        iterations: int,
        depth: int,
        c: float,
        gamma: float,
        dirichlet_alpha: float,
        noise: float,
        normalise_q: bool,
    ) -> None:
        self.function = function
        self.settings = dict(
            iterations=iterations,
            depth=depth,
            c=c,
            gamma=gamma,
            dirichlet_alpha=dirichlet_alpha,
            noise=noise,
            normalise_q=normalise_q,
        )
        super().__init__(self._search, name=f"AlphaZero(m={iterations})")

    def _search(self, model: Any, root_state: Any, rng: np.random.Generator) -> SearchResult:
        evaluate = model_evaluation(self.function, model)
        return puct(model, root_state, rng, evaluate=evaluate, **self.settings)

    def __repr__(self) -> str:
        return f"AlphaZeroAgent({self.settings})"


def build_alphazero(env: NSGymEnv, **hyper: Any) -> AlphaZeroAgent:
    """AlphaZero for ``env``; ``hyper`` are :class:`AlphaZeroArgs` fields.

    Family defaults are filled in; the network is trained on ``env``'s θ_0 first if it is not
    cached.
    """
    args = AlphaZeroArgs(**hyper).for_family(env.family)
    weights = obtain(alphazero_needed(env, args))
    function = PolicyValueFunction(weights, env.family.observation_space)
    assert args.c is not None and args.gamma is not None  # filled in by for_family
    return AlphaZeroAgent(
        function,
        iterations=args.search_iterations or args.iterations,
        depth=args.depth,
        c=args.c,
        gamma=args.gamma,
        dirichlet_alpha=args.dirichlet_alpha or 1.0,
        noise=args.noise or 0.0,
        normalise_q=args.normalise_q,
    )
