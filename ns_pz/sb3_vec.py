"""Moved to :mod:`ns_pz.learning.sb3_vec`; this module keeps earlier imports working."""

from ns_pz.learning.sb3_vec import SB3VecEnv

__all__ = ["SB3VecEnv"]
