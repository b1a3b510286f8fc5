"""ns_pz.learn: learning happens (small seeded runs), RARL logs and checkpoints, seeding.

Skipped without the ``learn`` extra (stable-baselines3).
"""

from __future__ import annotations

import json
import statistics

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from ns_pz.agents import SnapshotValueIteration  # noqa: E402
from stable_baselines3 import PPO  # noqa: E402

import ns_pz  # noqa: E402
import ns_pz.learning.alternating  # noqa: E402
from ns_pz import DECISION, NATURE  # noqa: E402
from ns_pz.learn import (  # noqa: E402
    TrainArgs,
    episode_returns,
    make_model,
    rarl,
    train_adversary,
)
from ns_pz.nature import (  # noqa: E402
    NatureConstraints,
    PolicyNature,
    RandomNature,
    StaticNature,
)

CARTPOLE = "ns_pz/CartPole-v0"
# Nature may only shorten or lengthen the pole, 2 cm a step and 45 cm an episode.
POLE = {
    "constraints": NatureConstraints(
        lipschitz={"length": 0.02},
        budget={
            "length": 0.45,
            "gravity": 0,
            "masscart": 0,
            "masspole": 0,
            "force_mag": 0,
            "tau": 0,
        },
    ),
    "max_episode_steps": 200,
}
PPO_SMALL = {"n_steps": 256, "batch_size": 64, "learning_rate": 3e-3}


def balance(obs):
    """A fixed controller that balances the stationary pole for the whole episode."""
    state = obs["state"]
    return int(0.1 * state[0] + 0.3 * state[1] + state[2] + 0.5 * state[3] > 0)


LAKE = {
    "params": {"slip": (1.0, 0.0, 0.0)},
    "notification": "none",
    "constraints": NatureConstraints(lipschitz=0.1, budget=0.6),
    "max_episode_steps": 100,
}


def planner_return(nature, episodes=range(100, 140)):
    """VI-snapshot's mean return on the lake against ``nature`` (``None``: θ fixed)."""
    policies = {} if nature is None else {NATURE: nature}
    env = ns_pz.single_agent("ns_pz/FrozenLake-v0", DECISION, policies, **LAKE)
    agent = SnapshotValueIteration(gamma=0.99)
    returns = []
    for seed in episodes:
        observation, _ = env.reset(seed=seed)
        agent.reset(np.random.default_rng(seed))
        total, done = 0.0, False
        while not done:
            action = agent.act(observation, env.planning_model())
            observation, reward, terminated, truncated, _ = env.step(action)
            total += float(reward)
            done = terminated or truncated
        returns.append(total)
    return statistics.fmean(returns)


@pytest.mark.parametrize("seed", [0, 1])
def test_a_ppo_adversary_learns_to_hurt_the_planner(seed):
    """4,096 steps of PPO in nature's seat cost VI-snapshot far more than random or untrained ones.

    On the slippery-free lake (θ_0 = (1, 0, 0), 0.1 a step, 0.6 an episode, not notified) the
    planner always reaches the goal when nothing changes or nature moves at random; a learned,
    state-aware nature makes it fall in about half the time (0.375-0.625 measured over seeds and
    torch thread counts; one thread here, so the run is reproducible).
    """
    torch = pytest.importorskip("torch")
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        model = train_adversary(
            "ns_pz/FrozenLake-v0",
            SnapshotValueIteration(gamma=0.99),
            args=TrainArgs(total_timesteps=4096, hyperparameters=PPO_SMALL),
            seed=seed,
            nature_observes_state=True,
            **LAKE,
        )
        seat = ns_pz.single_agent(
            "ns_pz/FrozenLake-v0",
            NATURE,
            {DECISION: SnapshotValueIteration(gamma=0.99)},
            nature_observes_state=True,
            **LAKE,
        )
        untrained = make_model(seat, TrainArgs(hyperparameters=PPO_SMALL), seed)
    finally:
        torch.set_num_threads(threads)
    learned = planner_return(PolicyNature(model, observes_state=True))
    baselines = {
        "static": planner_return(None),
        "random": planner_return(RandomNature(scale=0.05)),
        "untrained PPO": planner_return(PolicyNature(untrained, observes_state=True)),
    }
    assert baselines["static"] == 1.0
    assert learned < 0.8
    for name, value in baselines.items():
        assert learned < value - 0.2, (name, learned, baselines)


