"""Shared fixtures: small fixed instances and a way to register throwaway environments."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import gymnasium
import pytest
from ns_pz.envs import registry


@contextlib.contextmanager
def temporary_env(env_id: str, family: type, **kwargs: object) -> Iterator[str]:
    """Register ``family`` under ``env_id`` for the duration of a ``with`` block."""
    registry.register(env_id, family, max_episode_steps=50, description="test", **kwargs)
    try:
        yield env_id
    finally:
        registry._SPECS.pop(env_id, None)
        gymnasium.registry.pop(env_id, None)


@pytest.fixture
def register_temporary():
    """The :func:`temporary_env` context manager."""
    return temporary_env
