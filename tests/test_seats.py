"""single_agent: every seat as a Gymnasium env; PolicyNature/PolicyMonitor; regret; budgets seen."""

from __future__ import annotations

import math

import numpy as np
import pytest
from gymnasium import spaces
from gymnasium.utils.env_checker import check_env
from ns_pz.agents import SnapshotValueIteration
from ns_pz.agents.exact import OracleReference

import ns_pz
from ns_pz import DECISION, MONITOR, NATURE
from ns_pz.monitor import PolicyMonitor
from ns_pz.nature import NatureConstraints, PolicyNature
from ns_pz.regret import ReplayReference

LAKE = {"params": {"slip": (0.9, 0.05, 0.05)}, "notification": "detailed"}
BOUNDED = NatureConstraints(lipschitz=0.1, budget=0.5)


def push_left(obs):
    """A CartPole controller that always pushes left (any deterministic policy will do)."""
    return 0


def balance(obs):
    """A CartPole controller that balances the stationary pole: push towards the pole's lean."""
    state = obs["state"]
    return int(state[2] + 0.5 * state[3] > 0)


def lean_nature(obs):
    """A nature that always asks for the most of every parameter (normalised action +1)."""
    return np.ones(6, np.float32)


# check_env's advice, expected here: the seats are built without gym.make (no spec to test
# render modes through), and CartPole's state, which nature and the monitor observe, has
# unbounded velocities, as in Gymnasium's own CartPole.
@pytest.mark.filterwarnings("ignore:.*not having a spec:UserWarning")
@pytest.mark.filterwarnings("ignore:.*minimum value is -infinity:UserWarning")
@pytest.mark.filterwarnings("ignore:.*maximum value is infinity:UserWarning")
def test_every_seat_passes_gymnasiums_checker():
    """Nature (also state-aware) and monitor seats are valid Gymnasium envs, seeded by reset."""
    vi = SnapshotValueIteration(gamma=0.99)
    check_env(ns_pz.single_agent("ns_pz/FrozenLake-v0", "nature", {DECISION: vi}, **LAKE))
    check_env(
        ns_pz.single_agent(
            "ns_pz/CartPole-v0",
            "nature",
            {DECISION: balance},
            nature_observes_state=True,
            constraints=NatureConstraints(budget={"masspole": 0.5}),
        )
    )
    check_env(
        ns_pz.single_agent(
            "ns_pz/CartPole-v0",
            "monitor",
            {DECISION: balance},
            monitor_reward=lambda process, flags: -float(sum(flags)),
            notification="basic",
        )
    )
    assert isinstance(ns_pz.single_agent("ns_pz/CartPole-v0"), ns_pz.NSGymEnv)


def test_sb3_checker_accepts_the_nature_and_monitor_seats():
    """Stable-Baselines3's own checker (when installed) accepts both learner seats."""
    sb3_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    nature = ns_pz.single_agent("ns_pz/CartPole-v0", "nature", {DECISION: balance})
    sb3_checker.check_env(nature, warn=False)
    monitor = ns_pz.single_agent(
        "ns_pz/FrozenLake-v0",
        "monitor",
        {DECISION: lambda obs: 0},
        monitor_reward=lambda process, flags: 0.0,
    )
    sb3_checker.check_env(monitor, warn=False)


def test_nature_observation_is_finite_and_shows_budgets_left():
    """No inf without a budget; the budget fractions fall as nature spends."""
    env = ns_pz.single_agent("ns_pz/FrozenLake-v0", "nature", {DECISION: lambda o: 1}, **LAKE)
    obs, _ = env.reset(seed=0)
    assert np.isfinite(obs).all() and obs[-1] == 0.0  # no budget: flag 0, fractions 1
    env = ns_pz.single_agent(
        "ns_pz/FrozenLake-v0",
        "nature",
        {DECISION: lambda o: 1},
        constraints=BOUNDED,
        **LAKE,
    )
    obs, _ = env.reset(seed=0)
    assert obs[-1] == 1.0 and obs[4] == 1.0  # total budget whole
    obs, *_ = env.step(np.array([-1.0, 1.0, 0.0], np.float32))
    # slip moves by the Lipschitz bound 0.1 (total variation): 0.1 of the 0.5 budget is spent
    assert obs[4] == pytest.approx(0.8)
    assert env.ground_truth().theta.slip == pytest.approx((0.8, 0.15, 0.05))
    assert obs[0] == pytest.approx(1 / 100)  # t over the time limit


def test_normalized_actions_move_by_the_allowance():
    """+1 moves a scalar by its Lipschitz bound, or by 1 % of its θ_0 value without one."""
    env = ns_pz.single_agent(
        "ns_pz/CartPole-v0",
        "nature",
        {DECISION: push_left},
        constraints=NatureConstraints(lipschitz={"masspole": 0.05}),
    )
    env.reset(seed=0)
    action = np.zeros(6, np.float32)
    action[[0, 2]] = 1.0  # gravity and masspole
    env.step(action)
    theta = env.ground_truth().theta
    assert theta.masspole == pytest.approx(0.15) and theta.gravity == pytest.approx(9.8 * 1.01)
    with pytest.raises(ValueError, match="outside the action space"):
        env.step(np.full(6, 1.5, np.float32))
    env.step(np.zeros(6, np.float32))
    assert env.ground_truth().change_times == (0,)


