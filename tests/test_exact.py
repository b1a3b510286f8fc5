"""Exact solvers: backward induction, θ trajectories, the oracle and its baselines, robust VI."""

from __future__ import annotations

import itertools

import gymnasium
import numpy as np
import pytest
from ns_pz.agents import SnapshotValueIteration, mean_and_standard_error, run_episode
from ns_pz.agents.exact import (
    PolicyAgent,
    backward_induction,
    equal_split,
    evaluate_policy,
    initial_theta,
    oracle_agent,
    oracle_solution,
    policy_values,
    robust_backward_induction,
    robust_slip_solution,
    slip_intervals,
    snapshot_policy,
    stale_policy,
    start_value,
    theta_trajectory,
)
from ns_pz.envs.bridge import BridgeFamily, BridgeParams
from ns_pz.envs.frozen_lake import FrozenLakeParams

import ns_pz
from ns_pz.nature import (
    ContinuousScheduler,
    DiscreteScheduler,
    DistributionDecrementUpdate,
    DistributionIncrementUpdate,
    DistributionStepWiseUpdate,
    Nature,
    NatureConstraints,
    RandomNature,
    RandomScheduler,
    ScriptedNature,
)
from ns_pz.planning import TabularOutcomes


# -- backward induction ------------------------------------------------------------------------
def random_tables(rng: np.random.Generator, horizon: int, states: int, actions: int, k: int):
    """Time-varying tables on one random structure, some outcomes terminal."""
    next_states = rng.integers(states, size=(states, actions, k))
    rewards = rng.normal(size=(states, actions, k)).round(2)
    terminals = rng.random((states, actions, k)) < 0.25
    tables = []
    for _ in range(horizon):
        probs = rng.dirichlet(np.ones(k), size=(states, actions))
        tables.append(TabularOutcomes(probs, next_states, rewards, terminals))
    return tables


def recursive_value(tables, policy, t, state, gamma):
    """Expected return by enumerating every outcome path (no arrays, no backups)."""
    if t == len(tables):
        return 0.0
    table, action = tables[t], policy[t][state]
    total = 0.0
    for k in range(table.probs.shape[2]):
        after = 0.0
        if not table.terminals[state, action, k]:
            after = recursive_value(
                tables, policy, t + 1, table.next_states[state, action, k], gamma
            )
        total += table.probs[state, action, k] * (table.rewards[state, action, k] + gamma * after)
    return total


@pytest.mark.parametrize("gamma", [1.0, 0.9])
def test_backward_induction_matches_enumeration_of_every_policy(gamma):
    """On a 3-state, 2-action, 3-step problem: max over all 512 time-indexed policies."""
    tables = random_tables(np.random.default_rng(1), horizon=3, states=3, actions=2, k=2)
    solution = backward_induction(tables, gamma)
    best = np.full(3, -np.inf)
    for flat in itertools.product(range(2), repeat=9):
        policy = np.array(flat).reshape(3, 3)
        values = [recursive_value(tables, policy, 0, s, gamma) for s in range(3)]
        best = np.maximum(best, values)
        if flat[0] == 0:  # spot-check the exact policy evaluation on part of the policies
            np.testing.assert_allclose(evaluate_policy(tables, policy, gamma)[0], values)
    np.testing.assert_allclose(solution.values[0], best, rtol=0, atol=1e-12)
    np.testing.assert_allclose(evaluate_policy(tables, solution.policy, gamma), solution.values)
    assert solution.horizon == 3 and not solution.values[3].any()


def test_backward_induction_rejects_bad_input():
    """Bad tables, discounts and policies are refused with messages naming them."""
    table = random_tables(np.random.default_rng(0), 1, 2, 2, 2)[0]
    other = random_tables(np.random.default_rng(0), 1, 3, 2, 2)[0]
    with pytest.raises(ValueError, match=r"tables=\[\] is empty"):
        backward_induction([])
    with pytest.raises(TypeError, match="must be a sequence of TabularOutcomes"):
        backward_induction(table)
    with pytest.raises(TypeError, match=r"tables\[1\]=3 is not a TabularOutcomes"):
        backward_induction([table, 3])
    with pytest.raises(ValueError, match=r"tables\[1\] has shape \(3, 2, 2\)"):
        backward_induction([table, other])
    with pytest.raises(ValueError, match=r"gamma=1.5 must lie in \[0, 1\]"):
        backward_induction([table], gamma=1.5)
    with pytest.raises(ValueError, match=r"expected integer actions of shape \(1, 2\)"):
        evaluate_policy([table], np.zeros((2, 2), dtype=int))
    with pytest.raises(ValueError, match=r"actions outside 0..1"):
        evaluate_policy([table], np.full((1, 2), 2))


