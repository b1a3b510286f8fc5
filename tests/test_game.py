"""The AEC game: PettingZoo conformance, rewards, turn validation, scripted policies."""

from __future__ import annotations

import numpy as np
import pytest
from pettingzoo.test import api_test
from pettingzoo.utils.conversions import turn_based_aec_to_parallel

import ns_pz
from ns_pz import DECISION, MONITOR, NATURE, ResetNeeded
from ns_pz.nature import (
    ContinuousScheduler,
    DiscreteScheduler,
    IncrementUpdate,
    NatureConstraints,
    RandomNature,
    ScriptedNature,
    StepWiseUpdate,
)


def quiet(count: int) -> dict:
    """A monitor action that reports no change."""
    return {"env_change": np.zeros(count, np.int8), "delta_change": np.zeros(count, np.float32)}


# PettingZoo's api_test resets with options={"options": 1} to see that an unknown option does
# not crash; ns_pz warns that it ignores it, as it should for a user's typo. Expected here.
@pytest.mark.filterwarnings("ignore:reset options \\['options'\\] are not understood:UserWarning")
def test_api_test_with_an_adversarial_nature():
    """PettingZoo's api_test passes with nature moving every parameter every step."""
    game = ns_pz.make("ns_pz/FrozenLake-v0", nature=RandomNature(0.3), max_episode_steps=30)
    api_test(game, num_cycles=100)


@pytest.mark.parametrize(
    ("mode", "sign"), [("zero_sum", -1.0), ("cooperative", 1.0), ("none", 0.0)]
)
def test_rewards_follow_the_nature_reward_mode(mode, sign):
    """The agent gets r, nature -r (zero-sum), +r (cooperative) or 0, the monitor 0."""
    game = ns_pz.make("ns_pz/CartPole-v0", nature_reward=mode)
    game.reset(seed=0)
    game.step(np.zeros(6))
    game.step(quiet(6))
    game.step(1)
    assert game.rewards == {NATURE: sign * 1.0, MONITOR: 0.0, DECISION: 1.0}
    assert game.last()[1] == sign * 1.0  # nature's turn again: its accumulated reward
    with pytest.raises(ValueError, match="nature_reward='adversarial'"):
        ns_pz.make("ns_pz/CartPole-v0", nature_reward="adversarial")


def test_nature_acts_with_a_delta_and_zero_means_no_change():
    """Nature's action is Δθ in flat order; zero changes nothing."""
    game = ns_pz.make("ns_pz/CartPole-v0", notification="detailed")
    game.reset(seed=0)
    game.step(np.zeros(6))
    assert game.ground_truth().change_times == ()
    game.step(quiet(6))
    game.step(0)
    delta = np.zeros(6)
    delta[2] = 0.4
    game.step(delta)
    assert game.ground_truth().theta.masspole == pytest.approx(0.5)
    assert game.ground_truth().change_times == (1,)


@pytest.mark.parametrize(
    "action",
    [
        np.array([np.nan, 0, 0]),
        np.array([0.5, 0.5]),
        np.array([[0.1, 0.0, -0.1]]),
        "up",
        np.array([2.0, 0.0, 0.0]),
    ],
)
def test_bad_nature_actions_are_refused(action):
    """NaN, wrong shapes, non-numbers and steps beyond the space raise ValueError."""
    game = ns_pz.make("ns_pz/FrozenLake-v0")
    game.reset(seed=0)
    with pytest.raises(ValueError, match="nature action"):
        game.step(action)
    assert game.agent_selection == NATURE


@pytest.mark.parametrize(
    ("action", "match"),
    [
        ({"env_change": [2], "delta_change": [0.0]}, "must hold only 0 and 1"),
        ({"env_change": [1], "delta_change": [-0.5]}, "must be finite and >= 0"),
        ({"env_change": [1, 0], "delta_change": [0.5, 0.0]}, "needs 1 flags and 1 sizes"),
        ({"flags": [1]}, "must be a dict with keys"),
        ({"env_change": [1], "delta_change": [np.nan]}, "must be finite and >= 0"),
    ],
)
def test_bad_monitor_actions_are_refused(action, match):
    """Malformed notifications raise ValueError naming what is wrong."""
    game = ns_pz.make("ns_pz/FrozenLake-v0")
    game.reset(seed=0)
    game.step(np.zeros(3))
    with pytest.raises(ValueError, match=match):
        game.step(action)


