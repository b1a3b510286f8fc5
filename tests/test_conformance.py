"""Every registered environment passes the conformance suite; broken ones are caught."""

from __future__ import annotations

import numpy as np
import pytest
from ns_pz.envs.frozen_lake import FrozenLakeFamily

import ns_pz
from ns_pz import Monitor
from ns_pz.testing import (
    check_game_api,
    check_game_matches_view,
    check_ns_env,
    check_reproducible,
    check_theta_invariants,
)


@pytest.mark.parametrize("env_id", ns_pz.registered_envs())
def test_registered_env_conforms(env_id):
    """api_test, seed_test, check_env and the ns_pz invariants, for every registered id."""
    check_ns_env(env_id)


class GlobalRandomLake(FrozenLakeFamily):
    """Broken on purpose: draws its start state from numpy's global generator."""

    def initial_state(self, rng):
        """A start drawn from the global generator."""
        return int(np.random.randint(0, 4))


class MutatingLake(FrozenLakeFamily):
    """Broken on purpose: writes into the θ it is handed."""

    def step(self, state, action, theta, rng):
        """Overwrite θ's slip vector, then step."""
        object.__setattr__(theta, "slip", (1.0, 0.0, 0.0))
        return super().step(state, action, theta, rng)


class OutOfSpaceLake(FrozenLakeFamily):
    """Broken on purpose: observes a state index the space does not contain."""

    def observe(self, state):
        """An index past the last state."""
        return state + 100


def test_global_randomness_is_caught(register_temporary):
    """A family using the global RNG fails the reproducibility check."""
    with register_temporary("test/GlobalRandomLake-v0", GlobalRandomLake) as env_id:
        with pytest.raises(AssertionError, match="same seed, different trajectories"):
            for _ in range(5):  # the global draw differs from run to run
                check_reproducible(env_id)


def test_mutating_theta_is_caught(register_temporary):
    """A family that mutates θ fails the invariants check."""
    with register_temporary("test/MutatingLake-v0", MutatingLake) as env_id:
        with pytest.raises(AssertionError, match="mutated"):
            check_theta_invariants(env_id)


def test_observation_outside_its_space_is_caught(register_temporary):
    """A family whose observations leave their space fails the PettingZoo API test."""
    with register_temporary("test/OutOfSpaceLake-v0", OutOfSpaceLake) as env_id:
        with pytest.raises(AssertionError):
            check_game_api(env_id)


class LastRewardAlarm(Monitor):
    """A detector-style monitor: raises every flag when the last reward was positive."""

    def notify(self, observation, truth, memory, rng):
        """Flags from the observation alone; sizes zero."""
        alarm = int(observation["last_reward"][0] > 0)
        count = 6
        return (alarm,) * count, (0.0,) * count


def test_a_monitor_that_reads_observations_runs_alike_in_game_and_view():
    """Non-oracle monitors get the transition observation in both faces, with equal results."""
    check_game_matches_view("ns_pz/CartPole-v0", monitors=(LastRewardAlarm(),))
    env = ns_pz.make_gym("ns_pz/CartPole-v0", monitor=LastRewardAlarm(), notification="basic")
    env.reset(seed=0)
    assert env.step(1)[0]["env_change"].tolist() == [1] * 6  # CartPole pays +1 every step


class SharedStateMonitor(Monitor):
    """A broken monitor: it keeps its count on itself, not in the per-episode memory."""

    def __init__(self):
        self.calls = 0

    def notify(self, observation, truth, memory, rng):
        """Raises every flag on every third call, counting calls from every environment."""
        self.calls += 1
        alarm = int(self.calls % 3 == 0)
        return (alarm,) * 6, (0.0,) * 6


def test_game_and_view_agree_for_stateful_random_monitors_and_natures():
    """The default check runs a stateful random monitor (speaking at t = 0) and nature."""
    check_game_matches_view("ns_pz/CartPole-v0")
    check_game_matches_view("ns_pz/FrozenLake-v0")


def test_a_broken_monitor_fails_the_game_view_check():
    """A monitor whose state leaks between environments makes the game and the view differ."""
    with pytest.raises(AssertionError, match="!="):
        check_game_matches_view("ns_pz/CartPole-v0", monitors=(SharedStateMonitor(),))


def test_the_view_asks_the_monitor_at_reset_as_the_game_does():
    """The monitor's turn of step 0 happens in the view too (it used to be skipped)."""
    calls = []

    class Recorder(Monitor):
        def notify(self, observation, truth, memory, rng):
            calls.append(int(observation["relative_time"][0]))
            return (0,) * 6, (0.0,) * 6

    env = ns_pz.make_gym("ns_pz/CartPole-v0", monitor=Recorder(), notification="basic")
    env.reset(seed=0)
    env.step(0)
    assert calls == [0, 1]
