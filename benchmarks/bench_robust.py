"""Which way of training gives a robust agent? Plain PPO, domain randomisation, RARL, RARL+pool.

Two tasks (``--task``): CartPole (nature moves the pole's length and mass) and MuJoCo's
InvertedPendulum (nature tilts gravity and adds dry friction to the cart's rail), both cut at
200 steps. Each method trains a PPO agent for the same number of agent steps, from each of
several training seeds:

* ``plain``: on θ_0, stationary;
* ``dr``: under domain randomisation (:class:`ns_pz.nature.DomainRandomisation`) over a
  training box of θ_0 values;
* ``rarl``: alternating with a PPO nature (:func:`ns_pz.learning.rarl`), the nature held by the
  game to a Lipschitz bound and a budget on the parameters it may move;
* ``rarl-pool``: the same, the agent meeting natures drawn from a pool of the last rounds'.

Every final agent is then scored by :func:`ns_pz.learning.evaluate_robustness` with the same
evaluation seeds: on θ_0, over a θ grid wider than the training box (mean and worst member),
against a suite of scripted natures, and against fresh PPO adversaries trained against it
(the strongest of several, picked on selection episodes). Per method the table gives the
interquartile mean over training seeds with a 95 % percentile-bootstrap interval over seeds
(rliable's recipe, :func:`ns_pz.learning.aggregate_runs`).

Run from the repository root with the ``learn`` extra (each (method, seed) job is saved as it
ends; ``--resume`` skips saved ones)::

    python benchmarks/bench_robust.py --out /tmp/bench_robust --workers 2
    python benchmarks/bench_robust.py --task invertedpendulum --out /tmp/robust_ip --workers 2
    python benchmarks/bench_robust.py --quick --out /tmp/bench_robust_quick   # a smoke run
    python benchmarks/bench_robust.py --tabular --out /tmp/x --workers 2  # the calibration
    python benchmarks/bench_robust.py --throughput 16384 --out /tmp/x       # n_envs speed

The calibration (``--tabular``): on FrozenLake, where nature's exact best response to a fixed
agent is computable (:func:`ns_pz.agents.exact.nature_best_response`), each way of training a
PPO adversary is scored by the fraction of the exact achievable harm it finds. Both natures move
the whole slip vector within the same limits (0.1 a step, ``--lake-budget`` in all, in total
variation); the exact one chooses among a lattice of step 0.05 that holds every vertex of those
limits. With a budget of 0.1 or more the exact response leaves the agent almost nothing (0.002
of 1.0) and every way of training found nearly all of it; the default budget of 0.05 leaves
0.114, so a partial find shows.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

METHODS = ("plain", "dr", "rarl", "rarl-pool")
STATISTICS = ("nominal", "grid mean", "grid worst", "suite", "adversary")


@dataclass(frozen=True)
class Budget:
    """Sizes of one run."""

    agent_steps: int
    rounds: int
    eval_episodes: int
    adversary_trials: int
    adversary_steps: int


QUICK = Budget(agent_steps=1024, rounds=2, eval_episodes=2, adversary_trials=1, adversary_steps=512)


@dataclass(frozen=True)
class Task:
    """One environment of the benchmark: what every method trains in and is scored on.

    The callables are module-level functions, so a task travels to worker processes by name.
    """

    env_id: str
    horizon: int
    constraints: Callable[[], Any]
    """Nature's limits, in training (RARL) and in every scored condition."""
    training_box: Callable[[], Any]
    """Domain randomisation's training distribution (the grid reaches beyond it)."""
    suite: Callable[[], dict[str, Any]]
    """Scripted natures every agent meets."""
    grid: dict[str, list[float]]
    """θ_0 values scored, the product of the per-parameter lists."""
    quick_grid: dict[str, list[float]]
    hyperparameters: dict[str, Any]
    """PPO's settings, for the agent and for every nature."""
    full: Budget


