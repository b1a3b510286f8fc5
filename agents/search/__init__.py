"""Search agents: functions of (model, root state, budget, rng) and the agent that drives them.

* :class:`MCTS` / :func:`uct`: UCT with random rollouts (compiled with numba when installed);
* :class:`ADAMCTS`: ADA-MCTS with a Dirichlet transition learner (tabular envs);
* :func:`rats_agent`: RATS, UCT against the worst case of a Wasserstein ball around the model;
* :class:`SearchAgent`: plugs any ``search(model, root_state, rng) -> SearchResult`` into the loop.

Importing this package does not import numba: the compiled kernels load on first use.
"""

from ns_pz.agents.search.ada_mcts import ADAMCTS
from ns_pz.agents.search.mcts import MCTS, UCTTree, uct, uct_tree
from ns_pz.agents.search.rats import rats_agent
from ns_pz.agents.search.types import SearchAgent, SearchFunction, SearchResult

__all__ = [
    "ADAMCTS",
    "MCTS",
    "SearchAgent",
    "SearchFunction",
    "SearchResult",
    "UCTTree",
    "rats_agent",
    "uct",
    "uct_tree",
]