def test_policy_nature_replays_what_the_learner_seat_did():
    """A policy trained in nature's seat acts identically when put back into the view."""
    rng_actions = [np.random.default_rng(7).uniform(-1, 1, 6).astype(np.float32)]

    def wobbly(obs):
        """A deterministic function of the observation."""
        return np.tanh(rng_actions[0] * (1.0 + obs[0] * 5.0)).astype(np.float32)

    seat = ns_pz.single_agent("ns_pz/CartPole-v0", "nature", {DECISION: balance})
    obs, _ = seat.reset(seed=3)
    nature_total, done = 0.0, False
    while not done:
        obs, reward, terminated, truncated, _ = seat.step(wobbly(obs))
        nature_total += reward
        done = terminated or truncated
    view = ns_pz.make_gym("ns_pz/CartPole-v0", nature=PolicyNature(wobbly))
    obs, _ = view.reset(seed=3)
    agent_total, done = 0.0, False
    while not done:
        obs, reward, terminated, truncated, _ = view.step(balance(obs))
        agent_total += reward
        done = terminated or truncated
    assert view.ground_truth() == seat.ground_truth()
    assert len(seat.ground_truth().change_times) > 10
    assert nature_total == -agent_total


def test_the_game_and_the_seat_agree_for_a_policy_nature():
    """The game with PolicyNature (normalised actions) gives the same θ path as the seat env."""
    game = ns_pz.make(
        "ns_pz/CartPole-v0", nature=PolicyNature(lean_nature), nature_action="normalized"
    )
    game.reset(seed=1)
    seat = ns_pz.single_agent("ns_pz/CartPole-v0", "nature", {DECISION: push_left})
    obs, _ = seat.reset(seed=1)
    for _ in range(5):
        game_obs = game.observe(NATURE)
        assert np.array_equal(game_obs, obs)
        game.step(game.policy_action(NATURE))
        game.step(game.policy_action(MONITOR))
        game.step(0)
        obs, *_ = seat.step(lean_nature(obs))
    assert game.ground_truth() == seat.ground_truth()


def test_monitor_seat_pays_the_given_reward_and_its_flags_reach_the_agent():
    """The monitor learner's flags become the agent's notification; PolicyMonitor agrees."""
    seen = []

    def agent(obs):
        seen.append(obs["env_change"].tolist())
        return 0

    def alarm_on_odd(obs):
        return np.array([int(obs["relative_time"][0]) % 2], np.int64)

    env = ns_pz.single_agent(
        "ns_pz/FrozenLake-v0",
        "monitor",
        {DECISION: agent},
        monitor_reward=lambda process, flags: -float(flags[0]),
        notification="basic",
    )
    obs, _ = env.reset(seed=0)
    rewards = []
    for _ in range(4):
        obs, reward, terminated, truncated, _ = env.step(alarm_on_odd(obs))
        rewards.append(reward)
        if terminated or truncated:
            break
    assert seen[: len(rewards)] == [[t % 2] for t in range(len(rewards))]
    assert rewards == [-float(t % 2) for t in range(len(rewards))]
    view = ns_pz.make_gym(
        "ns_pz/FrozenLake-v0", monitor=PolicyMonitor(alarm_on_odd), notification="basic"
    )
    obs, _ = view.reset(seed=0)
    assert obs["env_change"].tolist() == [0]
    obs, *_ = view.step(0)
    assert obs["env_change"].tolist() == [1]


@pytest.mark.parametrize(
    "flags",
    [
        [2, 0, 0, 0, 0, 0],
        [1, 0, 0, 0, 0],
        [-1, 0, 0, 0, 0, 0],
        np.ones(6) * 0.5,
        np.ones(6),
        np.ones(6, object),
        np.ones(6, complex),
        "1",
    ],
)
def test_monitor_flags_must_be_zeros_and_ones(flags):
    """The monitor seat takes integer or bool 0/1 flags, one per parameter.

    PolicyMonitor also takes floats and Python objects equal to 0 or 1 (not complex numbers).
    """
    env = ns_pz.single_agent(
        "ns_pz/CartPole-v0", "monitor", {DECISION: lambda obs: 0}, monitor_reward="detection"
    )
    env.reset(seed=0)
    with pytest.raises(ValueError, match="must be 6 flags of 0/1"):
        env.step(flags)
    env.step(np.array([True, False, True, False, False, False]))
    view = ns_pz.make_gym(
        "ns_pz/CartPole-v0", monitor=PolicyMonitor(lambda obs: flags), notification="basic"
    )
    if isinstance(flags, np.ndarray) and flags.dtype.kind in "fO" and (flags == 1.0).all():
        view.reset(seed=0)
        assert view.step(0)[0]["env_change"].tolist() == [1] * 6
    else:
        with pytest.raises(ValueError, match="must give 6 flags of 0/1"):
            view.reset(seed=0)