def test_the_level_masks_what_the_monitor_says():
    """Whatever the monitor sends, the agent sees only what the level allows."""
    for level, expected in [("none", (0, 0.0)), ("basic", (1, 0.0)), ("detailed", (1, 0.25))]:
        game = ns_pz.make("ns_pz/FrozenLake-v0", notification=level)
        game.reset(seed=0)
        game.step(np.zeros(3))
        game.step({"env_change": np.array([1]), "delta_change": np.array([0.25])})
        obs = game.observe(DECISION)
        assert (obs["env_change"][0], float(obs["delta_change"][0])) == expected


def test_policy_action_reproduces_scripted_values_exactly():
    """Driving nature by its scripted Δθ lands exactly on the scripted values."""
    schedule = StepWiseUpdate(DiscreteScheduler({0, 1, 2}), [1.0, 0.3, 250.1])
    game = ns_pz.make("ns_pz/CartPole-v0", nature=ScriptedNature({"masspole": schedule}))
    game.reset(seed=0)
    seen = []
    for _ in range(3):
        game.step(game.policy_action(NATURE))
        seen.append(game.ground_truth().theta.masspole)
        game.step(game.policy_action(MONITOR))
        game.step(1)
    assert seen == [1.0, 0.3, 250.1]
    with pytest.raises(ValueError, match="has no configured policy"):
        game.policy_action(DECISION)


def test_all_agents_truncate_together_and_leave():
    """At the time limit all three agents are truncated, then removed by their dead steps."""
    game = ns_pz.make("ns_pz/CartPole-v0", max_episode_steps=2)
    game.reset(seed=0)
    for agent in game.agent_iter():
        _, _, terminated, truncated, _ = game.last()
        if terminated or truncated:
            assert all(game.truncations.values())
            game.step(None)
        else:
            game.step(
                game.policy_action(agent)
                if agent != DECISION
                else game.action_space(agent).sample()
            )
    assert game.agents == []
    with pytest.raises(ResetNeeded, match="after the episode ended"):
        game.step(0)


def test_spaces_are_the_same_objects_and_observations_inside():
    """Each agent's spaces are the same object on every call; first observations are inside."""
    game = ns_pz.make("ns_pz/FrozenLake-v0")
    game.reset(seed=0)
    for agent in game.possible_agents:
        assert game.observation_space(agent) is game.observation_space(agent)
        assert game.action_space(agent) is game.action_space(agent)
        assert game.observation_space(agent).contains(game.observe(agent))


def test_observe_before_reset_raises():
    """Observing a game that was never reset is an error, not a stale value."""
    with pytest.raises(ResetNeeded, match="observe\\(\\) called before reset"):
        ns_pz.make("ns_pz/FrozenLake-v0").observe(NATURE)


def test_turn_based_parallel_conversion_runs():
    """PettingZoo's turn-based parallel wrapper works on the game (aec_to_parallel cannot)."""
    parallel = turn_based_aec_to_parallel(ns_pz.make("ns_pz/FrozenLake-v0", max_episode_steps=5))
    observations, _ = parallel.reset(seed=0)
    assert set(observations) == {NATURE, MONITOR, DECISION}
    steps = 0
    while parallel.agents and steps < 30:
        actions = {agent: parallel.action_space(agent).sample() for agent in parallel.agents}
        parallel.step(actions)
        steps += 1
    assert not parallel.agents


def test_detailed_planning_model_never_shows_the_coming_theta():
    """At the agent's turn nature has chosen θ_t; the planning model still holds θ_{t-1}."""
    schedule = StepWiseUpdate(DiscreteScheduler({1}), [0.5])
    game = ns_pz.make(
        "ns_pz/CartPole-v0",
        nature=ScriptedNature({"masspole": schedule}),
        notification="detailed",
    )
    game.reset(seed=0)
    seen = []
    for _ in range(3):
        game.step(game.policy_action(NATURE))
        game.step(game.policy_action(MONITOR))
        seen.append(game.planning_model().theta.masspole)
        game.step(1)
    assert seen == [0.1, 0.1, 0.5]  # θ_1 = 0.5 drives transition 1; known from decision 2


