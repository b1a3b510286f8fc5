"""Small FrozenLake experiment specs shared by the runner's tests (TOML text)."""

from __future__ import annotations

RANDOM = '[[agents]]\nname = "random"\n'
VI = '[[agents]]\nname = "value_iteration"\nlabel = "VI"\n'
VI_GAMMA = VI + "quick = { gamma = 0.9 }\n"
MCTS = '[[agents]]\nname = "mcts"\nlabel = "MCTS"\nparams = { iterations = 200, depth = 30 }\n'


def tiny_spec(
    *agents: str,
    to: tuple[float, ...] = (0.4, 0.9),
    episodes: int = 4,
    horizon: int = 30,
    full_episodes: int | None = None,
    name: str = "tiny",
    title: str = "tiny FrozenLake",
) -> str:
    """A single-change FrozenLake spec (slip 0.7, detailed and none) with ``agents``' entries.

    ``full_episodes`` adds a ``full`` size of that many episodes (same horizon); the trials
    number ``len(to)`` settings × 2 levels × agents × ``episodes`` seeds.
    """
    sizes = f"[sizes.quick]\nepisodes = {episodes}\nhorizon = {horizon}\n"
    if full_episodes is not None:
        sizes += f"\n[sizes.full]\nepisodes = {full_episodes}\nhorizon = {horizon}\n"
    targets = ", ".join(repr(value) for value in to)
    head = f"""
version = 1
name = "{name}"
title = "{title}"
env = "ns_pz/FrozenLake-v0"
params = {{ slip = 0.7 }}
notifications = ["detailed", "none"]

[change]
kind = "single"
param = "slip"
first_step = 1
to = [{targets}]

"""
    return head + sizes + "".join("\n" + agent for agent in agents)
