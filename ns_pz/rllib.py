"""Moved to :mod:`ns_pz.learning.rllib`; this module keeps earlier imports working."""

from ns_pz.learning.rllib import GameForRLlib, env_creator, ppo_config, register

__all__ = ["GameForRLlib", "env_creator", "ppo_config", "register"]