def test_a_refused_action_changes_nothing():
    """Invalid nature, monitor or agent actions leave rewards, totals and the turn untouched."""
    game = ns_pz.make("ns_pz/CartPole-v0")
    game.reset(seed=0)
    game.step(np.zeros(6))
    game.step(quiet(6))
    game.step(1)
    before = (dict(game.rewards), dict(game._cumulative_rewards), game.agent_selection)
    with pytest.raises(ValueError):
        game.step(np.full(6, np.nan))
    assert (dict(game.rewards), dict(game._cumulative_rewards), game.agent_selection) == before
    game.step(np.zeros(6))
    game.step(quiet(6))
    totals = dict(game._cumulative_rewards)
    with pytest.raises(ValueError, match="outside the action space"):
        game.step(7)
    assert game._cumulative_rewards == totals and game.agent_selection == DECISION


def test_blocked_changes_are_not_recorded():
    """A zero Lipschitz bound freezes θ, and the ground truth records no change."""
    game = ns_pz.make(
        "ns_pz/CartPole-v0", constraints=NatureConstraints(lipschitz={"masspole": 0.0})
    )
    game.reset(seed=0)
    for _ in range(3):
        delta = np.zeros(6)
        delta[2] = 0.3
        game.step(delta)
        game.step(quiet(6))
        game.step(1)
    truth = game.ground_truth()
    assert truth.change_times == () and truth.theta == truth.theta0


def test_calls_before_reset_raise_reset_needed():
    """step() and last() on a game never reset raise ResetNeeded, not AttributeError."""
    game = ns_pz.make("ns_pz/FrozenLake-v0")
    with pytest.raises(ResetNeeded, match="before reset"):
        game.step(np.zeros(3))
    with pytest.raises(ResetNeeded, match="before reset"):
        game.last()


def test_a_scripted_action_from_a_past_episode_is_a_plain_delta():
    """After reset, an array from the old episode's policy_action is applied as Δθ only."""
    schedule = StepWiseUpdate(DiscreteScheduler({0, 1}), [0.3, 0.5])
    game = ns_pz.make("ns_pz/CartPole-v0", nature=ScriptedNature({"masspole": schedule}))
    game.reset(seed=0)
    game.step(game.policy_action(NATURE))
    game.step(game.policy_action(MONITOR))
    game.step(1)
    old = game.policy_action(NATURE)  # Δ 0.2 towards the scripted 0.5
    game.reset(seed=0)
    game.step(old)
    assert game.ground_truth().theta.masspole == pytest.approx(0.3)  # θ_0 + Δ, not 0.5


def test_policy_action_is_asked_once_per_turn():
    """Two calls in one turn give the same action; the schedule advances once per step."""
    schedule = StepWiseUpdate(DiscreteScheduler({1, 2}), [0.2, 0.3])
    game = ns_pz.make("ns_pz/CartPole-v0", nature=ScriptedNature({"masspole": schedule}))
    game.reset(seed=0)
    game.step(game.policy_action(NATURE))
    game.step(game.policy_action(MONITOR))
    game.step(1)
    first, second = game.policy_action(NATURE), game.policy_action(NATURE)
    assert first is second
    game.step(second)
    assert game.ground_truth().theta.masspole == pytest.approx(0.2)  # not 0.3


def test_policy_action_and_actions_out_of_turn_are_refused():
    """Asking nature's policy on the monitor's turn (or the reverse) raises, naming the turn."""
    game = ns_pz.make("ns_pz/CartPole-v0")
    game.reset(seed=0)
    with pytest.raises(ValueError, match="it is 'nature''s turn, not 'monitor''s"):
        game.policy_action(MONITOR)
    game.step(game.policy_action(NATURE))
    with pytest.raises(ValueError, match="it is 'monitor''s turn, not 'nature''s"):
        game.policy_action(NATURE)
    with pytest.raises(ValueError, match="has no configured policy"):
        game.policy_action(DECISION)