def test_rarl_logs_every_round_and_its_checkpoints_load_and_act_identically(tmp_path):
    """One log line and one pair of checkpoints per round; a loaded agent acts as the live one."""
    small = TrainArgs(total_timesteps=128, hyperparameters={"n_steps": 128, "batch_size": 64})
    result = rarl(
        CARTPOLE,
        rounds=2,
        agent_args=small,
        nature_args=small,
        seed=3,
        out_dir=tmp_path,
        eval_episodes=2,
        **POLE,
    )
    lines = [json.loads(line) for line in (tmp_path / "log.jsonl").read_text().splitlines()]
    assert [line["round"] for line in lines] == [1, 2] == [entry.round for entry in result.log]
    assert [line["agent_timesteps"] for line in lines] == [128, 256]
    assert [line["nature_timesteps"] for line in lines] == [128, 256]
    env = ns_pz.single_agent(CARTPOLE, DECISION, **POLE)
    nature_env = ns_pz.single_agent(CARTPOLE, NATURE, {DECISION: balance}, **POLE)
    agent = PPO.load(tmp_path / "round_2" / "agent.zip")
    nature = PPO.load(tmp_path / "round_2" / "nature.zip")
    for seed in range(3):
        obs, _ = env.reset(seed=seed)
        nature_obs, _ = nature_env.reset(seed=seed)
        assert (
            agent.predict(obs, deterministic=True)[0]
            == result.agent.predict(obs, deterministic=True)[0]
        )
        np.testing.assert_array_equal(
            nature.predict(nature_obs, deterministic=True)[0],
            result.nature.predict(nature_obs, deterministic=True)[0],
        )
    round_1 = PPO.load(tmp_path / "round_1" / "agent.zip")
    assert round_1.num_timesteps == 128
    with pytest.raises(ValueError, match="already holds a RARL run"):
        rarl(CARTPOLE, rounds=1, agent_args=small, nature_args=small, out_dir=tmp_path, **POLE)


def test_rarl_plays_nature_in_the_convention_it_trains(monkeypatch):
    """With nature_action="delta" the agent meets nature's model decoded as deltas too.

    Every PolicyNature rarl builds is recorded: the agent's side must decode as nature learns.
    """
    built = []

    class Recorded(PolicyNature):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            built.append(self)

    monkeypatch.setattr(ns_pz.learning.alternating, "PolicyNature", Recorded)
    small = TrainArgs(total_timesteps=64, hyperparameters={"n_steps": 64, "batch_size": 64})
    result = rarl(
        CARTPOLE,
        rounds=1,
        agent_args=small,
        nature_args=small,
        eval_episodes=1,
        nature_action="delta",
        **POLE,
    )
    assert built and all(nature.action == "delta" for nature in built)  # training and scoring
    # the nature model itself acts in the delta seat's space, and is accepted there
    seat = ns_pz.single_agent(CARTPOLE, NATURE, {DECISION: balance}, nature_action="delta", **POLE)
    assert result.nature.action_space == seat.action_space
    view = ns_pz.single_agent(
        CARTPOLE, DECISION, {NATURE: PolicyNature(result.nature, action="delta")}, **POLE
    )
    view.reset(seed=0)
    view.step(0)


def test_training_is_reproducible_from_its_seed():
    """Two adversaries trained with the same seed have the same weights; another seed differs."""

    def weights(seed):
        model = train_adversary(
            CARTPOLE,
            balance,
            args=TrainArgs(total_timesteps=128, hyperparameters={"n_steps": 128, "batch_size": 64}),
            seed=seed,
            **POLE,
        )
        return [p.detach().numpy().copy() for p in model.policy.parameters()]

    first, again, other = weights(5), weights(5), weights(6)
    assert all(np.array_equal(a, b) for a, b in zip(first, again, strict=True))
    assert not all(np.array_equal(a, b) for a, b in zip(first, other, strict=True))