def cartpole_constraints() -> Any:
    """Nature may move the pole's length and mass, within a per-step bound and a budget.

    The budget keeps the pole at least 0.2 long: with more, a nature learns to shrink it to
    almost nothing, where no controller balances it (every agent then lasts about 11 steps).
    """
    from ns_pz.nature import NatureConstraints

    moves = {"length": (0.02, 0.3), "masspole": (0.01, 0.2)}
    return NatureConstraints(
        lipschitz={name: step for name, (step, _) in moves.items()},
        budget={
            **{name: total for name, (_, total) in moves.items()},
            **dict.fromkeys(("gravity", "masscart", "force_mag", "tau"), 0.0),
        },
    )


def cartpole_box() -> Any:
    """CartPole's domain randomisation: length and pole mass, uniform."""
    from ns_pz.nature import DomainRandomisation, Uniform

    return DomainRandomisation({"length": Uniform(0.25, 1.5), "masspole": Uniform(0.05, 0.3)})


def cartpole_suite() -> dict[str, Any]:
    """CartPole's scripted natures."""
    from ns_pz.nature import (
        ContinuousScheduler,
        IncrementUpdate,
        PeriodicScheduler,
        RandomWalk,
        ScriptedNature,
    )

    return {
        "pole grows": ScriptedNature(
            {"length": IncrementUpdate(ContinuousScheduler(start=1), k=0.05)}
        ),
        "pole mass jumps": ScriptedNature(
            {"masspole": IncrementUpdate(PeriodicScheduler(period=50, start=1), k=0.2)}
        ),
        "random walk": ScriptedNature(
            {"length": RandomWalk(ContinuousScheduler(start=1), sigma=0.05)}
        ),
    }


def pendulum_constraints() -> Any:
    """Nature may tilt gravity and add dry friction to the cart's rail, and nothing else.

    These are the two knobs that hurt a PPO controller trained on θ_0 (measured over each
    knob's range: pole mass from 1.1 to 25 and slider damping up to 10 left it at 200 of 200
    steps; a tilt of 0.1 rad cut it to 56–68 steps, 50 N of rail friction to 74). Tilt moves by
    at most 0.01 rad a step and 0.1 rad in all; friction by 1 N a step and 15 N in all.
    """
    from ns_pz.nature import NatureConstraints

    moves = {"gravity_tilt": (0.01, 0.1), "rail_friction": (1.0, 15.0)}
    return NatureConstraints(
        movable=tuple(moves),
        lipschitz={name: step for name, (step, _) in moves.items()},
        budget={name: total for name, (_, total) in moves.items()},
    )


def pendulum_box() -> Any:
    """InvertedPendulum's domain randomisation: tilt and rail friction, uniform."""
    from ns_pz.nature import DomainRandomisation, Uniform

    return DomainRandomisation(
        {"gravity_tilt": Uniform(-0.1, 0.1), "rail_friction": Uniform(0.0, 15.0)}
    )


def pendulum_suite() -> dict[str, Any]:
    """InvertedPendulum's scripted natures (held to the same constraints as RARL's)."""
    from ns_pz.nature import (
        ContinuousScheduler,
        IncrementUpdate,
        PeriodicScheduler,
        RandomWalk,
        ScriptedNature,
    )

    return {
        "tilt drifts": ScriptedNature(
            {"gravity_tilt": IncrementUpdate(ContinuousScheduler(start=1), k=0.001)}
        ),
        "friction jumps": ScriptedNature(
            {"rail_friction": IncrementUpdate(PeriodicScheduler(period=50, start=1), k=5.0)}
        ),
        "tilt random walk": ScriptedNature(
            {"gravity_tilt": RandomWalk(ContinuousScheduler(start=1), sigma=0.005)}
        ),
    }