@pytest.mark.parametrize("call", ["action_space", "observation_space", "observe", "policy_action"])
def test_unknown_agent_names_get_a_clear_error(call):
    """A misspelt agent name is a ValueError that lists the agents, not a bare KeyError."""
    game = ns_pz.make("ns_pz/CartPole-v0")
    game.reset(seed=0)
    with pytest.raises(ValueError, match=r"agent='nature ' is not one of \('nature'"):
        getattr(game, call)("nature ")


def test_last_after_the_episode_says_so():
    """last() once every agent has left raises ResetNeeded, not KeyError."""
    game = ns_pz.make("ns_pz/FrozenLake-v0", max_episode_steps=1)
    game.reset(seed=0)
    for agent in game.agent_iter():
        _, _, terminated, truncated, _ = game.last()
        if terminated or truncated:
            game.step(None)
        else:
            game.step(game.policy_action(agent) if agent != DECISION else 0)
    with pytest.raises(ResetNeeded, match="after the episode ended"):
        game.last()


@pytest.mark.parametrize(
    ("seed", "error", "match"),
    [
        (-1, ValueError, "seed=-1 must be a non-negative int"),
        (1.5, TypeError, "seed=1.5"),
        (True, TypeError, "seed=True"),
    ],
)
def test_bad_seeds_are_refused_clearly(seed, error, match):
    """Game and view refuse negative, float and bool seeds with the seed in the message."""
    with pytest.raises(error, match=match):
        ns_pz.make("ns_pz/FrozenLake-v0").reset(seed=seed)
    with pytest.raises(error, match=match):
        ns_pz.make_gym("ns_pz/FrozenLake-v0").reset(seed=seed)


@pytest.mark.parametrize("position", range(6))
def test_normalized_nature_actions_are_checked_element_by_element(position):
    """Every element must lie in [-1, 1] (NaN and ±inf refused); the bounds themselves pass."""
    game = ns_pz.make("ns_pz/CartPole-v0", nature_action="normalized")
    game.reset(seed=0)
    allowance = game.process.nature_interface("normalized").allowance
    above = float(np.nextafter(np.float32(1.0), np.float32(2.0)))
    for bad in (np.nan, np.inf, -np.inf, above, -above):
        action = np.zeros(6, np.float32)
        action[position] = bad
        with pytest.raises(ValueError, match="outside the action space"):
            game.step(action)
    action = [0.0] * 6  # a list is fine
    action[position] = -1.0
    theta = game.process.theta
    game.step(action)
    name = theta.names()[position]
    expected = getattr(theta, name) - float(allowance[position])
    assert getattr(game.process.theta, name) == expected
    assert type(getattr(game.process.theta, name)) is float


@pytest.mark.parametrize(
    "action",
    [np.zeros(6, complex), np.zeros(6, bool), [True] + [False] * 5, [0.0] * 5 + [1j]],
)
def test_complex_and_bool_nature_actions_are_refused(action):
    """Only real vectors are Δθ; complex or bool arrays are refused like any outside the Box."""
    game = ns_pz.make("ns_pz/CartPole-v0")
    game.reset(seed=0)
    with pytest.raises(ValueError, match="nature action="):
        game.step(action)


def test_reset_options_set_theta0_for_one_episode():
    """reset(options={"params": ...}) starts that episode from another θ_0; unknown keys warn."""
    for env in (ns_pz.make("ns_pz/CartPole-v0"), ns_pz.make_gym("ns_pz/CartPole-v0")):
        env.reset(seed=0, options={"params": {"masspole": 0.3}})
        truth = env.ground_truth()
        assert truth.theta0.masspole == 0.3 and truth.theta.masspole == 0.3
        env.reset(seed=0)
        assert env.ground_truth().theta0.masspole == pytest.approx(0.1)
        with pytest.warns(UserWarning, match=r"\['colour'\] are not understood"):
            env.reset(seed=0, options={"colour": "red"})
        with pytest.raises(ns_pz.ParamOutOfRange, match="masspole=-1"):
            env.reset(seed=0, options={"params": {"masspole": -1.0}})