# -- θ trajectories ----------------------------------------------------------------------------
def single_change_env(env_id="ns_pz/FrozenLake-v0", base=0.7, new=0.4, first_step=1, **kwargs):
    """The paper's single change: p_0 = base, p -> new from transition ``first_step`` on (k)."""
    size = 4 if "Cliff" in env_id else 3
    rule = DistributionStepWiseUpdate(DiscreteScheduler({first_step}), [equal_split(new, size)])
    return ns_pz.make_gym(
        env_id,
        params={"slip": equal_split(base, size)},
        nature=ScriptedNature({"slip": rule}),
        **kwargs,
    )


@pytest.mark.parametrize(
    "nature, constraints",
    [
        (
            ScriptedNature(
                {"slip": DistributionDecrementUpdate(RandomScheduler(0.3, start=1), k=0.05)}
            ),
            None,
        ),
        (RandomNature(scale=0.1), NatureConstraints(lipschitz=0.03, budget=0.5)),
    ],
)
def test_theta_trajectory_is_the_one_a_played_episode_sees(nature, constraints):
    """Random natures too: replaying nature's turns gives the θ of every played transition."""
    env = ns_pz.make_gym(
        "ns_pz/CliffWalking-v0", nature=nature, constraints=constraints, ground_truth_info=True
    )
    rng = np.random.default_rng(5)
    for seed in (3, 4):
        thetas = theta_trajectory(env, seed)
        assert len(thetas) == 200
        env.reset(seed=seed)
        played, done, t = [], False, 0
        while not done and t < 60:
            _, _, terminated, truncated, info = env.step(int(rng.integers(4)))
            played.append(info["theta"]["slip"])
            if t == 2:  # replaying in the middle of an episode leaves the episode alone
                assert theta_trajectory(env, seed) == thetas
            done, t = terminated or truncated, t + 1
        assert played == [theta.slip for theta in thetas[: len(played)]]
        assert len(set(played)) > 2  # the trajectory did move


def test_theta_trajectory_through_gymnasium_make_and_its_refusals():
    """Through gymnasium.make the horizon is the view's own limit; bad input is refused."""
    nature = ScriptedNature({"slip": DistributionDecrementUpdate(ContinuousScheduler(1), 0.1)})
    wrapped = gymnasium.make("ns_pz/Bridge-v0", nature=nature)  # the view truncates by itself
    thetas = theta_trajectory(wrapped, 0)
    assert len(thetas) == 200 and thetas[0].slip[0] == 1.0
    assert thetas[3].slip[0] == pytest.approx(0.7)

    class FollowsTheAgent(Nature):
        def propose(self, t, theta, budget_left, memory, rng):
            return None

    env = ns_pz.make_gym("ns_pz/FrozenLake-v0", nature=FollowsTheAgent())
    with pytest.raises(TypeError, match="may make θ depend on the state or the agent"):
        theta_trajectory(env, 0)
    assert len(theta_trajectory(env, 0, 5, assume_open_loop=True)) == 5
    with pytest.raises(TypeError, match="seed=1.5 must be an int"):
        theta_trajectory(env, 1.5, assume_open_loop=True)
    with pytest.raises(ValueError, match="horizon=0 must be >= 1"):
        theta_trajectory(env, 0, 0, assume_open_loop=True)
    with pytest.raises(TypeError, match="is not an ns_pz environment"):
        theta_trajectory(object(), 0)


