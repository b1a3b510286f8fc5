"""Search agents: functions of (model, root state, budget, rng) and the agent that drives them."""

from ns_pz.agents.search.types import SearchAgent, SearchFunction, SearchResult

__all__ = ["SearchAgent", "SearchFunction", "SearchResult"]
