"""MonitorFeatures' options: a detector's statistic, stacked past transitions; a recurrent seat."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import ns_pz
from ns_pz import DECISION, MONITOR
from ns_pz.monitor import MonitorFeatures, PolicyMonitor, TabularCusumMonitor

HORIZON = 60


def _cliff_nature(first: int) -> Any:
    """CliffWalking's slip 1.0 -> 0.5 (equal split) at transition ``first``."""
    from ns_pz.agents.exact import equal_split

    from ns_pz.nature import DiscreteScheduler, DistributionStepWiseUpdate, ScriptedNature

    return ScriptedNature(
        {"slip": DistributionStepWiseUpdate(DiscreteScheduler({first}), [equal_split(0.5, 4)])}
    )


def _walk(obs: dict[str, Any]) -> int:
    """A decision agent that cycles through the four moves."""
    return int(obs["relative_time"][0]) % 4


def _seat(features: MonitorFeatures) -> Any:
    return ns_pz.single_agent(
        "ns_pz/CliffWalking-v0",
        MONITOR,
        {DECISION: _walk},
        monitor_reward="detection",
        monitor_features=features,
        nature=_cliff_nature(10),
        notification="basic",
        max_episode_steps=HORIZON,
    )


def _view(monitor: Any) -> Any:
    return ns_pz.make_gym(
        "ns_pz/CliffWalking-v0",
        monitor=monitor,
        nature=_cliff_nature(10),
        notification="basic",
        max_episode_steps=HORIZON,
    )


def _view_alarms(monitor: Any, seed: int) -> list[int]:
    """Transitions whose notification raised a flag, over one episode of the view."""
    view = _view(monitor)
    obs, _ = view.reset(seed=seed)
    alarms, t, done = [], 0, False
    while not done:
        obs, _, terminated, truncated, _ = view.step(_walk(obs))
        t += 1
        if obs["env_change"][0]:
            alarms.append(t - 1)
        done = terminated or truncated
    return alarms


def _follow_detector(obs: dict[str, Any]) -> np.ndarray:
    """Alarm exactly when the feature's detector alarms."""
    return np.array([int(obs["detector"][1])], np.int64)


def test_a_policy_reading_the_detector_feature_alarms_where_the_detector_does() -> None:
    """Following the feature's alarm bit reproduces the CUSUM's alarms, in the seat and game."""
    features = MonitorFeatures(horizon=HORIZON, detector=TabularCusumMonitor(threshold=10.0))
    seat = _seat(features)
    check_env(seat, skip_render_check=True)
    for seed in range(3):
        obs, _ = seat.reset(seed=seed)
        seat_alarms, statistics, t, done = [], [], 0, False
        while not done:
            assert obs in seat.observation_space
            statistics.append(float(obs["detector"][0]))
            flags = _follow_detector(obs)
            if flags[0]:
                seat_alarms.append(t - 1)
                assert obs["detector"][2] == 0.5  # one detector alarm since the seat's last
            obs, _, terminated, truncated, _ = seat.step(flags)
            t += 1
            done = terminated or truncated
        assert statistics[:10] == [0.0] * 10  # nothing surprising before the change
        cusum = _view_alarms(TabularCusumMonitor(threshold=10.0), seed)
        assert cusum and all(alarm >= 10 for alarm in cusum)
        assert seat_alarms == cusum
        following = PolicyMonitor(_follow_detector, features=features)
        assert _view_alarms(following, seed) == cusum


def test_the_detector_feature_counts_its_alarms_until_the_learned_monitor_alarms() -> None:
    """A silent learned monitor sees the detector's alarms add up; alarming clears the count."""
    features = MonitorFeatures(horizon=HORIZON, detector=TabularCusumMonitor(threshold=2.0))
    seat = _seat(features)
    obs, _ = seat.reset(seed=0)
    counts, done = [], False
    while not done:
        counts.append(float(obs["detector"][2]))
        obs, _, terminated, truncated, _ = seat.step(np.array([0]))
        done = terminated or truncated
    assert counts == sorted(counts) and counts[-1] >= 2 / 3  # two or more alarms kept
    obs, _ = seat.reset(seed=0)
    while obs["detector"][2] == 0.0:
        obs, *_ = seat.step(np.array([0]))
    obs, *_ = seat.step(np.array([1]))  # the learned monitor alarms
    assert obs["detector"][2] in (0.0, 0.5)  # cleared (0.5: the detector alarmed again)