def test_seeds_reproduce_every_seat():
    """Same seed, same actions: same observations and ground truth (the agent seat too)."""

    def run(seed):
        env = ns_pz.single_agent(
            "ns_pz/FrozenLake-v0",
            "nature",
            {DECISION: lambda o: int(o["state"]) % 4},
            constraints=BOUNDED,
            **LAKE,
        )
        obs, _ = env.reset(seed=seed)
        trace = [obs]
        for action in np.random.default_rng(0).uniform(-1, 1, (30, 3)):
            obs, reward, terminated, truncated, _ = env.step(action.astype(np.float32))
            trace.append((obs, reward))
            if terminated or truncated:
                break
        return trace, env.ground_truth()

    first, again, other = run(4), run(4), run(5)
    assert str(first) == str(again) and str(first) != str(other)


def test_regret_pays_the_oracle_value_minus_the_agent_return():
    """Nature's episode total under "regret" is the exact oracle value minus the agent's return."""
    vi = SnapshotValueIteration(gamma=1.0, horizon=20)
    env = ns_pz.single_agent(
        "ns_pz/FrozenLake-v0",
        "nature",
        {DECISION: vi},
        nature_reward="regret",
        constraints=BOUNDED,
        max_episode_steps=20,
        **LAKE,
    )
    for seed in range(3):
        obs, _ = env.reset(seed=seed)
        total, agent_return, done = 0.0, 0.0, False
        while not done:
            obs, reward, terminated, truncated, _ = env.step(np.array([-1, 1, 0], np.float32))
            total += reward
            done = terminated or truncated
            agent_return += env.process.last_reward
        oracle = OracleReference()(env.process)
        assert 0.0 < oracle <= 1.0
        assert total == pytest.approx(oracle - agent_return)


def _self_replay_regret_seat(**env_kwargs):
    """Nature's seat on CartPole, paid the balancing agent's regret against its own replay."""
    return ns_pz.single_agent(
        "ns_pz/CartPole-v0",
        "nature",
        {DECISION: balance},
        nature_reward="regret",
        regret_reference=ReplayReference(balance),
        **env_kwargs,
    )


def test_replay_reference_of_the_agent_itself_has_no_regret_on_a_deterministic_env():
    """Replaying the agent's own policy on deterministic CartPole gives exactly its return."""
    env = _self_replay_regret_seat(max_episode_steps=100)
    obs, _ = env.reset(seed=0)
    total, done = 0.0, False
    while not done:
        obs, reward, terminated, truncated, _ = env.step(lean_nature(obs))
        total += reward
        done = terminated or truncated
    assert len(env.ground_truth().change_times) > 0 and total == 0.0
    with pytest.raises(ValueError, match="not tabular"):
        ns_pz.single_agent(
            "ns_pz/CartPole-v0", "nature", {DECISION: balance}, nature_reward="regret"
        )


@pytest.mark.parametrize(
    ("learner", "policies", "kwargs", "match"),
    [
        ("adversary", {}, {}, "learner='adversary'"),
        ("nature", {}, {}, r"policies\['agent'\] is needed"),
        ("nature", {"agent": balance, "nature": lean_nature}, {}, "'nature' is the learner"),
        ("agent", {"natur": lean_nature}, {}, "seat 'natur'"),
        ("monitor", {"agent": balance}, {}, "monitor_reward=None"),
        ("nature", {"agent": 3}, {}, "cannot drive the agent seat"),
        # an option outside its values, whoever learns
        ("agent", {}, {"nature_reward": "bogus"}, "nature_reward='bogus'"),
        ("agent", {}, {"nature_action": "bogus"}, "nature_action='bogus'"),
        ("nature", {"agent": balance}, {"monitor_reward": "bogus"}, "monitor_reward='bogus'"),
        ("agent", {}, {"nature_observes_state": "no"}, "nature_observes_state='no'"),
        ("agent", {}, {"default_step": 5}, "default_step=5"),
        ("agent", {}, {"deterministic": "no"}, "deterministic='no'"),
        # a schedule for the seat that learns, or a seat given twice
        ("nature", {"agent": balance}, {"nature": ns_pz.nature.RandomNature()}, "is the learner"),
        (
            "monitor",
            {"agent": balance},
            {"monitor": ns_pz.monitor.OracleMonitor(), "monitor_reward": "detection"},
            "is the learner",
        ),
        (
            "agent",
            {"nature": lean_nature},
            {"nature": ns_pz.nature.RandomNature()},
            "both say who plays 'nature'",
        ),
        # options for a seat they would not reach
        ("agent", {}, {"nature_reward": "cooperative"}, "apply only when nature learns"),
        ("agent", {}, {"monitor_reward": "detection"}, "only when the monitor learns"),
        ("nature", {"agent": balance}, {"monitor_reward": "detection"}, "monitor learns"),
        ("monitor", {"agent": balance}, {"nature_reward": "regret"}, "nature learns"),
        ("agent", {}, {"nature_action": "delta"}, "apply only to a learning nature"),
        (
            "agent",
            {"nature": PolicyNature(lean_nature)},
            {"nature_action": "delta"},
            r"nature_action='delta' \(its own: 'normalized'\)",
        ),
    ],
)
def test_single_agent_refuses_bad_seats(learner, policies, kwargs, match):
    """Bad seats, missing or unusable policies, options out of range or unheard: clear errors."""
    with pytest.raises((ValueError, TypeError), match=match):
        ns_pz.single_agent("ns_pz/CartPole-v0", learner, policies, **kwargs)