def test_bad_training_arguments_are_named():
    """TrainArgs and rarl refuse bad values, naming them."""
    with pytest.raises(ValueError, match="algo='Nope'"):
        TrainArgs(algo="Nope")
    with pytest.raises(ValueError, match="total_timesteps=0"):
        TrainArgs(total_timesteps=0)
    with pytest.raises(ValueError, match="rounds=0"):
        rarl(CARTPOLE, rounds=0)
    with pytest.raises(ValueError, match="seed=-1 must be an int in"):
        rarl(CARTPOLE, seed=-1)
    with pytest.raises(TypeError, match="agent_args=\\{'algo': 'PPO'\\} must be a TrainArgs"):
        rarl(CARTPOLE, agent_args={"algo": "PPO"})
    with pytest.raises(TypeError, match="rarl trains nature itself"):
        rarl(CARTPOLE, nature=StaticNature())
    fixed = lambda obs: 1  # noqa: E731
    with pytest.raises(ValueError, match="seed=4294967296 must be an int in \\[0, 4294967296\\)"):
        rarl(CARTPOLE, seed=2**32)  # Stable-Baselines3 seeds np.random with it
    with pytest.raises(ValueError, match="seed=1.5 must be an int in"):
        train_adversary(CARTPOLE, fixed, seed=1.5)
    with pytest.raises(ValueError, match="selection_seed=-3"):
        train_adversary(CARTPOLE, fixed, restarts=2, selection_seed=-3)
    with pytest.raises(TypeError, match="args=\\{'total_timesteps': 256\\} must be a TrainArgs"):
        train_adversary(CARTPOLE, fixed, args={"total_timesteps": 256})


def test_training_arguments_that_training_sets_or_sb3_lacks_are_named():
    """A hyperparameter the algorithm lacks, or one training sets itself, is refused by name."""
    with pytest.raises(ValueError, match=r"hyperparameters\['n_stpes'\].*no such argument"):
        TrainArgs(hyperparameters={"n_stpes": 64})
    with pytest.raises(ValueError, match=r"hyperparameters\['seed'\].*training sets it"):
        TrainArgs(hyperparameters={"seed": 3})
    with pytest.raises(ValueError, match=r"hyperparameters\['n_epochs'\] is not allowed for DQN"):
        TrainArgs(algo="DQN", hyperparameters={"n_epochs": 4})
    with pytest.raises(TypeError, match="hyperparameters=.*mapping"):
        TrainArgs(hyperparameters=[("n_steps", 64)])
    with pytest.raises(ValueError, match="algo='common'"):
        TrainArgs(algo="common")
    steps = TrainArgs(total_timesteps=np.int64(100)).total_timesteps
    assert steps == 100 and type(steps) is int
    with pytest.raises(ValueError, match="total_timesteps=100.0"):
        TrainArgs(total_timesteps=100.0)


def test_episode_returns_takes_every_kind_of_policy():
    """Callables, SB3-style models and (in an agent's view) ns_pz agents; agents elsewhere not."""
    lake = ns_pz.single_agent("ns_pz/FrozenLake-v0", DECISION, **LAKE)
    planner = SnapshotValueIteration(gamma=0.99)
    assert episode_returns(lake, planner, [0, 1]) == episode_returns(lake, planner, [0, 1])
    assert len(episode_returns(lake, lambda obs: 1, [0, 1])) == 2
    seat = ns_pz.single_agent("ns_pz/FrozenLake-v0", NATURE, {DECISION: planner}, **LAKE)
    with pytest.raises(TypeError, match="ns_pz Agent"):
        episode_returns(seat, planner, [0])
    with pytest.raises(TypeError, match="policy=3 cannot drive the agent seat.*ns_pz Agent"):
        episode_returns(lake, 3, [0])
    with pytest.raises(TypeError, match="policy=3 cannot drive the nature seat"):
        episode_returns(seat, 3, [0])