# -- oracle, snapshot, stale -------------------------------------------------------------------
def test_oracle_value_is_its_monte_carlo_mean_and_beats_stale_and_snapshot():
    """FrozenLake, p: 0.7 -> 0.4 at transition 1, H = 100."""
    env = single_change_env()
    family, thetas = env.family, theta_trajectory(env, 0)
    oracle, solution = oracle_agent(env, 0)
    exact = {
        "oracle": start_value(family, solution.values),
        "stale": start_value(
            family, policy_values(family, thetas, stale_policy(family, initial_theta(env), 100))
        ),
        "snapshot": start_value(
            family,
            policy_values(family, thetas, snapshot_policy(family, initial_theta(env), thetas)),
        ),
    }
    assert exact["oracle"] > exact["stale"] + 0.1 and exact["oracle"] >= exact["snapshot"]
    agents = {
        "oracle": (oracle, "none"),
        "stale": (SnapshotValueIteration(gamma=1.0, horizon=100), "none"),
        "snapshot": (SnapshotValueIteration(gamma=1.0, horizon=100), "detailed"),
    }
    means = {}
    for name, (agent, level) in agents.items():
        env = single_change_env(notification=level)
        returns = [run_episode(env, agent, seed).episode_return for seed in range(400)]
        mean, se = mean_and_standard_error(returns)
        assert abs(mean - exact[name]) < 4 * se, (name, mean, se, exact[name])
        means[name] = mean
    assert exact["oracle"] >= max(means["stale"], means["snapshot"]) - 0.02
    assert means["oracle"] > means["stale"]


def test_snapshot_agent_plays_the_snapshot_policy_step_by_step():
    """The agent at ``detailed`` (one-step lag) and snapshot_policy agree at every decision."""
    env = single_change_env(
        "ns_pz/CliffWalking-v0", base=1.0, new=0.6, goal_reward=100.0, notification="detailed"
    )
    thetas = theta_trajectory(env, 0)
    policy = snapshot_policy(env.family, initial_theta(env), thetas)
    stale = stale_policy(env.family, initial_theta(env), 200)
    assert (policy[1] != stale[1]).any() or (policy[2] != stale[2]).any()
    assert_agent_plays(env, SnapshotValueIteration(gamma=1.0, horizon=200), policy, seeds=3)


def assert_agent_plays(env, agent, policy, seeds, steps=60):
    """``agent`` picks ``policy[t, state]`` at every decision of ``seeds`` episodes."""
    agent.reset(np.random.default_rng(0))
    for seed in range(seeds):
        obs, _ = env.reset(seed=seed)
        for _ in range(steps):
            t, state = int(obs["relative_time"][0]), int(obs["state"])
            action = agent.act(obs, env.planning_model())
            assert action == policy[t, state], (seed, t, state)
            obs, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                break


def test_a_change_at_step_0_is_unknown_to_the_first_decision():
    """Bridge, p 1.0 -> 0.6 at step 0 (k = 0), γ = 0.9, H = 50.

    ``thetas[0]`` already holds p = 0.6, but before transition 0 every planner still knows only
    the θ at reset: the snapshot planner (``detailed``) crosses the bridge (RIGHT) on its first
    move, and so does the stale one, though for p = 0.6 the safe road (LEFT) is better. The
    exact values agree with played episodes; stale is not the oracle.
    """
    env = single_change_env(
        "ns_pz/Bridge-v0", 1.0, 0.6, first_step=0, max_episode_steps=50, notification="detailed"
    )
    family, thetas, theta0 = env.family, theta_trajectory(env, 0), initial_theta(env)
    assert thetas[0].slip == equal_split(0.6, 3) and theta0.slip == (1.0, 0.0, 0.0)
    start = family.start_states[0]
    policy = snapshot_policy(family, theta0, thetas, gamma=0.9)
    stale = stale_policy(family, theta0, 50, gamma=0.9)
    oracle = oracle_solution(family, thetas, gamma=0.9)
    assert policy[0, start] == stale[0, start] == 2 and oracle.policy[0, start] == 0
    assert_agent_plays(env, SnapshotValueIteration(gamma=0.9, horizon=50), policy, seeds=10)
    exact = {
        "snapshot": start_value(family, policy_values(family, thetas, policy, gamma=0.9)),
        "stale": start_value(family, policy_values(family, thetas, stale, gamma=0.9)),
    }
    assert max(exact.values()) < start_value(family, oracle.values) - 0.3
    for name, level in (("snapshot", "detailed"), ("stale", "none")):
        env = single_change_env(
            "ns_pz/Bridge-v0", 1.0, 0.6, first_step=0, max_episode_steps=50, notification=level
        )
        agent = SnapshotValueIteration(gamma=0.9, horizon=50)
        episodes = [run_episode(env, agent, seed) for seed in range(300)]
        # the Bridge pays only on entering a terminal cell, on the episode's last step
        returns = [e.episode_return * 0.9 ** (e.length - 1) for e in episodes]
        mean, se = mean_and_standard_error(returns)
        assert abs(mean - exact[name]) < 4 * se, (name, mean, se, exact[name])