@pytest.mark.parametrize("flags_only", [False, True])
def test_the_monitor_policys_unmodified_action_sends_its_exact_notification(
    flags_only: bool,
) -> None:
    """Stepped as handed out: the exact float64 sizes; modified in place: what it now says."""
    nature = ScriptedNature({"masspole": IncrementUpdate(ContinuousScheduler(start=0), k=1e-3)})
    kwargs = {"monitor_action": "flags"} if flags_only else {}
    game = ns_pz.make("ns_pz/CartPole-v0", nature=nature, notification="detailed", **kwargs)
    game.reset(seed=0)
    for step in range(3):
        game.step(game.policy_action(NATURE))
        action = game.policy_action(MONITOR)
        assert game.policy_action(MONITOR) is action  # asked once per turn
        truth = game.process.last_sizes()
        if step == 2:  # the user edits the handed-out action: it is taken as it now is
            (action if flags_only else action["env_change"])[:] = 0
        game.step(action)
        flags, sizes = game.process.notice
        if step == 0:  # no transition yet, nothing to notify
            assert not any(flags) and not any(sizes)
        elif step == 1:
            assert flags == tuple(1 if s > 0 else 0 for s in truth)
            assert sizes == (game.process.no_change if flags_only else truth)  # not float32
        else:
            assert not any(flags) and not any(sizes)
        game.step(1)


def test_the_monitor_policys_action_with_a_replaced_array_is_taken_as_it_is() -> None:
    """A new array put in the handed-out dict is what is sent; handed-out arrays are fresh."""
    nature = ScriptedNature({"masspole": IncrementUpdate(ContinuousScheduler(start=0), k=1e-3)})
    game = ns_pz.make("ns_pz/CartPole-v0", nature=nature, notification="detailed")
    game.reset(seed=0)
    game.step(game.policy_action(NATURE))
    quiet = game.policy_action(MONITOR)
    quiet["env_change"][:] = 1  # edits the array handed out, not a template behind it
    quiet["delta_change"][:] = 5.0
    game.step(quiet)
    assert game.process.notice == ((1,) * 6, (5.0,) * 6)
    game.step(0)
    game.step(game.policy_action(NATURE))
    action = game.policy_action(MONITOR)
    assert action["env_change"].tolist() == [0, 0, 1, 0, 0, 0]  # masspole, third field
    assert action["delta_change"][2] > 0.0 and not any(np.delete(action["delta_change"], 2))
    action["delta_change"] = np.zeros(6, np.float32)  # replaced, not edited in place
    game.step(action)
    assert game.process.notice == ((0, 0, 1, 0, 0, 0), (0.0,) * 6)
    game.reset(seed=0)
    game.step(game.policy_action(NATURE))
    quiet = game.policy_action(MONITOR)  # the edits above reached no template
    assert not quiet["env_change"].any() and not quiet["delta_change"].any()


@pytest.mark.parametrize("env_id", ["ns_pz/MountainCarContinuous-v0", "ns_pz/InvertedPendulum-v0"])
def test_the_monitors_observation_owns_its_arrays(env_id: str) -> None:
    """``last_action`` is neither the agent's array (which it may reuse) nor a shared template."""
    if "Pendulum" in env_id:
        pytest.importorskip("mujoco")
    game = ns_pz.make(env_id)
    game.reset(seed=0)
    first = game.observe(MONITOR)
    game.reset(seed=0)
    assert game.observe(MONITOR)["last_action"] is not first["last_action"]
    push = np.array([0.5], np.float32)
    game.step(game.policy_action(NATURE))
    game.step(game.policy_action(MONITOR))
    game.step(push)
    seen = game.observe(MONITOR)
    push[0] = -1.0  # the agent reuses its buffer
    assert seen["last_action"].tolist() == [0.5]
    assert game.observe(MONITOR)["last_action"].tolist() == [0.5]


