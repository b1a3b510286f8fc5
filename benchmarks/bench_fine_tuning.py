"""DDQN-WN's fine-tuning, measured exactly: the greedy policy's value before and after one.

For a tabular spec's quick size (default ``cliffwalking-single``) and each agent seed, the
DDQN-WN agent is told of a change at the start state and handed a model of the θ after the
change; the printed figures are the exact expected returns (:mod:`ns_pz.agents.exact`, no
sampling) from the start state over the spec's horizon of the stationary greedy policy of the
network before and after that one fine-tuning, under that θ. The row ``unchanged`` hands it
a model of θ_0 (nothing changed) and evaluates under θ_0.

``--time S`` runs the agent with the paper's wall-clock budget (``time_budget=S``) and prints
the transitions and gradient steps it bought per fine-tuning: the step counts' equivalence on
this machine. ``--agent '{...}'`` overrides DDQN-WN's hyper-parameters (a Python dict literal).

Run: ``python benchmarks/bench_fine_tuning.py [spec] [--seeds 5] [--time 0.4]``. The network is
trained first if it is not cached (about 20 s for CliffWalking's 40 000 steps).
"""

from __future__ import annotations

import argparse
import ast
from typing import Any

import numpy as np
from ns_pz.agents.catalog import agent_entry
from ns_pz.agents.exact import policy_values, start_value, theta_trajectory
from ns_pz.agents.learning.ddqn import DoubleDQN

from ns_pz.experiments.spec import Cell, load_spec


def greedy_policy(network: DoubleDQN, num_states: int, horizon: int) -> np.ndarray:
    """``[horizon, num_states]``: the network's greedy action in every state, at every step."""
    actions = network.q(np.eye(num_states)).argmax(axis=1)
    return np.tile(actions, (horizon, 1))


def exact_value(env: Any, network: DoubleDQN, theta: Any, horizon: int) -> float:
    """Expected return from the start state of the greedy policy under a constant θ."""
    n = int(env.family.observation_space.n)
    values = policy_values(env.family, [theta] * horizon, greedy_policy(network, n, horizon))
    return start_value(env.family, values)


def told_of_a_change(env: Any, seed: int, theta: Any) -> tuple[dict[str, Any], Any]:
    """A start observation flagging a change, and a model of ``theta`` at that state."""
    observation, _ = env.reset(seed=seed)
    observation = {**observation, "env_change": np.ones_like(observation["env_change"])}
    model = env.planning_model()
    return observation, type(model)(model.family, theta, model.get_state(), model.rng)


def one_row(spec: Any, index: int, seed: int, hyper: dict[str, Any], unchanged: bool) -> dict:
    """Before/after values (and the budget used) of one agent seed in one setting."""
    env = spec.make_env(Cell(spec.settings()[index], "detailed", index))
    thetas = theta_trajectory(env, seed, spec.horizon)
    theta = thetas[0] if unchanged else thetas[-1]
    agent = agent_entry("ddqn_wn").make(env, hyper)
    agent.reset(np.random.default_rng(seed))
    before = exact_value(env, agent.learner, theta, spec.horizon)
    agent.act(*told_of_a_change(env, seed, theta))
    after = exact_value(env, agent.learner, theta, spec.horizon)
    return {"before": before, "after": after, **agent.last_fine_tuning}


def main() -> None:
    """Print one line per setting: before, after per seed, their mean, the budget used."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("spec", nargs="?", default="cliffwalking-single")
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--time", type=float, default=None, help="time_budget in seconds")
    parser.add_argument("--agent", default="{}", help="DDQN-WN hyper-parameters to override")
    options = parser.parse_args()
    spec = load_spec(options.spec, "quick")
    hyper = next(dict(a.hyper) for a in spec.agents if a.name == "ddqn_wn")
    hyper.update(ast.literal_eval(options.agent))
    if options.time is not None:
        hyper["time_budget"] = options.time
    print(f"{spec.name} quick, DDQN-WN {hyper}")
    rows = [("unchanged", 0, True)] + [(s, i, False) for i, s in enumerate(spec.settings())]
    for label, index, unchanged in rows:
        runs = [one_row(spec, index, seed, hyper, unchanged) for seed in range(options.seeds)]
        after = [r["after"] for r in runs]
        budget = {
            key: int(np.mean([r[key] for r in runs]))
            for key in ("model_steps", "gradient_steps", "scoring_steps")
        }
        accepted = sum(r["accepted_round"] > 0 for r in runs)
        print(
            f"{label:10s} before {runs[0]['before']:9.3f}  after "
            f"{' '.join(f'{a:9.3f}' for a in after)}  mean {np.mean(after):9.3f}  "
            f"replaced {accepted}/{len(runs)}  mean budget {budget}"
        )


if __name__ == "__main__":
    main()