def test_oracle_values_of_the_paper_single_change_settings_are_ordered():
    """Sanity of the optimum row: oracle >= snapshot >= ... and the deterministic CW path."""
    env = single_change_env("ns_pz/CliffWalking-v0", base=1.0, new=1.0, goal_reward=100.0)
    _, solution = oracle_agent(env, 0)
    assert start_value(env.family, solution.values) == pytest.approx(88.0)  # 13 moves, 100 - 12
    for new in (0.4, 0.6, 0.8):
        env = single_change_env("ns_pz/Bridge-v0", new=new)
        thetas = theta_trajectory(env, 0)
        value = start_value(env.family, oracle_solution(env.family, thetas).values)
        snap = start_value(
            env.family,
            policy_values(
                env.family, thetas, snapshot_policy(env.family, initial_theta(env), thetas)
            ),
        )
        assert -1.0 <= snap <= value <= 1.0


def test_policy_agent_and_snapshot_horizon_errors():
    """Policies of the wrong shape and episodes past the horizon are refused."""
    with pytest.raises(
        ValueError, match=r"expected integer actions of shape \(horizon, num_states\)"
    ):
        PolicyAgent(np.zeros(4))
    agent = PolicyAgent(np.zeros((2, 16), dtype=np.int64))
    obs = {"state": 3, "relative_time": np.array([2.0], np.float32)}
    with pytest.raises(ValueError, match="relative_time=2 is beyond the policy's horizon 2"):
        agent.act(obs)
    with pytest.raises(ValueError, match="horizon=0 must be >= 1"):
        SnapshotValueIteration(horizon=0)
    with pytest.raises(
        ValueError, match=r"gamma=1.0 must lie in \[0, 1\) \(or \[0, 1\] with a horizon\)"
    ):
        SnapshotValueIteration(gamma=1.0)
    env = single_change_env()
    obs, _ = env.reset(seed=0)
    obs["relative_time"][0] = 5
    with pytest.raises(ValueError, match="relative_time=5 is beyond horizon=5"):
        SnapshotValueIteration(gamma=1.0, horizon=5).act(obs, env.planning_model())


# -- robust value iteration --------------------------------------------------------------------
def test_slip_intervals_follow_lipschitz_budget_and_bounds():
    """Radius L per nature move, capped by the budget, clipped to [low, high]."""
    lo, hi = slip_intervals(0.7, 6, lipschitz=0.1, budget=0.25, low=0.3, first_change_step=1)
    np.testing.assert_allclose(lo, [0.7, 0.6, 0.5, 0.45, 0.45, 0.45])
    np.testing.assert_allclose(hi, [0.7, 0.8, 0.9, 0.95, 0.95, 0.95])
    lo, hi = slip_intervals(0.7, 3, low=0.4, high=0.8)  # no Lipschitz bound: the interval
    np.testing.assert_allclose(lo, [0.4] * 3)
    np.testing.assert_allclose(hi, [0.8] * 3)
    with pytest.raises(ValueError, match="lipschitz=-0.1 must be a finite number >= 0"):
        slip_intervals(0.7, 3, lipschitz=-0.1)
    with pytest.raises(ValueError, match=r"low=0.9 must be <= high=0.8"):
        slip_intervals(0.7, 3, low=0.9, high=0.8)
    with pytest.raises(ValueError, match=r"p0=1.2 must lie in \[0, 1\]"):
        slip_intervals(1.2, 3)
    with pytest.raises(ValueError, match="first_change_step=-1 must be >= 0"):
        slip_intervals(0.7, 3, first_change_step=-1)