def test_the_monitor_policys_action_is_refused_out_of_its_turn() -> None:
    """Even the policy's own, unmodified action is refused once it is not the monitor's turn."""
    game = ns_pz.make("ns_pz/CartPole-v0", notification="detailed")
    game.reset(seed=0)
    game.step(game.policy_action(NATURE))
    action = game.policy_action(MONITOR)
    game.process.play_until(DECISION)  # someone else played the monitor's turn
    with pytest.raises(ValueError, match="turn"):
        game.step(action)


def test_a_notification_is_seen_on_exactly_one_agent_observation():
    """Between the agent's transition and the monitor's next turn the agent hears nothing.

    The flag of the change at step 1 is on the observation after the monitor's turn of step 2,
    and not again after nature's turn of step 3 (it had lingered until the next monitor turn).
    """
    nature = ScriptedNature({"masspole": IncrementUpdate(DiscreteScheduler([1]), k=0.1)})
    game = ns_pz.make("ns_pz/CartPole-v0", nature=nature, notification="detailed")
    game.reset(seed=0)
    seen = []
    for _ in range(4):
        game.step(game.policy_action(NATURE))
        seen.append(int(game.observe(DECISION)["env_change"].any()))  # before the monitor
        game.step(game.policy_action(MONITOR))
        seen.append(int(game.observe(DECISION)["env_change"].any()))  # after it
        game.step(0)
    assert seen == [0, 0, 0, 0, 0, 1, 0, 0]


def test_an_out_of_bounds_action_is_observed_clipped_inside_the_spaces():
    """An action beyond the bounds is observed clipped, inside nature's and the monitor's spaces.

    The dynamics clip it (as Gymnasium's do); the reward sees it as given.
    """
    game = ns_pz.make("ns_pz/Pendulum-v0", nature_observes_state=True)
    game.reset(seed=0)
    game.step(game.policy_action(NATURE))
    game.step(game.policy_action(MONITOR))
    game.step(np.array([5.0], np.float32))
    nature_obs = game.observe(NATURE)
    assert game.observation_space(NATURE).contains(nature_obs) and nature_obs[-1] == 2.0
    game.step(game.policy_action(NATURE))
    monitor_obs = game.observe(MONITOR)
    assert game.observation_space(MONITOR).contains(monitor_obs)
    assert monitor_obs["last_action"].tolist() == [2.0]


def test_a_size_is_shown_only_with_its_flag():
    """A monitor action sizing an unflagged parameter shows no size for it."""
    game = ns_pz.make("ns_pz/CartPole-v0", notification="detailed")
    game.reset(seed=0)
    game.step(game.policy_action(NATURE))
    flags = np.array([1, 0, 0, 0, 0, 0], np.int8)
    sizes = np.array([0.25, 0.5, 0, 0, 0, 0], np.float32)
    game.step({"env_change": flags, "delta_change": sizes})
    assert game.observe(DECISION)["delta_change"].tolist() == [0.25, 0, 0, 0, 0, 0]


def test_a_notification_from_outside_gives_the_planner_nothing_beyond_theta0():
    """The monitor's turn played by the caller: the planner keeps θ_0.

    The configured oracle's knowledge is not the sender's (it had the truth with no flag sent).
    """
    nature = ScriptedNature({"masspole": IncrementUpdate(DiscreteScheduler([1]), k=0.1)})
    game = ns_pz.make("ns_pz/CartPole-v0", nature=nature, notification="detailed")
    game.reset(seed=0)
    count = len(game.family.params_cls.names())
    for _ in range(3):
        game.step(game.policy_action(NATURE))
        game.step(quiet(count))
        assert game.planning_model().theta.masspole == pytest.approx(0.1)
        game.step(0)
    game.step(game.policy_action(NATURE))
    game.step(game.policy_action(MONITOR))  # the configured oracle again: the truth
    assert game.planning_model().theta.masspole == pytest.approx(0.2)


