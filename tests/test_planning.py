"""Planning models: save/restore, agreement with the outcome table, independence."""

from __future__ import annotations

import numpy as np
from ns_pz.envs.frozen_lake import FrozenLakeFamily, FrozenLakeParams

import ns_pz
from ns_pz.planning import TabularModel


def test_save_restore_replays_the_same_transition_given_the_same_draw():
    """Restoring a saved state and redrawing with the same generator state repeats the outcome."""
    env = ns_pz.make_gym("ns_pz/CartPole-v0")
    env.reset(seed=0)
    model = env.planning_model()
    saved = model.get_state()
    first = model.step(1)
    model.set_state(saved)
    assert model.step(1) == first
    assert model.get_state() == first[0]


def test_sampled_frequencies_match_the_outcome_table():
    """Sampling a tabular model reproduces the probabilities of its explicit table."""
    family = FrozenLakeFamily("4x4")
    theta = FrozenLakeParams(slip=(0.5, 0.3, 0.2))
    model = family.planning_model(theta, 5 - 5, np.random.default_rng(0))
    assert isinstance(model, TabularModel)
    counts: dict = {}
    draws = 20_000
    for _ in range(draws):
        nxt, _, _ = model.transition(0, 2)
        counts[nxt] = counts.get(nxt, 0) + 1
    table = model.outcomes
    expected: dict = {}
    for k in range(3):
        nxt = int(table.next_states[0, 2, k])
        expected[nxt] = expected.get(nxt, 0.0) + table.probs[0, 2, k]
    for nxt, prob in expected.items():
        assert abs(counts[nxt] / draws - prob) < 0.015


def test_clone_is_independent_in_state():
    """A clone moves on its own; the original keeps its state."""
    env = ns_pz.make_gym("ns_pz/FrozenLake-v0")
    env.reset(seed=0)
    model = env.planning_model()
    clone = model.clone()
    clone.step(2)
    assert model.get_state() == 0
    assert clone.theta is model.theta


def test_terminal_cells_absorb():
    """From a hole or the goal every outcome stays put, terminal, with no reward."""
    family = FrozenLakeFamily("4x4")
    table = family.outcomes(FrozenLakeParams())
    for cell in (5, 15):
        assert (table.next_states[cell] == cell).all() and table.terminals[cell].all()
        assert not table.rewards[cell].any()
