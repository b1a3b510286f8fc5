"""The CartPole and FrozenLake families: Gymnasium-equal dynamics, and every θ field has effect."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from ns_pz.envs.cartpole import CartPoleFamily, CartPoleParams
from ns_pz.envs.frozen_lake import FrozenLakeFamily, FrozenLakeParams

import ns_pz
from ns_pz.nature import DiscreteScheduler, ScriptedNature, StepWiseUpdate

ACTIONS = np.random.default_rng(5).integers(0, 2, 300).tolist()


def gymnasium_cartpole(theta: CartPoleParams) -> gym.Env:
    """Gymnasium's CartPole with θ set *and* its derived constants recomputed."""
    env = gym.make("CartPole-v1").unwrapped
    for name, value in theta.as_dict().items():
        setattr(env, name, value)
    env.total_mass = theta.total_mass
    env.polemass_length = theta.polemass_length
    return env


@pytest.mark.parametrize(
    "theta",
    [CartPoleParams(), CartPoleParams(masspole=0.7, length=1.3, gravity=3.7, tau=0.01)],
)
def test_cartpole_matches_gymnasium_step_for_step(theta):
    """Same seed, same θ, same actions: the same observations as Gymnasium's CartPole."""
    reference = gymnasium_cartpole(theta)
    expected, _ = reference.reset(seed=4)
    env = ns_pz.make_gym("ns_pz/CartPole-v0", params=theta)
    observed, _ = env.reset(seed=4)
    for action in ACTIONS:
        np.testing.assert_allclose(observed["state"], expected, rtol=1e-6, atol=1e-7)
        expected, reward, terminated, _, _ = reference.step(action)
        observed, obs_reward, obs_terminated, _, _ = env.step(action)
        assert (obs_reward, obs_terminated) == (reward, terminated)
        if terminated:
            break


@pytest.mark.parametrize("name", CartPoleParams.names())
def test_every_cartpole_parameter_changed_at_run_time_equals_building_with_it(name):
    """θ changed right after reset gives exactly the trajectory of an env built with that θ."""
    spec = CartPoleParams.spec(name)
    value = spec.default * 1.7 if spec.default else 2.0
    changed = ns_pz.make_gym("ns_pz/CartPole-v0")
    built = ns_pz.make_gym("ns_pz/CartPole-v0", params={name: value})
    baseline = ns_pz.make_gym("ns_pz/CartPole-v0")
    changed.reset(seed=8)
    built.reset(seed=8)
    baseline.reset(seed=8)
    changed.set_params(**{name: value})
    differs = False
    for action in ACTIONS[:40]:
        a, _, done, _, _ = changed.step(action)
        b, *_ = built.step(action)
        c, _, baseline_done, _, _ = baseline.step(action)
        assert np.array_equal(a["state"], b["state"])
        differs |= not np.array_equal(a["state"], c["state"])
        if done or baseline_done:
            break
    assert differs, f"changing {name} had no effect on the dynamics"


def test_cartpole_masspole_change_mid_episode_uses_new_derived_quantities():
    """A change of masspole by nature updates total mass and pole mass-length in the physics."""
    nature = ScriptedNature({"masspole": StepWiseUpdate(DiscreteScheduler({3}), [0.9])})
    env = ns_pz.make_gym("ns_pz/CartPole-v0", nature=nature)
    env.reset(seed=0)
    for _ in range(3):
        env.step(1)
    state = env._process.state
    expected = CartPoleFamily().step(state, 0, CartPoleParams(masspole=0.9), None)[0]
    env.step(0)
    assert env._process.state == expected