class _Alternating:
    """A recurrent SB3-style model in miniature: pushes left, right, left... from its state.

    Its state counts the episode's steps; asked without it (state ``None``) it starts afresh
    and always pushes left. It carries an LSTM state shape, as sb3-contrib's policies do.
    """

    class policy:  # noqa: N801 - the attribute sb3-contrib's models carry
        lstm_hidden_state_shape = (1, 1, 1)

    def predict(self, obs, state=None, episode_start=None, deterministic=False):
        steps = 0 if state is None or (episode_start is not None and episode_start[0]) else state
        return np.array(steps % 2), steps + 1


def test_a_recurrent_model_carries_its_state_through_each_episode():
    """A recurrent model is played with the state it returned, from a fresh one each episode.

    Asked without its state it started afresh at every step: another policy, scored silently
    (here: always left, which drops the pole sooner). Nature's seat cannot carry it, so
    PolicyNature refuses one; PolicyMonitor asks for recurrent=True.
    """
    from unittest import mock

    from ns_pz.monitor import PolicyMonitor
    from ns_pz.seat_policies import DecisionPolicy, is_recurrent

    env = ns_pz.single_agent(CARTPOLE, DECISION, max_episode_steps=60)
    model = _Alternating()
    assert is_recurrent(model) and not is_recurrent(lambda obs: 1)
    assert not is_recurrent(mock.MagicMock())  # any attribute, but no state shape
    alternating = episode_returns(env, lambda obs: 0, range(3))  # the stateless reading
    assert episode_returns(env, model, range(3)) > alternating
    pushes = []
    decide = DecisionPolicy(model)  # the agent's seat as an opponent plays it
    view = env.unwrapped
    for seed in range(2):
        env.reset(seed=seed)
        decide.reset(np.random.default_rng(seed))
        pushes.append([int(decide(view.process)) for _ in range(4)])
    assert pushes == [[0, 1, 0, 1]] * 2  # carried within an episode, fresh at the next
    with pytest.raises(TypeError, match="recurrent model needs its state carried"):
        PolicyNature(model)
    with pytest.raises(ValueError, match="PolicyMonitor\\(model, recurrent=True\\)"):
        PolicyMonitor(model)
    assert PolicyMonitor(model, recurrent=True).recurrent


def test_sampling_opponents_follow_the_seed_and_leave_torchs_generator_alone():
    """SB3 opponents asked with deterministic=False sample from the seed: one seed, one run."""
    import torch

    agent_env = ns_pz.single_agent(CARTPOLE, DECISION, **POLE)
    agent = make_model(agent_env, TrainArgs(hyperparameters=PPO_SMALL), seed=0)
    nature_env = ns_pz.single_agent(
        CARTPOLE, NATURE, {DECISION: agent}, deterministic=False, **POLE
    )
    zero = np.zeros(nature_env.action_space.shape, np.float32)
    torch.manual_seed(123)
    before = torch.random.get_rng_state()
    first = episode_returns(nature_env, lambda obs: zero, [0, 1, 2])
    assert torch.equal(torch.random.get_rng_state(), before)
    torch.manual_seed(7)  # another global state: the same run
    assert episode_returns(nature_env, lambda obs: zero, [0, 1, 2]) == first
    assert episode_returns(nature_env, lambda obs: zero, [3, 4, 5]) != first


def test_training_leaves_no_log_folders_and_honours_verbose(tmp_path, monkeypatch, capsys):
    """SB3's default logger would make an empty SB3-<date> folder per learn(); ours makes none.

    ``verbose`` among the hyperparameters is the model's verbosity (it clashed with ours).
    """
    import tempfile

    monkeypatch.delenv("SB3_LOGDIR", raising=False)
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    lake = ns_pz.single_agent("ns_pz/FrozenLake-v0", DECISION, max_episode_steps=20)
    quiet = TrainArgs(total_timesteps=64, hyperparameters={"n_steps": 32, "batch_size": 32})
    model = ns_pz.learn.train(lake, quiet, seed=0)
    assert model.verbose == 0
    assert capsys.readouterr().out == ""
    loud = TrainArgs(
        total_timesteps=64, hyperparameters={"n_steps": 32, "batch_size": 32, "verbose": 1}
    )
    model = ns_pz.learn.train(lake, loud, seed=0)
    assert model.verbose == 1
    assert "total_timesteps" in capsys.readouterr().out
    assert list(tmp_path.iterdir()) == []