def test_seat_options_that_reach_their_seat_are_taken():
    """Conventions for a bare nature policy, or matching a PolicyNature's own, are accepted."""
    for policy in (lean_nature, PolicyNature(lean_nature, observes_state=True)):
        env = ns_pz.single_agent(
            "ns_pz/CartPole-v0", "agent", {NATURE: policy}, nature_observes_state=True
        )
        env.reset(seed=0)
        env.step(0)
    # A PolicyNature of another convention, the options left at their defaults: its own rule.
    delta = PolicyNature(lambda obs: np.zeros(6), action="delta")
    ns_pz.single_agent("ns_pz/CartPole-v0", "agent", {NATURE: delta}).reset(seed=0)


def test_a_stateful_monitor_reward_is_copied_per_environment():
    """One DetectionReward handed to several seat envs: each keeps its own episode state."""
    from ns_pz.monitor import DetectionReward
    from ns_pz.seats import DetectionReward as old_home

    assert old_home is DetectionReward  # still importable where it lived

    shared = DetectionReward(2.0)
    kwargs = {"notification": "basic", "monitor_reward": shared}
    envs = [ns_pz.single_agent("ns_pz/CartPole-v0", MONITOR, {DECISION: balance}, **kwargs)]
    envs.append(ns_pz.single_agent("ns_pz/CartPole-v0", MONITOR, {DECISION: balance}, **kwargs))
    rewards = [env.unwrapped._monitor_reward for env in envs]
    assert rewards[0] is not shared and rewards[1] is not shared and rewards[0] is not rewards[1]
    assert rewards[0].false_alarm_cost == 2.0


def test_learner_seats_render_and_report_the_ground_truth():
    """render_mode and ground_truth_info reach a learner seat's env, as they do the view."""
    lake = ns_pz.single_agent(
        "ns_pz/FrozenLake-v0",
        NATURE,
        {DECISION: lambda obs: 1},
        render_mode="ansi",
        ground_truth_info=True,
        **LAKE,
    )
    assert lake.render_mode == "ansi" and "ansi" in lake.metadata["render_modes"]
    _, info = lake.reset(seed=0)
    assert isinstance(lake.render(), str) and set(info["theta"]) == {"slip"}
    _, _, _, _, info = lake.step(np.ones(lake.action_space.shape, np.float32))
    assert info["theta"]["slip"] == lake.unwrapped.process.last_theta.slip
    frames = ns_pz.single_agent(
        "ns_pz/FrozenLake-v0",
        MONITOR,
        {DECISION: lambda obs: 1},
        monitor_reward="detection",
        render_mode="rgb_array",
        **LAKE,
    )
    frames.reset(seed=0)
    frame = frames.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3
    with pytest.raises(ValueError, match="render_mode"):
        ns_pz.single_agent("ns_pz/CartPole-v0", NATURE, {DECISION: balance}, render_mode="ansi")


def test_policy_nature_and_monitor_refuse_bad_arguments():
    """Types are checked when the policy is built, not at its first move."""
    with pytest.raises(TypeError, match="observes_state='no'"):
        PolicyNature(lean_nature, observes_state="no")
    with pytest.raises(ValueError, match="default_step=5"):
        PolicyNature(lean_nature, default_step=5)
    with pytest.raises(TypeError, match="deterministic='no'"):
        PolicyNature(lean_nature, deterministic="no")
    with pytest.raises(TypeError, match=r"PolicyNature\(policy\)=None"):
        PolicyNature(None)
    with pytest.raises(TypeError, match="deterministic=1"):
        PolicyMonitor(push_left, deterministic=1)
    with pytest.raises(TypeError, match=r"PolicyMonitor\(policy\)=3"):
        PolicyMonitor(3)


class _Spaced:
    """A policy that carries its own spaces, as an SB3 model does."""

    def __init__(self, observation_space, action_space):
        self.observation_space = observation_space
        self.action_space = action_space

    def predict(self, observation, deterministic=True):
        return self.action_space.sample() * 0, None


