"""Detect a change you are not told about: CUSUM detectors on FrozenLake and CartPole.

An honest detector monitor sees only what the agent sees (states, actions, rewards) and θ_0,
never the true θ. Given as ``monitor=`` at ``notification="detailed"``, its alarms reach the agent
as ``env_change`` flags, with its estimate of the change in ``delta_change``.

* FrozenLake (an 8x8 lake without holes, so a random walk lasts): the slip vector changes from
  (0.7, 0.15, 0.15) to (0.2, 0.4, 0.4) at step 150; :class:`TabularCusumMonitor` runs a CUSUM of
  the log-likelihood ratio of each transition against θ_0's outcome table, one per point of a
  grid of slip vectors.
* CartPole: the pole's mass goes from 0.1 to 0.3 at step 40; :class:`PredictionErrorMonitor`
  runs a CUSUM on the θ_0 model's one-step prediction error (zero but for float32 rounding
  while θ = θ_0).

The script prints when each change happened and when it was detected, scores the episodes with
``detection_metrics``, and plots the CUSUM statistic against the true change time into a PNG: the
path given as first argument, or a new file ``ns_pz_detect_change_*.png`` in the temporary
directory, never one that exists already (needs matplotlib, ``pip install "ns_pz[plot]"``; no
display needed).
"""

import os
import sys
import tempfile
from pathlib import Path

import numpy as np

import ns_pz
from ns_pz.monitor import PredictionErrorMonitor, TabularCusumMonitor, detection_metrics
from ns_pz.nature import (
    DiscreteScheduler,
    DistributionStepWiseUpdate,
    ScriptedNature,
    StepWiseUpdate,
)

LAKE = ["SFFFFFFF"] + ["FFFFFFFF"] * 6 + ["FFFFFFFG"]

CASES = {
    "FrozenLake": dict(
        env_id="ns_pz/FrozenLake-v0",
        env_kwargs={"desc": LAKE},
        params={"slip": (0.7, 0.15, 0.15)},
        nature=ScriptedNature(
            {"slip": DistributionStepWiseUpdate(DiscreteScheduler({150}), [(0.2, 0.4, 0.4)])}
        ),
        monitor=TabularCusumMonitor(threshold=10.0),
        policy=lambda observation, rng: int(rng.integers(4)),
    ),
    "CartPole": dict(
        env_id="ns_pz/CartPole-v0",
        env_kwargs={},
        params={"masspole": 0.1},
        nature=ScriptedNature({"masspole": StepWiseUpdate(DiscreteScheduler({40}), [0.3])}),
        monitor=PredictionErrorMonitor(threshold=5.0),
        # push towards the side the pole leans to: keeps it up for a while
        policy=lambda observation, rng: int(observation["state"][2] + observation["state"][3] > 0),
    ),
}


def run_episode(case: dict, seed: int) -> tuple[list[float], list[int], tuple[int, ...], int]:
    """One episode: the CUSUM statistic per transition, the alarms, the true changes, steps."""
    env = ns_pz.make_gym(
        case["env_id"],
        params=case["params"],
        nature=case["nature"],
        monitor=case["monitor"],
        notification="detailed",
        max_episode_steps=400,
        **case["env_kwargs"],
    )
    monitor = case["monitor"]
    # The same detector, replayed on what the agent saw, exposes its statistic for the plot
    # (the env keeps its own copy of the detector's memory; these detectors draw no randomness).
    replay = monitor.initial_memory()
    rng = np.random.default_rng(seed)
    observation, _ = env.reset(seed=seed)
    alarms, statistic, done, steps = [], [], False, 0
    while not done:
        action = case["policy"](observation, rng)
        next_observation, reward, terminated, truncated, _ = env.step(action)
        done = terminated or truncated
        if not done:  # the monitor speaks about a transition only if the episode goes on
            seen = {
                "last_state": observation["state"],
                "last_action": action,
                "last_reward": np.array([reward], np.float32),
                "state": next_observation["state"],
                "relative_time": next_observation["relative_time"],
            }
            monitor.notify(seen, None, replay, rng)
            statistic.append(replay.trace[-1])
        if next_observation["env_change"].any():
            alarms.append(steps)
        observation = next_observation
        steps += 1
    assert alarms == replay.alarms, "the replay sees what the env's monitor saw"
    return statistic, alarms, env.ground_truth().change_times, steps


def main() -> None:
    """Detect, score, plot."""
    traces = {}
    for name, case in CASES.items():
        episodes = []
        for seed in range(5):
            statistic, alarms, changes, steps = run_episode(case, seed)
            episodes.append((changes, alarms, steps))
            if seed == 0:
                traces[name] = (statistic, alarms, changes, case["monitor"].threshold)
        summary = detection_metrics(episodes)
        print(
            f"{name:10s} changes at {[list(e[0]) for e in episodes]}, "
            f"alarms at {[e[1] for e in episodes]}"
        )
        print(
            f"{'':10s} mean delay {summary.mean_delay:.1f} steps, "
            f"{summary.false_alarms_per_1000:.1f} false alarms per 1,000 steps, "
            f"{summary.missed} of {summary.changes} missed"
        )
    try:
        import matplotlib

        matplotlib.use("Agg")  # no display needed
        import matplotlib.pyplot as plt
    except ImportError:
        print('(no plot: matplotlib is missing; pip install "ns_pz[plot]")')
        return
    fig, axes = plt.subplots(1, len(traces), figsize=(11, 3.6))
    for ax, (name, (statistic, alarms, changes, threshold)) in zip(
        axes, traces.items(), strict=True
    ):
        ax.plot(range(1, len(statistic) + 1), statistic, label="CUSUM statistic")
        ax.axhline(threshold, color="grey", linestyle=":", label="threshold")
        for change in changes:
            ax.axvline(change, color="red", linestyle="--", label="true change")
        for alarm in alarms:
            ax.axvline(alarm, color="green", alpha=0.6, label="alarm")
        ax.set_yscale("symlog")
        ax.set_ylim(bottom=0.0)
        ax.set_xlabel("transition")
        ax.set_title(name)
        handles, labels = ax.get_legend_handles_labels()
        unique = dict(zip(labels, handles, strict=True))
        ax.legend(unique.values(), unique.keys(), fontsize="small")
    fig.tight_layout()
    if len(sys.argv) > 1:
        path = Path(sys.argv[1])
    else:  # a file of our own: a fixed name in a shared folder could be anyone's, or a link
        handle, name = tempfile.mkstemp(prefix="ns_pz_detect_change_", suffix=".png")
        os.close(handle)
        path = Path(name)
    fig.savefig(path, dpi=110)
    print(f"plot: {path}")


if __name__ == "__main__":
    main()