def test_a_refused_reset_leaves_the_episode_and_its_generators_alone():
    """A detector refusing an episode's θ_0 refuses before the reseed."""
    from ns_pz.monitor import TabularCusumMonitor

    env = ns_pz.make_gym("ns_pz/FrozenLake-v0", monitor=TabularCusumMonitor())
    env.reset(seed=0)
    env.step(1)
    before = (env.np_random_seed, env.process.t, env.process.env_rng.bit_generator.state)
    with pytest.raises(ValueError, match="bound to θ_0"):
        env.reset(seed=123, options={"params": {"slip": (0.5, 0.25, 0.25)}})
    after = (env.np_random_seed, env.process.t, env.process.env_rng.bit_generator.state)
    assert after == before


def test_monitor_reward_pays_the_monitor_at_its_turn():
    """The game pays a learning monitor (it paid it nothing).

    With ``DetectionReward``: -1 per step a change is undetected, 0 for the detecting alarm, -λ
    for a second one.
    """
    from ns_pz.monitor import DetectionReward

    nature = ScriptedNature({"masspole": StepWiseUpdate(DiscreteScheduler({2}), [0.2])})
    game = ns_pz.make(
        "ns_pz/CartPole-v0",
        nature=nature,
        monitor_action="flags",
        monitor_reward=DetectionReward(false_alarm_cost=10.0),
    )
    silent, alarm = np.zeros(6, np.int64), np.eye(6, dtype=np.int64)[2]
    for episode in range(2):  # the reward's episode state is reset with the game
        game.reset(seed=episode)
        paid, told = [], []
        for t, flags in enumerate([silent] * 4 + [alarm, alarm, silent]):
            game.step(game.policy_action(NATURE))
            assert game.agent_selection == MONITOR
            told.append(game.last()[1])  # what the monitor earned since it last acted
            game.step(flags)
            paid.append(game.rewards[MONITOR])
            assert game.rewards[NATURE] == game.rewards[DECISION] == 0.0
            assert game.agent_selection == DECISION
            game.step(t % 2)
            assert game.rewards[MONITOR] == 0.0
        # The monitor at step t speaks of transition t - 1; the change is at transition 2.
        assert paid == [0.0, 0.0, 0.0, -1.0, 0.0, -10.0, 0.0]
        assert told == [0.0, *paid[:-1]]


def test_monitor_reward_is_refused_unless_none_detection_or_a_function():
    """A bad reward is named; an RLlib monitor learner without one is refused."""
    with pytest.raises(ValueError, match="monitor_reward='detect'; allowed: None, 'detection'"):
        ns_pz.make("ns_pz/CartPole-v0", monitor_reward="detect")
    from ns_pz.rllib import env_creator

    create = env_creator("ns_pz/CartPole-v0", scripted_monitor=False)
    with pytest.raises(ValueError, match="needs a reward: pass monitor_reward='detection'"):
        create({})
    with pytest.raises(ValueError, match="needs a reward"):  # env_config overrides the game's
        env_creator("ns_pz/CartPole-v0", scripted_monitor=False, monitor_reward="detection")(
            {"monitor_reward": None}
        )


def _nan_reward(process, flags):
    return float("nan")


def _text_reward(process, flags):
    return "1.0"


@pytest.mark.parametrize(
    ("reward_fn", "error", "said"),
    [(_nan_reward, ValueError, "returned nan"), (_text_reward, TypeError, "returned '1.0'")],
)
@pytest.mark.parametrize("where", ["game", "seat"])
def test_a_monitor_reward_giving_nan_or_a_non_number_is_refused_by_name(
    reward_fn, error, said, where
):
    """NaN would reach the learner as reward=nan; a string failed inside float() unnamed."""
    if where == "game":
        game = ns_pz.make("ns_pz/CartPole-v0", monitor_action="flags", monitor_reward=reward_fn)
        game.reset(seed=0)
        game.step(game.policy_action(NATURE))
        with pytest.raises(error, match=f"monitor_reward=.*_reward.* {said}"):
            game.step(np.zeros(6, np.int64))
    else:
        seat = ns_pz.single_agent(
            "ns_pz/CartPole-v0", "monitor", {DECISION: lambda obs: 0}, monitor_reward=reward_fn
        )
        seat.reset(seed=0)
        with pytest.raises(error, match=f"monitor_reward=.*_reward.* {said}"):
            seat.step(np.zeros(6, np.int64))