def test_a_policy_trained_in_other_spaces_is_refused_at_its_first_move():
    """A model of another action convention, observation or family is refused, not misread.

    A nature model of the delta convention (or without the state) put in as normalised, or a
    monitor model of another family.
    """
    seat = ns_pz.single_agent(
        "ns_pz/CartPole-v0", NATURE, {DECISION: balance}, nature_action="delta"
    )
    delta_model = _Spaced(seat.observation_space, seat.action_space)
    view = ns_pz.single_agent("ns_pz/CartPole-v0", DECISION, {NATURE: PolicyNature(delta_model)})
    with pytest.raises(ValueError, match=r"(?s)action space Box.*action='normalized'"):
        view.reset(seed=0)
    seen = ns_pz.single_agent(
        "ns_pz/CartPole-v0", NATURE, {DECISION: balance}, nature_observes_state=True
    )
    state_model = _Spaced(seen.observation_space, seen.action_space)
    view = ns_pz.single_agent("ns_pz/CartPole-v0", DECISION, {NATURE: PolicyNature(state_model)})
    with pytest.raises(ValueError, match="observation space"):
        view.reset(seed=0)
    matching = PolicyNature(delta_model, action="delta")
    ns_pz.single_agent("ns_pz/CartPole-v0", DECISION, {NATURE: matching}).reset(seed=0)
    monitor = ns_pz.single_agent(
        "ns_pz/FrozenLake-v0", MONITOR, {DECISION: lambda obs: 1}, monitor_reward="detection"
    )
    lake_monitor = PolicyMonitor(_Spaced(monitor.observation_space, monitor.action_space))
    with pytest.raises(ValueError, match="PolicyMonitor's policy"):
        ns_pz.single_agent("ns_pz/CartPole-v0", DECISION, {MONITOR: lake_monitor}).reset(seed=0)


def test_learner_agent_gets_policy_nature_and_monitor():
    """learner="agent" is the usual view, with the other seats played by the given policies."""
    env = ns_pz.single_agent(
        "ns_pz/CartPole-v0", "agent", {NATURE: lean_nature}, notification="detailed"
    )
    obs, _ = env.reset(seed=0)
    obs, *_ = env.step(0)
    obs, *_ = env.step(0)
    assert obs["env_change"].all() and math.isclose(obs["delta_change"][2], 0.001, rel_tol=1e-3)


def test_the_game_pays_nature_its_regret_at_the_end():
    """In the game, nature's cumulative reward is the oracle's value minus the agent's return."""
    game = ns_pz.make(
        "ns_pz/FrozenLake-v0",
        nature_reward="regret",
        nature_action="normalized",
        constraints=BOUNDED,
        max_episode_steps=15,
        **LAKE,
    )
    game.reset(seed=2)
    totals = dict.fromkeys(game.possible_agents, 0.0)
    for agent in game.agent_iter():
        _, reward, terminated, truncated, _ = game.last()
        totals[agent] += reward
        if terminated or truncated:
            game.step(None)
        elif agent == NATURE:
            game.step(np.array([-1.0, 0.0, 1.0], np.float32))
        elif agent == MONITOR:
            game.step(game.policy_action(MONITOR))
        else:
            game.step(2)
    oracle = OracleReference()(game.process)
    assert totals[NATURE] == pytest.approx(oracle - totals[DECISION])
    assert oracle > totals[DECISION]


def test_a_monitor_seat_paid_by_detection_scores_delay_and_false_alarms():
    """monitor_reward="detection": -1 per undetected step, -λ per false alarm (t = 0 too)."""
    from ns_pz.nature import DiscreteScheduler, ScriptedNature, StepWiseUpdate

    nature = ScriptedNature({"masspole": StepWiseUpdate(DiscreteScheduler({3}), [0.5])})
    env = ns_pz.single_agent(
        "ns_pz/CartPole-v0",
        "monitor",
        {DECISION: balance},
        monitor_reward="detection",
        nature=nature,
        notification="basic",
    )
    env.reset(seed=0)
    alarm, quiet = np.ones(6, np.int64), np.zeros(6, np.int64)
    # turn t speaks of transition t-1; the change hits transition 3, detected at turn 6
    plan = [alarm, quiet, quiet, quiet, quiet, quiet, alarm, quiet]
    rewards = [env.step(flags)[1] for flags in plan]
    assert rewards == [-10.0, 0.0, 0.0, 0.0, -1.0, -1.0, 0.0, 0.0]
    env.reset(seed=0)
    assert env.step(quiet)[1] == 0.0  # nothing pending after a reset


def _random_lake_nature():
    """A nature that draws from its generator (when and how θ moves), so streams are exercised."""
    from ns_pz.nature import RandomCategorical, RandomScheduler, ScriptedNature

    return ScriptedNature({"slip": RandomCategorical(RandomScheduler(probability=0.4, start=1))})


def _lake_policy(obs):
    """A deterministic decision policy that reads the state and the notification."""
    return (int(obs["state"]) + int(obs["env_change"][0]) + int(obs["relative_time"][0])) % 4


def test_one_seed_gives_one_trajectory_through_the_view_the_game_and_the_agent_seat():
    """Slippery lake, a random nature, detailed notices: the three drivers see the same episode."""
    kwargs = {
        "params": {"slip": (0.6, 0.2, 0.2)},
        "notification": "detailed",
        "max_episode_steps": 40,
        "constraints": BOUNDED,
    }

    def through_view(env):
        obs, _ = env.reset(seed=11)
        trace, done = [obs], False
        while not done:
            obs, reward, terminated, truncated, _ = env.step(_lake_policy(obs))
            trace.append((obs, reward, terminated, truncated))
            done = terminated or truncated
        return str(trace), env.ground_truth()

    view = through_view(
        ns_pz.make_gym("ns_pz/FrozenLake-v0", nature=_random_lake_nature(), **kwargs)
    )
    seat = through_view(
        ns_pz.single_agent("ns_pz/FrozenLake-v0", "agent", nature=_random_lake_nature(), **kwargs)
    )
    game = ns_pz.make("ns_pz/FrozenLake-v0", nature=_random_lake_nature(), **kwargs)
    game.reset(seed=11)
    trace: list = []
    while game.agents:
        agent = game.agent_selection
        obs, reward, terminated, truncated, _ = game.last()
        if agent == DECISION and game.rewards:  # the result of the last transition, if any
            if trace:
                trace.append((obs, reward, terminated, truncated))
            else:
                trace.append(obs)
        if terminated or truncated:
            game.step(None)
        elif agent == DECISION:
            game.step(_lake_policy(obs))
        else:
            game.step(game.policy_action(agent))
    assert len(view[1].change_times) >= 3  # the nature really moved, at random times
    assert view == seat == (str(trace), game.ground_truth())