def test_frozen_lake_outcomes_match_gymnasium_slippery_table():
    """At slip (1/3, 1/3, 1/3) the outcome table gives Gymnasium's slippery P distribution."""
    family = FrozenLakeFamily("4x4")
    table = family.outcomes(FrozenLakeParams())
    reference = gym.make("FrozenLake-v1").unwrapped.P
    for s in range(16):
        for a in range(4):
            ours: dict = {}
            for k in range(3):
                key = (
                    int(table.next_states[s, a, k]),
                    float(table.rewards[s, a, k]),
                    bool(table.terminals[s, a, k]),
                )
                ours[key] = ours.get(key, 0.0) + table.probs[s, a, k]
            theirs: dict = {}
            for prob, nxt, reward, done in reference[s][a]:
                key = (nxt, float(reward), done)
                theirs[key] = theirs.get(key, 0.0) + prob
            if family.is_terminal_state(s):
                continue  # Gymnasium never steps from a terminal cell
            assert ours.keys() == theirs.keys()
            for key in ours:
                assert ours[key] == pytest.approx(theirs[key])


def test_frozen_lake_samples_like_gymnasium_with_the_same_generator():
    """With one uniform draw per step, as Gymnasium, the trajectories coincide exactly."""
    slip = (0.6, 0.3, 0.1)
    reference = gym.make("FrozenLake-v1").unwrapped
    for s in range(16):  # rebuild Gymnasium's table with NS-Gym's outcome order and θ
        for a in range(4):
            if reference.P[s][a][0][3] and len(reference.P[s][a]) == 1:
                continue
            outcomes = {nxt: (r, d) for _, nxt, r, d in reference.P[s][a]}
            moves = [FrozenLakeFamily("4x4")._table[s][a][k] for k in range(3)]
            reference.P[s][a] = [(p, n, r, d) for p, (n, r, d) in zip(slip, moves, strict=True)]
            assert set(outcomes) >= {m[0] for m in moves}
    reference.reset(seed=3)
    env = ns_pz.make_gym("ns_pz/FrozenLake-v0", params={"slip": slip})
    env.reset(seed=3)
    actions = np.random.default_rng(1).integers(0, 4, 200).tolist()
    for action in actions:
        state, reward, terminated, _, _ = reference.step(action)
        obs, obs_reward, obs_terminated, _, _ = env.step(action)
        assert (obs["state"], obs_reward, obs_terminated) == (state, reward, terminated)
        if terminated:
            reference.reset()
            env.reset()


def test_frozen_lake_slip_changed_at_run_time_equals_building_with_it():
    """Changing the slip vector mid-run equals an env built with it: no stale table."""
    changed = ns_pz.make_gym("ns_pz/FrozenLake-v0")
    built = ns_pz.make_gym("ns_pz/FrozenLake-v0", params={"slip": (1.0, 0.0, 0.0)})
    changed.reset(seed=2)
    built.reset(seed=2)
    changed.set_params(slip=(1.0, 0.0, 0.0))
    path = [2, 2, 1, 1, 1, 2]  # RIGHT RIGHT DOWN DOWN DOWN RIGHT reaches the goal if deterministic
    for action in path:
        a = changed.step(action)
        b = built.step(action)
        assert a[0]["state"] == b[0]["state"] and a[1:4] == b[1:4]
    assert a[1] == 1.0 and a[2] is True


def test_frozen_lake_map_arguments_are_checked():
    """Unknown maps and malformed custom maps raise clear errors."""
    with pytest.raises(ValueError, match=r"map_name='9x9' is not a map; allowed: \['4x4', '8x8'\]"):
        FrozenLakeFamily("9x9")
    with pytest.raises(ValueError, match="rows of different lengths"):
        FrozenLakeFamily(desc=["SF", "FFG"])
    with pytest.raises(ValueError, match=r"unknown cells \['X'\]"):
        FrozenLakeFamily(desc=["SX", "FG"])
    with pytest.raises(ValueError, match="no start cell"):
        FrozenLakeFamily(desc=["FF", "FG"])
    family = FrozenLakeFamily(desc=["SFG"])
    assert family.observation_space.n == 3