def test_endpoints_suffice_for_the_robust_backup():
    """Nature choosing among 11 slip values in [lo, hi] is no worse than the two endpoints."""
    family = BridgeFamily()
    ends = [family.outcomes(BridgeParams(slip=equal_split(p, 3))) for p in (0.3, 0.9)]
    grid = [
        family.outcomes(BridgeParams(slip=equal_split(p, 3))) for p in np.linspace(0.3, 0.9, 11)
    ]
    by_ends = robust_backward_induction([ends] * 30)
    by_grid = robust_backward_induction([grid] * 30)
    np.testing.assert_allclose(by_ends.values, by_grid.values, atol=1e-12)
    middle = robust_backward_induction([grid[3:8]] * 30)  # a smaller set: a larger guarantee
    assert (middle.values[0] >= by_ends.values[0] - 1e-12).all()
    assert (middle.values[0] > by_ends.values[0] + 1e-6).any()


@pytest.mark.parametrize(
    "env_id", ["ns_pz/FrozenLake-v0", "ns_pz/Bridge-v0", "ns_pz/CliffWalking-v0"]
)
def test_robust_value_is_below_every_nature_inside_the_bound(env_id):
    """Lipschitz 0.05 per step from θ_0: natures inside never push the robust policy below V."""
    size, p0 = (4, 0.9) if "Cliff" in env_id else (3, 0.7)
    horizon, lipschitz = 40, 0.05
    kwargs = {"goal_reward": 100.0} if "Cliff" in env_id else {}
    theta0 = {"slip": equal_split(p0, size)}
    family = ns_pz.make_gym(env_id, **kwargs).family
    robust = robust_slip_solution(family, family.params_cls(**theta0), horizon, lipschitz=lipschitz)
    natures = [
        ScriptedNature({"slip": DistributionDecrementUpdate(ContinuousScheduler(0), 1.0)}),
        ScriptedNature({"slip": DistributionIncrementUpdate(ContinuousScheduler(0), 1.0)}),
        ScriptedNature({"slip": DistributionDecrementUpdate(RandomScheduler(0.5, start=0), 0.05)}),
        ScriptedNature(
            {"slip": DistributionStepWiseUpdate(DiscreteScheduler({5}), [equal_split(0.0, size)])}
        ),
    ]
    constraints = NatureConstraints(lipschitz=lipschitz)
    for nature in natures:
        env = ns_pz.make_gym(
            env_id, params=theta0, nature=nature, constraints=constraints, **kwargs
        )
        thetas = theta_trajectory(env, 1, horizon)
        achieved = policy_values(family, thetas, robust.policy)
        best = oracle_solution(family, thetas).values
        assert (robust.values <= achieved + 1e-9).all()
        assert (achieved <= best + 1e-9).all()
    # A nature twice as fast breaks the guarantee somewhere: the test can fail.
    env = ns_pz.make_gym(
        env_id,
        params=theta0,
        nature=natures[0],
        constraints=NatureConstraints(lipschitz=0.1),
        **kwargs,
    )
    thetas = theta_trajectory(env, 1, horizon)
    assert (policy_values(family, thetas, robust.policy)[0] < robust.values[0] - 1e-6).any()


def test_robust_interval_without_lipschitz():
    """A fixed interval [0.5, 0.9]: the ends and θ_0 itself never go below the guarantee."""
    family = ns_pz.make_gym("ns_pz/FrozenLake-v0").family
    theta0 = FrozenLakeParams(slip=equal_split(0.7, 3))
    robust = robust_slip_solution(family, theta0, 50, low=0.5, high=0.9)
    for p in (0.5, 0.7, 0.9):
        achieved = policy_values(
            family, [FrozenLakeParams(slip=equal_split(p, 3))] * 50, robust.policy
        )
        assert (robust.values <= achieved + 1e-9).all()
    with pytest.raises(TypeError, match="is not tabular"):
        robust_slip_solution(ns_pz.make_gym("ns_pz/CartPole-v0").family, theta0, 5)