def test_the_strongest_of_several_adversaries_is_kept_and_holds_on_other_episodes():
    """Restarts: each nature from its own seed, ranked on selection episodes.

    The one kept is at least as strong as the single run of the first seed on held-out
    episodes.
    """
    torch = pytest.importorskip("torch")
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        trials = ns_pz.learning.train_adversaries(
            "ns_pz/FrozenLake-v0",
            SnapshotValueIteration(gamma=0.99),
            restarts=3,
            args=TrainArgs(total_timesteps=2048, hyperparameters=PPO_SMALL),
            seed=0,
            selection_episodes=20,
            nature_observes_state=True,
            **LAKE,
        )
    finally:
        torch.set_num_threads(threads)
    assert len(trials.models) == len(trials.selection_returns) == 3
    assert trials.best == int(np.argmin(trials.selection_returns))
    assert trials.strongest is trials.models[trials.best]
    single, kept = (
        planner_return(PolicyNature(model, observes_state=True))
        for model in (trials.models[0], trials.strongest)
    )
    assert kept <= single
    assert kept < planner_return(None) - 0.2  # it learned to hurt the planner


def test_vectorised_training_matches_its_seed_and_runs_in_subprocesses():
    """n_envs environments: reproducible from the seed, in this process or in subprocesses."""
    args = TrainArgs(total_timesteps=256, hyperparameters={"n_steps": 32, "batch_size": 64})

    def weights(**kwargs):
        model = train_adversary(CARTPOLE, balance, args=args, seed=3, **kwargs, **POLE)
        assert model.n_envs == kwargs.get("n_envs", 1)
        return [p.detach().numpy().copy() for p in model.policy.parameters()]

    first, again = weights(n_envs=4), weights(n_envs=4)
    assert all(np.array_equal(a, b) for a, b in zip(first, again, strict=True))
    parallel = weights(n_envs=2, vec_env="subproc")
    assert all(np.isfinite(p).all() for p in parallel)
    with pytest.raises(ValueError, match="vec_env='threads'"):
        weights(n_envs=2, vec_env="threads")
    with pytest.raises(ValueError, match="n_envs=0"):
        weights(n_envs=0)


def test_rarl_with_a_population_meets_past_natures_and_scores_a_suite(tmp_path):
    """The pool grows by the nature the agent met each round, up to its size.

    The suite is scored every round; stochastic opponents follow the seed; a file as out_dir
    is refused before any training.
    """
    small = TrainArgs(total_timesteps=64, hyperparameters={"n_steps": 32, "batch_size": 32})

    def run(**kwargs):
        options = {"rounds": 1, "eval_episodes": 1, "eval_suite": {"static": StaticNature()}}
        options.update(kwargs)
        return rarl(CARTPOLE, agent_args=small, nature_args=small, **options, **POLE)

    result = run(rounds=3, population=1, n_envs=2)
    assert [entry.population for entry in result.log] == [1, 2, 2]
    assert len(result.population) == 3
    assert all(set(entry.suite_returns) == {"static"} for entry in result.log)
    stochastic = run(deterministic_opponents=False).agent.policy.state_dict()
    again = run(deterministic_opponents=False).agent.policy.state_dict()
    assert all((stochastic[k] == again[k]).all() for k in stochastic)
    file = tmp_path / "a_file"
    file.write_text("")
    with pytest.raises(ValueError, match="is a file"):
        run(out_dir=file)
    with pytest.raises(ValueError, match="population=0"):
        run(population=0)
    with pytest.raises(TypeError, match="eval_suite\\['x'\\]=1"):
        run(eval_suite={"x": 1})


