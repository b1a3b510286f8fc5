"""Decision agents (installed as ``ns_pz.agents``)."""