def test_robust_refuses_theta0_off_the_equal_split_line():
    """Bridge θ_0 = (0.7, 0.3, 0), budget 0.3: the old solver's guarantee was false.

    It "guaranteed" 0.64 from state 8 over 3 steps, while a nature that jumps to (0.4, 0.6, 0)
    (TV 0.3, inside the budget) gets 0.496. Off the line nature's set is no segment; the solver
    refuses such a θ_0 and names it. Rounding on the line is accepted.
    """
    family = BridgeFamily()
    with pytest.raises(ValueError, match=r"theta0.slip=\(0.7, 0.3, 0.0\) is off the equal-split"):
        robust_slip_solution(family, BridgeParams(slip=(0.7, 0.3, 0.0)), 3, budget=0.3)
    with pytest.raises(ValueError, match=r"accepts only slip vectors \[p, \(1-p\)/2, ...\]"):
        robust_slip_solution(family, BridgeParams(slip=(0.7, 0.2, 0.1)), 3, budget=0.3)
    robust_slip_solution(family, BridgeParams(slip=(0.7, 0.15, 0.15)), 3, budget=0.3)


def test_robust_guarantee_holds_for_every_nature_schedule_of_a_small_instance():
    """Bridge, θ_0 on the line at p = 0.7, H = 5, L = 0.1, budget 0.3, nature from step 0.

    Brute force over every schedule moving p by -0.1, -0.05, 0, 0.05 or 0.1 per step within the
    budget (1,893 schedules): none gets the robust policy below its guaranteed value at any
    state, and the worst of them reaches the guarantee at the start. A nature with the same
    per-step and total TV that leaves the line (mass to one slip outcome only) gets below it.
    """
    family, horizon = BridgeFamily(), 5
    theta0 = BridgeParams(slip=equal_split(0.7, 3))
    robust = robust_slip_solution(family, theta0, horizon, lipschitz=0.1, budget=0.3)
    worst = np.full(robust.values.shape[1], np.inf)
    schedules = 0
    for steps in itertools.product(range(-2, 3), repeat=horizon):  # in units of 0.05
        if sum(map(abs, steps)) > 6:  # budget 0.3
            continue
        p_values = [min(1.0, round(0.7 + 0.05 * k, 12)) for k in np.cumsum(steps)]
        thetas = [BridgeParams(slip=equal_split(p, 3)) for p in p_values]
        worst = np.minimum(worst, policy_values(family, thetas, robust.policy)[0])
        schedules += 1
    assert schedules == 1893
    assert (worst >= robust.values[0] - 1e-9).all()
    start = family.start_states[0]
    assert worst[start] == pytest.approx(robust.values[0, start], abs=1e-9)
    off_line = [(0.6, 0.15, 0.25), (0.5, 0.15, 0.35), (0.4, 0.25, 0.35)]  # TV 0.1 per step
    thetas = [BridgeParams(slip=v) for v in off_line + off_line[-1:] * 2]
    achieved = policy_values(family, thetas, robust.policy)[0]
    assert (achieved < robust.values[0] - 0.04).any()


def test_theta_trajectory_starts_from_the_episodes_own_theta0() -> None:
    """``reset(options={"params": ...})``: the trajectory (and so the oracle) starts there.

    It started from the env's default θ_0, so the "exact optimum" was another episode's.
    """
    from ns_pz.agents.exact.regret_reference import recorded_thetas

    from ns_pz.nature import DiscreteScheduler, TrajectoryNature
    from ns_pz.nature.distribution_updates import DistributionStepWiseUpdate

    nature = ScriptedNature(
        {"slip": DistributionStepWiseUpdate(DiscreteScheduler({5}), [equal_split(0.5, 3)])}
    )
    env = gymnasium.make("ns_pz/FrozenLake-v0", nature=nature, max_episode_steps=30).unwrapped
    env.reset(seed=0, options={"params": {"slip": equal_split(0.95, 3)}})
    planned = theta_trajectory(env, 0, np.int64(30))
    for _ in range(30):
        *_, terminated, truncated, _ = env.step(0)
        if terminated or truncated:
            break
    assert list(planned) == recorded_thetas(env.process, 30)
    assert planned[0].slip[0] == 0.95 and planned[5].slip[0] == 0.5
    truth = env.ground_truth()
    replayed = gymnasium.make(
        "ns_pz/FrozenLake-v0",
        nature=TrajectoryNature(truth.change_times, truth.change_values),
        params={"slip": equal_split(0.95, 3)},
        max_episode_steps=30,
    )
    assert theta_trajectory(replayed, 0) == planned  # a replayed trajectory is open-loop