def test_rarl_in_subprocesses_meets_frozen_opponents_and_reproduces():
    """vec_env="subproc": each phase ships frozen opponents to subprocesses, seeded per phase.

    The pool grows as in-process, the run reproduces from its seed, and an unknown vec_env is
    refused before any training.
    """
    small = TrainArgs(total_timesteps=64, hyperparameters={"n_steps": 32, "batch_size": 32})

    def run():
        options = {"rounds": 2, "eval_episodes": 1, "population": 1}
        return rarl(
            CARTPOLE,
            agent_args=small,
            nature_args=small,
            n_envs=2,
            vec_env="subproc",
            **options,
            **POLE,
        )

    from stable_baselines3.common.vec_env import SubprocVecEnv

    first, second = run(), run()
    assert isinstance(first.agent.get_env(), SubprocVecEnv)  # the last phase's, now closed
    assert isinstance(first.nature.get_env(), SubprocVecEnv)
    assert [entry.population for entry in first.log] == [1, 2]
    assert first.agent.num_timesteps == first.nature.num_timesteps == 128
    for model in ("agent", "nature"):
        a = getattr(first, model).policy.state_dict()
        b = getattr(second, model).policy.state_dict()
        assert all((a[k] == b[k]).all() for k in a)
    assert [e.agent_return_mean for e in first.log] == [e.agent_return_mean for e in second.log]
    with pytest.raises(ValueError, match="vec_env='threads'"):
        rarl(CARTPOLE, rounds=1, n_envs=2, vec_env="threads")


def test_the_batched_agent_env_trains_under_domain_randomisation_and_reproduces():
    """make_agent_vec_env: PPO learns CartPole in the batched core, per-episode θ_0 drawn.

    Seeded runs agree; SB3 sees its episode statistics; autoreset_mode is SB3's to fix.
    """
    from ns_pz.learning import make_agent_vec_env, train
    from ns_pz.nature import DomainRandomisation, Uniform

    nature = DomainRandomisation({"length": Uniform(0.4, 0.6)})
    args = TrainArgs(
        total_timesteps=12_288,
        hyperparameters={
            "n_steps": 32,
            "batch_size": 256,
            "gae_lambda": 0.8,
            "gamma": 0.98,
            "learning_rate": 1e-3,
            "ent_coef": 0.0,
        },
    )

    def run(args):
        env = make_agent_vec_env(CARTPOLE, 8, nature=nature, max_episode_steps=200)
        return train(env, args, seed=3)

    short = TrainArgs(total_timesteps=512, hyperparameters=args.hyperparameters)
    weights, other = (run(short).policy.state_dict() for _ in range(2))
    assert all((weights[k] == other[k]).all() for k in weights)
    model = run(args)
    assert len(model.ep_info_buffer) > 0
    env = ns_pz.single_agent(CARTPOLE, DECISION, {NATURE: nature}, max_episode_steps=200)
    untrained = make_model(env, args, seed=3)
    trained_mean = np.mean(episode_returns(env, model, range(100, 110)))
    untrained_mean = np.mean(episode_returns(env, untrained, range(100, 110)))
    assert trained_mean > max(50.0, 3 * untrained_mean)  # seen: 83.8 against 10.2
    with pytest.raises(ValueError, match="autoreset_mode='NextStep'"):
        make_agent_vec_env(CARTPOLE, 2, autoreset_mode="NextStep")


def test_a_snapshot_of_a_policy_leaves_torch_s_generator_where_it_was():
    """RARL's snapshots build a policy anew; its initial weights must not consume SB3's stream.

    Otherwise taking a pool snapshot would change every later sample of the training.
    """
    import torch

    from ns_pz.learning.alternating import _frozen

    model = make_model(ns_pz.single_agent(CARTPOLE, DECISION, **POLE), TrainArgs(), seed=0)
    torch.manual_seed(5)
    expected = torch.rand(3)
    torch.manual_seed(5)
    snapshot = _frozen(model.policy)
    assert torch.equal(torch.rand(3), expected)
    weights, copied = model.policy.state_dict(), snapshot.state_dict()
    assert all(torch.equal(weights[k], copied[k]) for k in weights)