TASKS = {
    "cartpole": Task(
        env_id="ns_pz/CartPole-v0",
        horizon=200,
        constraints=cartpole_constraints,
        training_box=cartpole_box,
        suite=cartpole_suite,
        grid={"length": [0.25, 0.75, 1.5], "masspole": [0.05, 0.2, 0.5]},
        quick_grid={"length": [0.5, 1.5], "masspole": [0.1]},
        # RL Zoo's CartPole settings, 8 environments, 10 epochs instead of 20
        hyperparameters={
            "n_steps": 32,
            "batch_size": 256,
            "gae_lambda": 0.8,
            "gamma": 0.98,
            "n_epochs": 10,
            "learning_rate": 1e-3,
            "ent_coef": 0.0,
        },
        full=Budget(
            agent_steps=32_000,
            rounds=4,
            eval_episodes=8,
            adversary_trials=2,
            adversary_steps=8_000,
        ),
    ),
    "invertedpendulum": Task(
        env_id="ns_pz/InvertedPendulum-v0",
        horizon=200,
        constraints=pendulum_constraints,
        training_box=pendulum_box,
        suite=pendulum_suite,
        grid={"gravity_tilt": [-0.15, 0.0, 0.15], "rail_friction": [0.0, 15.0, 30.0]},
        quick_grid={"gravity_tilt": [-0.1, 0.1], "rail_friction": [5.0]},
        # SB3's PPO defaults but for 8 environments of 128 steps a rollout: 64k steps bring
        # a θ_0 agent to 200 of 200 steps (a first trial: 32k steps gave 94)
        hyperparameters={
            "n_steps": 128,
            "batch_size": 256,
            "n_epochs": 10,
            "learning_rate": 3e-4,
            "gamma": 0.99,
        },
        full=Budget(
            agent_steps=64_000,
            rounds=4,
            eval_episodes=8,
            adversary_trials=2,
            adversary_steps=16_000,
        ),
    ),
}


def env_kwargs(task: Task) -> dict[str, Any]:
    """The environment every method trains and is scored in."""
    return {"max_episode_steps": task.horizon, "constraints": task.constraints()}


def ppo(task: Task, steps: int) -> Any:
    """PPO with the task's settings for ``steps`` steps."""
    from ns_pz.learning import TrainArgs

    return TrainArgs(total_timesteps=steps, hyperparameters=task.hyperparameters)


def train_agent(task: Task, method: str, seed: int, budget: Budget) -> Any:
    """The final agent of ``method`` from training seed ``seed``."""
    from ns_pz.learning import make_seat_env, rarl, train
    from ns_pz.learning.seats import single_agent

    kwargs = env_kwargs(task)
    if method in ("plain", "dr"):
        if method == "dr":
            kwargs["nature"] = task.training_box()
        env = make_seat_env(lambda: single_agent(task.env_id, "agent", **kwargs), n_envs=8)
        return train(env, ppo(task, budget.agent_steps), seed)
    per_round = budget.agent_steps // budget.rounds
    result = rarl(
        task.env_id,
        rounds=budget.rounds,
        agent_args=ppo(task, per_round),
        nature_args=ppo(task, per_round),
        seed=seed,
        population=3 if method == "rarl-pool" else None,
        n_envs=8,
        **kwargs,
    )
    return result.agent