@pytest.mark.parametrize("limit", [1, 2, 7])
def test_regret_and_detection_hold_at_the_shortest_episodes_and_at_the_time_limit(limit):
    """Regret and detection rewards at one-transition episodes and at the time limit.

    Nature's total is still the oracle's value minus the agent's return; the monitor is still
    paid per turn.
    """

    def seat(learner, **kwargs):
        return ns_pz.single_agent(
            "ns_pz/FrozenLake-v0",
            learner,
            {DECISION: lambda obs: 2},
            max_episode_steps=limit,
            **LAKE,
            **kwargs,
        )

    env = seat("nature", nature_reward="regret", constraints=BOUNDED)
    for seed in range(4):
        env.reset(seed=seed)
        total, agent_return, steps, truncated = 0.0, 0.0, 0, False
        terminated = False
        while not (terminated or truncated):
            _, reward, terminated, truncated, _ = env.step(np.array([1, -1, 0], np.float32))
            total += reward
            agent_return += env.process.last_reward
            steps += 1
        assert steps <= limit and (truncated == (steps == limit and not terminated))
        assert total == pytest.approx(OracleReference()(env.process) - agent_return)
    monitor = seat("monitor", monitor_reward="detection")
    monitor.reset(seed=0)
    _, reward, terminated, truncated, _ = monitor.step(np.ones(1, np.int64))
    assert reward == -10.0  # an alarm before any transition is false
    assert (truncated == (limit == 1)) or terminated


def test_replay_regret_with_a_detector_and_a_per_episode_theta0():
    """Replay regret with a detector and an episode's own θ_0 (``reset(options=...)``).

    The replay shares the episode's detector, bound to the base θ_0, and starts from the
    episode's θ_0: no rebinding error, and on the deterministic CartPole the agent's own replay
    gives it no regret. A 2 cm pole falls in 4 steps; from the base θ_0 the replay would
    balance for all 30, a regret of 26.
    """
    from ns_pz.monitor import PredictionErrorMonitor

    env = _self_replay_regret_seat(
        monitor=PredictionErrorMonitor(), notification="detailed", max_episode_steps=30
    )
    env.reset(seed=0, options={"params": {"length": 0.02}})
    total, done = 0.0, False
    while not done:
        _, reward, terminated, truncated, _ = env.step(np.zeros(6, np.float32))
        total += reward
        done = terminated or truncated
    assert env.process.theta0.length == 0.02 and env.process.t == 4
    assert total == pytest.approx(0.0)


@pytest.mark.parametrize(
    ("env_id", "observes_state", "constraints"),
    [
        ("ns_pz/CartPole-v0", True, NatureConstraints(budget={"masspole": 0.5})),
        ("ns_pz/FrozenLake-v0", False, NatureConstraints(budget=0.4)),
        ("ns_pz/CartPole-v0", False, None),
    ],
)
def test_nature_observation_layout_entry_by_entry(
    env_id: str, observes_state: bool, constraints: NatureConstraints | None
) -> None:
    """Clock, θ offsets, budgets left, budget flag, then state and last action, as documented."""
    from ns_pz.nature.constraints import budget_fractions_left

    game = ns_pz.make(env_id, nature=ns_pz.nature.RandomNature(0.05), constraints=constraints)
    game.reset(seed=4)
    process = game.process
    interface = process.nature_interface("normalized", observes_state=observes_state)
    for _ in range(4):
        for agent in (NATURE, MONITOR):
            game.step(game.policy_action(agent))
        game.step(0)
        observation = interface.observe(process)
        offsets = (process.theta.flat() - process.theta0.flat()) / np.where(
            interface.allowance > 0.0, interface.allowance, 1.0
        )
        budgets = budget_fractions_left(
            process.constraints, process.family.params_cls, process.spent
        )
        expected = [process.t / process.max_episode_steps, *offsets, *budgets]
        expected.append(float(process.constraints.has_budget))
        if observes_state:
            action_space = process.family.action_space  # a Discrete action: one-hot
            expected += [*process.family.observe(process.state)]
            expected += [*spaces.flatten(action_space, process.last_action)]
        assert observation.dtype == np.float32
        assert observation.tolist() == np.array(expected, np.float32).tolist()
        assert interface.observation_space.contains(observation)