def test_outcome_structure_is_shared_between_snapshots():
    """Snapshots share the map's outcome arrays; only the probabilities follow θ."""
    family = FrozenLakeFamily("8x8")
    first = family.outcomes(FrozenLakeParams(slip=(1.0, 0.0, 0.0)))
    second = family.outcomes(FrozenLakeParams(slip=(0.5, 0.25, 0.25)))
    assert first.next_states is second.next_states and first.rewards is second.rewards
    assert first.probs.shape == (64, 4, 3) and first.probs.strides[1] == 0  # broadcast, no copy
    np.testing.assert_allclose(second.probs.sum(axis=2), 1.0)
    assert not first.next_states.flags.writeable


def test_slip_outcomes_are_oriented_as_documented():
    """Outcome k=1 is action+1 and k=2 action-1, checked against Gymnasium's own listing.

    Gymnasium's slippery table lists the moves in the order action-1, action, action+1.
    """
    family = FrozenLakeFamily("4x4")
    reference = gym.make("FrozenLake-v1").unwrapped.P
    for s in range(16):
        if family.is_terminal_state(s):
            continue
        for a in range(4):
            minus, straight, plus = (entry[1] for entry in reference[s][a])
            assert [family._table[s][a][k][0] for k in range(3)] == [straight, plus, minus]
    lake = ns_pz.make_gym("ns_pz/FrozenLake-v0", params={"slip": (0.0, 1.0, 0.0)})
    lake.reset(seed=0)
    assert lake.step(0)[0]["state"] == 4  # LEFT turned by +1 is DOWN
    lake = ns_pz.make_gym("ns_pz/FrozenLake-v0", params={"slip": (0.0, 0.0, 1.0)})
    lake.reset(seed=0)
    assert lake.step(2)[0]["state"] == 4  # RIGHT turned by -1 is DOWN


CLASSIC_IDS = [
    "ns_pz/CartPole-v0",
    "ns_pz/MountainCar-v0",
    "ns_pz/MountainCarContinuous-v0",
    "ns_pz/Acrobot-v0",
    "ns_pz/Pendulum-v0",
    "ns_pz/FrozenLake-v0",
    "ns_pz/CliffWalking-v0",
    "ns_pz/Bridge-v0",
]


def _deterministic_families() -> list:
    """The built-in classic and grid families that set ``deterministic_step``, with their θ_0."""
    found = []
    for env_id in CLASSIC_IDS:
        env = ns_pz.make_gym(env_id)
        env.reset(seed=0)
        if env.family.deterministic_step:
            found.append((env.family, env.planning_model().theta))
    return found


def test_a_family_that_says_its_step_is_deterministic_never_draws():
    """deterministic_step: 300 random steps leave the generator as it was; a repeat is equal."""
    families = _deterministic_families()
    for family, theta in families:
        rng = np.random.default_rng(3)
        family.action_space.seed(4)
        state = family.initial_state(np.random.default_rng(0))
        before = rng.bit_generator.state
        for _ in range(300):
            action = family.action_space.sample()
            if isinstance(family.action_space, gym.spaces.Discrete):
                action = int(action)
            outcome = family.step(state, action, theta, rng)
            assert family.step(state, action, theta, np.random.default_rng(9)) == outcome
            state = outcome[0] if not outcome[2] else family.initial_state(np.random.default_rng(1))
        assert rng.bit_generator.state == before, type(family).__name__
    assert len(families) == 4


def test_the_families_whose_steps_draw_do_not_say_they_are_deterministic():
    """Acrobot (torque noise) and the slip grids draw in their step."""
    flagged = {i for i in CLASSIC_IDS if ns_pz.make_gym(i).family.deterministic_step}
    assert flagged == {
        "ns_pz/CartPole-v0",
        "ns_pz/MountainCar-v0",
        "ns_pz/MountainCarContinuous-v0",
        "ns_pz/Pendulum-v0",
    }