def job(task_name: str, method: str, seed: int, quick: bool, out: Path) -> dict[str, Any]:
    """Train and score one agent; save and return its scores."""
    import torch

    torch.set_num_threads(1)
    from ns_pz.learning import AdversarySearch, evaluate_robustness

    task = TASKS[task_name]
    budget = QUICK if quick else task.full
    started = time.perf_counter()
    cpu_started = time.process_time()
    agent = train_agent(task, method, seed, budget)
    trained = time.perf_counter() - started
    report = evaluate_robustness(
        agent,
        task.env_id,
        grid=task.quick_grid if quick else task.grid,
        natures=task.suite(),
        adversaries=AdversarySearch(
            trials=budget.adversary_trials,
            args=ppo(task, budget.adversary_steps),
            selection_episodes=max(2, budget.eval_episodes // 2),
            n_envs=8,
        ),
        episodes=budget.eval_episodes,
        seed=100_000,
        **env_kwargs(task),
    )
    suite_means = [report.row(label).mean.value for label in task.suite()]
    scores = {
        "nominal": report.row("nominal").mean.value,
        "grid mean": report.row("grid").mean.value,
        "grid worst": report.row("grid").worst.value,  # type: ignore[union-attr]
        "suite": float(np.mean(suite_means)),
        "adversary": report.row("adversary").mean.value,
    }
    record = {
        "task": task_name,
        "quick": quick,
        "method": method,
        "seed": seed,
        "scores": scores,
        "train_seconds": trained,
        "total_seconds": time.perf_counter() - started,
        "cpu_seconds": time.process_time() - cpu_started,
        "report": report.to_dict(),
    }
    path = out / f"{method}_{seed}.json"
    partial = path.with_suffix(".part")
    partial.write_text(json.dumps(record))
    os.replace(partial, path)  # a job killed mid-write leaves no truncated record
    return record


def table(records: list[dict[str, Any]]) -> str:
    """IQM over seeds [95 % bootstrap interval] per method and statistic, and training time.

    The last column is the median wall time of training one agent (the runs' load varies, so
    it is a rough cost, not a speed measurement).
    """
    from ns_pz.learning import aggregate_runs

    lines = [
        "| method | seeds | " + " | ".join(STATISTICS) + " | training s |",
        "|---|---|" + "---|" * (len(STATISTICS) + 1),
    ]
    for method in METHODS:
        runs = [r for r in records if r["method"] == method]
        if not runs:
            continue
        cells = []
        for name in STATISTICS:
            estimate = aggregate_runs([r["scores"][name] for r in runs])
            cells.append(f"{estimate.value:.1f} [{estimate.low:.1f}, {estimate.high:.1f}]")
        cells.append(f"{np.median([r['train_seconds'] for r in runs]):.0f}")
        lines.append(f"| {method} | {len(runs)} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


LAKE = "ns_pz/FrozenLake-v0"
LAKE_HORIZON = 100
WAYS = {
    "PPO, 4,096 steps": {"steps": 4096},
    "PPO, 16,384 steps, 8 envs": {"steps": 16384, "n_envs": 8},
    "best of 3 PPO runs, 4,096 steps each": {"steps": 4096, "restarts": 3},
}
"""Ways of training an adversary, scored against nature's exact best response."""


def lake_setting(budget: float) -> tuple[dict[str, Any], Any]:
    """FrozenLake without slip; nature moves the slip vector 0.1 a step, ``budget`` in all."""
    from ns_pz.nature import NatureConstraints

    limits = NatureConstraints(lipschitz=0.1, budget=budget)
    kwargs = {
        "params": {"slip": (1.0, 0.0, 0.0)},
        "constraints": limits,
        "max_episode_steps": LAKE_HORIZON,
    }
    return kwargs, limits


LAKE_STEP = 0.05
"""Spacing of the slip vectors nature's exact best response chooses from."""


def lake_agent() -> Any:
    """The θ_0-optimal agent: a fixed time-indexed policy, blind to changes."""
    from ns_pz.agents.exact import PolicyAgent, oracle_solution
    from ns_pz.envs.registry import make_gym

    kwargs, _ = lake_setting(1.0)
    process = make_gym(LAKE, **kwargs).unwrapped.process
    solution = oracle_solution(process.family, [process.base_theta0] * LAKE_HORIZON, 1.0)
    return PolicyAgent(solution.policy, name="θ_0-optimal")


def lake_values(budget: float) -> tuple[float, float]:
    """The agent's exact value when nothing changes, and under nature's exact best response.

    Nature's exact response chooses among every slip vector of the simplex on a lattice of
    step :data:`LAKE_STEP` (231 points), the moves held to the same total-variation limits as
    the learned nature's, which moves the vector continuously: the lattice holds every vertex
    of a move's limits, so the exact response is (up to the lattice) the best any nature can
    do, and a learned one finds a fraction of its harm.
    """
    from ns_pz.agents.exact import (
        nature_best_response,
        nature_grid,
        oracle_solution,
        start_value,
    )
    from ns_pz.envs.registry import make_gym

    kwargs, limits = lake_setting(budget)
    env = make_gym(LAKE, **kwargs)
    process = env.unwrapped.process
    theta0 = process.base_theta0
    solution = oracle_solution(process.family, [theta0] * LAKE_HORIZON, 1.0)
    static = start_value(process.family, solution.values)
    n = round(1 / LAKE_STEP)
    simplex = [
        theta0.replace(slip=(i * LAKE_STEP, j * LAKE_STEP, (n - i - j) * LAKE_STEP))
        for i in range(n + 1)
        for j in range(n + 1 - i)
    ]
    grid = nature_grid(simplex, theta0, limits, budget_unit=LAKE_STEP)
    response = nature_best_response(env, solution.policy, grid, LAKE_HORIZON)
    return float(static), float(response.value)


def tabular_job(way: str, seed: int, episodes: int, budget: float) -> dict[str, Any]:
    """Train one adversary the way ``way`` says against the θ_0-optimal agent; its harm."""
    import torch

    torch.set_num_threads(1)
    from ns_pz.learning import TrainArgs, episode_returns, train_adversary
    from ns_pz.learning.seats import single_agent
    from ns_pz.nature import PolicyNature

    options = dict(WAYS[way])
    kwargs, _ = lake_setting(budget)
    steps = options.pop("steps")
    args = TrainArgs(
        total_timesteps=steps,
        hyperparameters={
            "n_steps": 256 // options.get("n_envs", 1),
            "batch_size": 64,
            "learning_rate": 3e-3,
        },
    )
    agent = lake_agent()
    started = time.perf_counter()
    model = train_adversary(
        LAKE, agent, args=args, seed=seed, nature_observes_state=True, **options, **kwargs
    )
    seconds = time.perf_counter() - started
    env = single_agent(
        LAKE, "agent", {"nature": PolicyNature(model, observes_state=True)}, **kwargs
    )
    returns = episode_returns(env, agent, range(50_000, 50_000 + episodes))
    return {"way": way, "seed": seed, "value": float(np.mean(returns)), "seconds": seconds}


def tabular(seeds: int, episodes: int, workers: int, budget: float) -> str:
    """The fraction of nature's exact achievable harm each way of training finds."""
    from ns_pz.learning import aggregate_runs

    static, best = lake_values(budget)
    with ProcessPoolExecutor(max_workers=max(1, workers)) as pool:
        futures = [
            pool.submit(tabular_job, w, s, episodes, budget) for w in WAYS for s in range(seeds)
        ]
        records = [f.result() for f in futures]
    lines = [
        f"FrozenLake, the θ_0-optimal agent at none: exact value {static:.3f} when nothing "
        f"changes, {best:.4f} under nature's exact best response (the slip simplex, step "
        f"{LAKE_STEP:g}; budget {budget:g})",
        "",
        "| way of training | seeds | agent's return | fraction of the exact harm | "
        "per seed | training seconds |",
        "|---|---|---|---|---|---|",
    ]
    for way in WAYS:
        runs = [r for r in records if r["way"] == way]
        value = aggregate_runs([r["value"] for r in runs])
        fractions = [(static - r["value"]) / (static - best) for r in runs]
        harm = aggregate_runs(fractions)
        seconds = np.mean([r["seconds"] for r in runs])
        lines.append(
            f"| {way} | {len(runs)} | {value.value:.3f} [{value.low:.3f}, {value.high:.3f}] | "
            f"{harm.value:.2f} [{harm.low:.2f}, {harm.high:.2f}] | "
            + " ".join(f"{f:.2f}" for f in fractions)
            + f" | {seconds:.0f} |"
        )
    return "\n".join(lines)


def balance(observation: dict[str, Any]) -> int:
    """A fixed linear controller that balances CartPole's stationary pole."""
    s = observation["state"]
    return int(0.1 * s[0] + 0.3 * s[1] + s[2] + 0.5 * s[3] > 0)


def throughput(steps: int) -> str:
    """Nature-training steps per second against a fixed controller, by number of environments.

    1 env, 8 in-process and 8 in subprocesses, PPO with 2,048 steps a rollout in every case.
    """
    import torch

    torch.set_num_threads(1)
    from ns_pz.learning import TrainArgs, train_adversary

    task = TASKS["cartpole"]
    lines = ["| environments | steps/s | seconds |", "|---|---|---|"]
    for n_envs, vec_env in ((1, "dummy"), (8, "dummy"), (8, "subproc")):
        args = TrainArgs(
            total_timesteps=steps, hyperparameters={"n_steps": 2048 // n_envs, "batch_size": 256}
        )
        started = time.perf_counter()
        train_adversary(
            task.env_id, balance, args=args, n_envs=n_envs, vec_env=vec_env, **env_kwargs(task)
        )
        seconds = time.perf_counter() - started
        label = "1" if n_envs == 1 else f"{n_envs}, {vec_env}"
        lines.append(f"| {label} | {steps / seconds:.0f} | {seconds:.1f} |")
    return "\n".join(lines) + "\n\n" + agent_throughput(steps)


def agent_throughput(steps: int) -> str:
    """The agent's PPO training under domain randomisation: 8 single envs or the batched core.

    CPU seconds of ``steps`` steps (CartPole's PPO settings), SB3's ``DummyVecEnv`` of
    :func:`ns_pz.single_agent` envs against :func:`ns_pz.learning.make_agent_vec_env`, each
    after a short untimed run (the first one in a process pays torch's and SB3's first use).
    """
    from ns_pz.learning import make_agent_vec_env, make_seat_env, train
    from ns_pz.learning.seats import single_agent

    task = TASKS["cartpole"]
    kwargs = {**env_kwargs(task), "nature": task.training_box()}
    builders = {
        "8 single envs (DummyVecEnv)": lambda: make_seat_env(
            lambda: single_agent(task.env_id, "agent", **kwargs), n_envs=8
        ),
        "8 in the batched core (make_agent_vec_env)": lambda: make_agent_vec_env(
            task.env_id, 8, **kwargs
        ),
    }
    for build in builders.values():  # first use of torch and SB3's modules, not timed
        train(build(), ppo(task, 512), seed=0)
    lines = ["| agent's environments | CPU seconds | steps/CPU-s |", "|---|---|---|"]
    for label, build in builders.items():
        started = time.process_time()
        train(build(), ppo(task, steps), seed=0)
        seconds = time.process_time() - started
        lines.append(f"| {label} | {seconds:.1f} | {steps / seconds:.0f} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    """Run the jobs (in parallel), then print the table."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, required=True, help="folder of the per-job JSON")
    parser.add_argument("--task", choices=sorted(TASKS), default="cartpole")
    parser.add_argument("--seeds", type=int, default=5, help="training seeds per method")
    parser.add_argument("--methods", nargs="+", default=list(METHODS), choices=METHODS)
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--quick", action="store_true", help="tiny sizes: a smoke run")
    parser.add_argument("--resume", action="store_true", help="keep jobs saved in --out")
    parser.add_argument(
        "--tabular",
        action="store_true",
        help="instead: ways of training an adversary against nature's exact best response",
    )
    parser.add_argument("--episodes", type=int, default=1000, help="--tabular's scoring episodes")
    parser.add_argument(
        "--lake-budget",
        type=float,
        default=0.05,
        help="--tabular: nature's total slip budget (0.1 already lets nature win outright)",
    )
    parser.add_argument(
        "--throughput",
        type=int,
        metavar="STEPS",
        help="instead: nature-training steps/s with 1 and 8 environments, STEPS steps each",
    )
    args = parser.parse_args(argv)
    if args.throughput:
        print(throughput(args.throughput))
        return
    if args.tabular:
        print(tabular(args.seeds, args.episodes, args.workers, args.lake_budget))
        return
    args.out.mkdir(parents=True, exist_ok=True)
    records = []
    todo = []
    for seed in range(args.seeds):
        for method in args.methods:
            path = args.out / f"{method}_{seed}.json"
            if args.resume and path.exists():
                record = json.loads(path.read_text())
                if record.get("task", "cartpole") != args.task:
                    raise SystemExit(f"{path} is of task {record.get('task', 'cartpole')!r}")
                if record.get("quick", False) != args.quick:
                    size = "--quick" if args.quick else "full"
                    raise SystemExit(f"{path} is not of this run's size ({size}); use a new --out")
                records.append(record)
            else:
                todo.append((method, seed))
    started = time.perf_counter()
    run: Callable[..., Any] = job
    with ProcessPoolExecutor(max_workers=max(1, args.workers)) as pool:
        futures = {pool.submit(run, args.task, m, s, args.quick, args.out): (m, s) for m, s in todo}
        for future in as_completed(futures):
            record = future.result()
            records.append(record)
            print(
                f"{record['method']} seed {record['seed']}: "
                + ", ".join(f"{k} {v:.1f}" for k, v in record["scores"].items())
                + f" ({record['total_seconds']:.0f} s, {time.perf_counter() - started:.0f} s in)",
                flush=True,
            )
    print(table(records))


if __name__ == "__main__":
    main()
