"""Agents that fail on purpose, importable by worker processes as ``agents_for_tests:...``."""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

from ns_pz.agents.baselines import RandomAgent


class FailsOnCell(RandomAgent):
    """A random agent that raises (or kills its process) when it stands on one cell."""

    def __init__(self, action_space: Any, cell: int, hard: bool) -> None:
        super().__init__(action_space)
        self.cell, self.hard = cell, hard

    def act(self, observation: dict[str, Any], model: Any = None) -> int:
        """Random, except on :attr:`cell`."""
        if int(observation["state"]) == self.cell:
            if self.hard:
                os._exit(3)  # a crash no Python handler sees, like a segfault
            raise RuntimeError(f"boom on cell {self.cell}")
        return super().act(observation, model)


def raises_on_cell(env: Any, *, cell: int = 8) -> FailsOnCell:
    """Raises RuntimeError on ``cell``."""
    return FailsOnCell(env.family.action_space, cell, hard=False)


def exits_on_cell(env: Any, *, cell: int = 8) -> FailsOnCell:
    """Kills its own process on ``cell``."""
    return FailsOnCell(env.family.action_space, cell, hard=True)


class ExitsOnCell(FailsOnCell):
    """Calls ``sys.exit`` on its cell, as a library's argument parser might."""

    def act(self, observation: dict[str, Any], model: Any = None) -> int:
        """Random, except on :attr:`cell`."""
        if int(observation["state"]) == self.cell:
            raise SystemExit(0)
        return RandomAgent.act(self, observation, model)


def exits_politely_on_cell(env: Any, *, cell: int = 8) -> FailsOnCell:
    """Raises SystemExit on ``cell``."""
    return ExitsOnCell(env.family.action_space, cell, hard=False)


class SlowRandom(RandomAgent):
    """A random agent that takes ``pause`` seconds a step and leaves its process id in a folder."""

    def __init__(self, action_space: Any, pause: float, marker: str) -> None:
        super().__init__(action_space)
        self.pause, self.marker = pause, marker

    def act(self, observation: dict[str, Any], model: Any = None) -> int:
        """Random, after the pause."""
        if self.marker:
            Path(self.marker, str(os.getpid())).touch()
        time.sleep(self.pause)
        return super().act(observation, model)


def slow_random(env: Any, *, pause: float = 0.05, marker: str = "") -> SlowRandom:
    """A random agent slow enough to be caught mid-trial (``marker``: a folder for its pids)."""
    return SlowRandom(env.family.action_space, pause, marker)