def test_stack_shows_the_past_transitions_newest_first() -> None:
    """stack=3: the two turns before this one, as the observations of those turns showed them."""
    features = MonitorFeatures(horizon=HORIZON, stack=3)
    seat = _seat(features)
    check_env(seat, skip_render_check=True)
    obs, _ = seat.reset(seed=1)
    seen = [obs]
    for _ in range(6):
        obs, *_ = seat.step(np.array([0]))
        seen.append(obs)
    for t, now in enumerate(seen):
        assert now["stacked"].tolist() == [float(t >= 2), float(t >= 3)]
        for back in (1, 2):
            if t - back >= 1:  # a past turn that showed a transition
                for name in ("last_state", "last_action", "last_reward", "state"):
                    assert np.array_equal(now[f"{name}_{back}"], seen[t - back][name]), (t, name)
    assert (
        seen[3]["state_1"] != seen[3]["state_2"]
        or seen[3]["last_action_1"] != (seen[3]["last_action_2"])
    )  # the walk moves: the two past turns differ


def test_features_refuse_bad_options() -> None:
    """A detector that keeps no statistic, a stack below 1, recurrent without predict."""
    with pytest.raises(TypeError, match="detector=3 must be None, a TabularCusumMonitor"):
        MonitorFeatures(horizon=10, detector=3)
    with pytest.raises(ValueError, match="stack=0"):
        MonitorFeatures(horizon=10, stack=0)
    with pytest.raises(TypeError, match="recurrent=True needs a model with predict"):
        PolicyMonitor(lambda obs: [0], recurrent=True)
    with pytest.raises(TypeError, match="recurrent"):
        PolicyMonitor(lambda obs: [0], recurrent="yes")


class _Recorder:
    """A recurrent model's stand-in: records the state and episode start it is handed."""

    def __init__(self, model: Any) -> None:
        self.model = model
        self.observation_space = model.observation_space
        self.action_space = model.action_space
        self.calls: list[tuple[Any, bool, Any]] = []

    def predict(self, obs: Any, state: Any, episode_start: Any, deterministic: bool) -> Any:
        action, new_state = self.model.predict(
            obs, state=state, episode_start=episode_start, deterministic=deterministic
        )
        self.calls.append((state, bool(episode_start[0]), new_state))
        return action, new_state


def test_recurrent_ppo_trains_in_the_seat_and_plays_back_with_its_state() -> None:
    """RecurrentPPO in the monitor seat; PolicyMonitor(recurrent=True) hands its state back."""
    pytest.importorskip("sb3_contrib")
    import torch
    from sb3_contrib import RecurrentPPO

    torch.set_num_threads(1)
    features = MonitorFeatures(horizon=HORIZON)
    seat = _seat(features)
    model = RecurrentPPO(
        "MultiInputLstmPolicy", seat, n_steps=64, batch_size=64, n_epochs=1, seed=0, device="cpu"
    )
    model.learn(total_timesteps=128)
    obs, _ = seat.reset(seed=4)
    state, start, seat_alarms, t, done = None, True, [], 0, False
    while not done:
        flags, state = model.predict(
            obs, state=state, episode_start=np.array([start]), deterministic=True
        )
        start = False
        if flags[0]:
            seat_alarms.append(t - 1)
        obs, _, terminated, truncated, _ = seat.step(flags)
        t += 1
        done = terminated or truncated
    recorder = _Recorder(model)
    monitor = PolicyMonitor(recorder, features=features, recurrent=True)
    assert _view_alarms(monitor, 4) == seat_alarms
    assert len(recorder.calls) == HORIZON
    assert recorder.calls[0][0] is None and recorder.calls[0][1]
    for (_, _, returned), (handed, start, _) in zip(
        recorder.calls, recorder.calls[1:], strict=False
    ):
        assert handed is returned and not start  # each turn gets the state the last returned
    _view_alarms(monitor, 5)  # a new episode starts the state afresh
    assert recorder.calls[HORIZON][0] is None and recorder.calls[HORIZON][1]


def test_an_episode_from_another_theta0_is_refused_where_the_features_depend_on_it() -> None:
    """The evidence and the detector are built for the bound θ_0, so another is refused.

    ``reset(options={"params": ...})`` started an episode the features still judged against
    the bound θ_0: an unchanging slippery walk read as impossible transitions and false
    alarms. The plain detector refused it already; features without evidence or detector
    depend on no θ_0 and serve it.
    """
    other = {"params": {"slip": (0.5, 0.2, 0.2, 0.1)}}
    flag = lambda obs: np.zeros(1, dtype=np.int64)  # noqa: E731
    for features in (
        MonitorFeatures(horizon=HORIZON),
        MonitorFeatures(horizon=HORIZON, evidence=False, detector=TabularCusumMonitor()),
    ):
        env = _view(PolicyMonitor(flag, features=features))
        with pytest.raises(ValueError, match="θ_0"):
            env.reset(seed=0, options=other)
    plain = _view(PolicyMonitor(flag, features=MonitorFeatures(horizon=HORIZON, evidence=False)))
    plain.reset(seed=0, options=other)
    assert plain.unwrapped.process.nominal_theta0.slip == (0.5, 0.2, 0.2, 0.1)
    seat = _seat(MonitorFeatures(horizon=HORIZON))
    with pytest.raises(ValueError, match="θ_0"):
        seat.reset(seed=0, options=other)