def test_a_learning_monitor_gives_the_agents_planner_nothing_beyond_theta0():
    """Its flags are the learner's, not the configured oracle's: the planner keeps θ_0."""
    seen = []
    env = ns_pz.single_agent(
        "ns_pz/CartPole-v0",
        MONITOR,
        {DECISION: push_left},
        monitor_reward="detection",
        notification="detailed",
        nature=ns_pz.nature.ScriptedNature(
            {"masspole": ns_pz.nature.IncrementUpdate(ns_pz.nature.DiscreteScheduler([1]), k=0.1)}
        ),
    )
    env.reset(seed=0)
    for _ in range(3):
        env.step(np.zeros(6, np.int64))
        seen.append(env.process.planning_theta().masspole)
    assert seen == [0.1, 0.1, 0.1]


def test_a_policy_nature_pickles_after_acting():
    """Its record of checked environments is not pickled (weak references)."""
    import pickle

    nature = PolicyNature(lean_nature)
    view = ns_pz.single_agent("ns_pz/CartPole-v0", DECISION, {NATURE: nature})
    view.reset(seed=0)
    view.step(0)
    again = pickle.loads(pickle.dumps(nature))
    assert again.action == nature.action and len(again._checked) == 0


@pytest.mark.parametrize(
    "budget",
    [{"budget": 0.0}, {"normalized_budget": 0.0}, {"budget": {"masspole": 0.0}}],
)
def test_nature_observes_a_zero_budget_as_spent_not_as_absent(budget: dict) -> None:
    """A budget of 0 (nature frozen) reads 0.0 left, "no budget" 1.0; both inside the space."""
    observations = {}
    for name, constraints in (("zero", NatureConstraints(**budget)), ("none", None)):
        game = ns_pz.make("ns_pz/CartPole-v0", constraints=constraints)
        game.reset(seed=1)
        interface = game.process.nature_interface("normalized")
        observations[name] = observation = interface.observe(game.process)
        assert interface.observation_space.contains(observation)
    names = ns_pz.make("ns_pz/CartPole-v0").process.family.params_cls.names()
    start = 1 + len(game.process.theta.flat_values())
    zero = observations["zero"][start : start + 2 + len(names)].tolist()
    none = observations["none"][start : start + 2 + len(names)].tolist()
    assert none == [1.0] * (2 + len(names))
    slot = {"budget": 0, "normalized_budget": 1}.get(next(iter(budget)), None)
    if isinstance(budget.get("budget"), dict):
        slot = 2 + names.index("masspole")
    assert zero[slot] == 0.0
    assert zero[:slot] + zero[slot + 1 :] == [1.0] * (1 + len(names))
    assert observations["zero"][start + 2 + len(names)] == 1.0  # the budgeted flag


def test_one_policy_monitor_bound_to_two_families_is_refused_as_detectors_are():
    """It took the last family's flag count and broke the first env.

    Envs of one family, whatever their θ_0, still share it (a vector of envs, game and view).
    """
    monitor = PolicyMonitor(lambda obs: [0])
    first = ns_pz.make_gym("ns_pz/FrozenLake-v0", monitor=monitor, notification="basic")
    ns_pz.make_gym("ns_pz/FrozenLake-v0", monitor=monitor, params={"slip": (0.5, 0.25, 0.25)})
    with pytest.raises(ValueError, match="PolicyMonitor is bound to FrozenLakeFamily.*own"):
        ns_pz.make_gym("ns_pz/CartPole-v0", monitor=monitor, notification="basic")
    first.reset(seed=0)
    observation, *_ = first.step(0)  # the first env still gets its one flag
    assert observation["env_change"].tolist() == [0]


# check_env's advice for a seat built without gym.make (no spec) and for the "delta" actions
# (Δθ in its own units, by design not in [-1, 1]); neither is what this test checks.
@pytest.mark.filterwarnings("ignore:.*not having a spec:UserWarning")
@pytest.mark.filterwarnings("ignore:.*symmetric and normalized space:UserWarning")
def test_movable_drops_the_frozen_parameters_from_natures_action_space():
    """NatureConstraints(movable=...) leaves nature two action elements; the rest stay at θ_0."""
    constraints = NatureConstraints(
        movable=("length", "force_mag"), lipschitz={"length": 0.05, "force_mag": 0.5}
    )
    for mode in ("normalized", "delta"):
        seat = ns_pz.single_agent(
            "ns_pz/CartPole-v0",
            "nature",
            {DECISION: balance},
            constraints=constraints,
            nature_action=mode,
        )
        assert seat.action_space.shape == (2,)
        check_env(seat)
    seat = ns_pz.single_agent(
        "ns_pz/CartPole-v0", "nature", {DECISION: balance}, constraints=constraints
    )
    seat.reset(seed=0)
    for _ in range(5):
        seat.step(np.ones(2, np.float32))
    truth = seat.unwrapped.ground_truth()
    moved = {n for n in truth.theta0.names() if getattr(truth.theta, n) != getattr(truth.theta0, n)}
    assert moved == {"length", "force_mag"}
    assert truth.theta.length == pytest.approx(truth.theta0.length + 5 * 0.05)
    assert truth.theta.force_mag == pytest.approx(truth.theta0.force_mag + 5 * 0.5)


