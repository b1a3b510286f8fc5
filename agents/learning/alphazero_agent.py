"""The AlphaZero agent: PUCT on the handed planning model, guided by a network frozen at θ_0.

The network is trained once by self-play on the base environment (:mod:`.alphazero`) and never
updated while acting; what changes with the notification level is only the planning model the
search runs in (θ_0 without notification, the current θ with). Acting needs numpy only.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
from ns_pz.agents.learning.config import AlphaZeroArgs
from ns_pz.agents.learning.puct import (
    PolicyValueFunction,
    PUCTSettings,
    model_evaluation,
    puct,
)
from ns_pz.agents.learning.trained import alphazero_needed, obtain
from ns_pz.agents.search.types import SearchAgent, SearchResult

from ns_pz.views import NSGymEnv


class AlphaZeroAgent(SearchAgent):
    """PUCT (:func:`ns_pz.agents.learning.puct.puct`) with a trained policy/value network.

    Args:
        function: The trained network.
        settings: PUCT's hyper-parameters at decision time.
    """

    def __init__(self, function: PolicyValueFunction, settings: PUCTSettings) -> None:
        self.function = function
        self.settings = settings
        super().__init__(self._search, name=f"AlphaZero(m={settings.iterations})")

    def _search(self, model: Any, root_state: Any, rng: np.random.Generator) -> SearchResult:
        return puct(model, root_state, rng, model_evaluation(self.function, model), self.settings)

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
    settings = args.puct_settings()
    if args.search_iterations is not None:
        settings = dataclasses.replace(settings, iterations=args.search_iterations)
    return AlphaZeroAgent(function, settings)
