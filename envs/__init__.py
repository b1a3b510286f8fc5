"""Base environment families with their θ, and the registry (installed as ``ns_pz.envs``)."""