# -- a monitor seat a learner can use ---------------------------------------------------------
def _cliff_change_at(first: int):
    from ns_pz.agents.exact import equal_split

    from ns_pz.nature import DiscreteScheduler, DistributionStepWiseUpdate, ScriptedNature

    return ScriptedNature(
        {"slip": DistributionStepWiseUpdate(DiscreteScheduler({first}), [equal_split(0.5, 4)])}
    )


def test_the_last_transition_is_judged_in_the_seat_and_the_game():
    """A change at the last transition, never flagged: charged 1 step in both (it was free).

    score_episode counts it missed; summed, the detection reward is -(undetected time).
    """
    from ns_pz.monitor import score_episode

    kwargs = {"nature": _cliff_change_at(4), "notification": "basic", "max_episode_steps": 5}
    seat = ns_pz.single_agent(
        "ns_pz/CliffWalking-v0",
        MONITOR,
        {DECISION: lambda obs: 0},
        monitor_reward="detection",
        **kwargs,
    )
    seat.reset(seed=0)
    quiet, rewards, done = np.zeros(1, np.int64), [], False
    while not done:
        _, reward, terminated, truncated, _ = seat.step(quiet)
        rewards.append(reward)
        done = terminated or truncated
    assert seat.unwrapped.ground_truth().change_times == (4,)
    assert score_episode([4], [], 5).missed == 1
    assert rewards == [0.0, 0.0, 0.0, 0.0, -1.0]
    game = ns_pz.make(
        "ns_pz/CliffWalking-v0", monitor_reward="detection", monitor_action="flags", **kwargs
    )
    game.reset(seed=0)
    paid = 0.0
    for agent in game.agent_iter():
        _, reward, terminated, truncated, _ = game.last()
        if agent == MONITOR:
            paid += reward
        if terminated or truncated:
            game.step(None)
        elif agent == MONITOR:
            game.step(quiet)
        elif agent == DECISION:
            game.step(0)
        else:
            game.step(game.policy_action(agent))
    assert paid == -1.0


def _first_impossible(obs):
    """Alarm on the first transition impossible under θ_0; never again (one bit of memory)."""
    memory = obs["memory"]
    return np.array([int(memory[2] > 0 and memory[1] == 0)], np.int64)


def test_monitor_features_give_memory_and_a_trained_policy_sees_the_same_in_the_view():
    """Clock in [0, 1], evidence since the last alarm; the seat and PolicyMonitor agree."""
    from ns_pz.monitor import MonitorFeatures

    features = MonitorFeatures(horizon=40)
    kwargs = {"nature": _cliff_change_at(5), "notification": "basic", "max_episode_steps": 40}
    walk = lambda obs: int(obs["relative_time"][0]) % 4  # noqa: E731
    seat = ns_pz.single_agent(
        "ns_pz/CliffWalking-v0",
        MONITOR,
        {DECISION: walk},
        monitor_reward="detection",
        monitor_features=features,
        **kwargs,
    )
    check_env(seat, skip_render_check=True)
    assert "relative_time" not in seat.observation_space.spaces
    obs, _ = seat.reset(seed=3)
    seat_alarms, t, done = [], 0, False
    while not done:
        assert obs["clock"][0] == pytest.approx(t / 40) and obs in seat.observation_space
        flags = _first_impossible(obs)
        if flags[0]:
            seat_alarms.append(t - 1)
        obs, _, terminated, truncated, _ = seat.step(flags)
        t += 1
        done = terminated or truncated
    assert len(seat_alarms) == 1 and seat_alarms[0] >= 5
    assert obs["memory"][1] == 0.5  # one alarm raised: 1 / (1 + 1)
    view = ns_pz.make_gym(
        "ns_pz/CliffWalking-v0",
        monitor=PolicyMonitor(_first_impossible, features=features),
        **kwargs,
    )
    obs, _ = view.reset(seed=3)
    view_alarms, t, done = [], 0, False
    while not done:
        obs, _, terminated, truncated, _ = view.step(walk(obs))
        t += 1
        if obs["env_change"][0]:
            view_alarms.append(t - 1)
        done = terminated or truncated
    assert view_alarms == seat_alarms


def test_monitor_features_refuse_what_they_cannot_serve():
    """No horizon, evidence on a family without outcome tables, a seat that is not the monitor."""
    from ns_pz.monitor import MonitorFeatures

    with pytest.raises(ValueError, match="horizon=0 must be an int >= 1"):
        MonitorFeatures(horizon=0)
    with pytest.raises(ValueError, match="unlikely=1.5"):
        MonitorFeatures(horizon=10, unlikely=1.5)
    with pytest.raises(TypeError, match="evidence=False"):
        ns_pz.single_agent(
            "ns_pz/CartPole-v0",
            MONITOR,
            {DECISION: balance},
            monitor_reward="detection",
            monitor_features=MonitorFeatures(horizon=10),
        )
    with pytest.raises(ValueError, match="monitor_features=.* only when the monitor learns"):
        ns_pz.single_agent(
            "ns_pz/CartPole-v0",
            NATURE,
            {DECISION: balance},
            monitor_features=MonitorFeatures(horizon=10, evidence=False),
        )
