"""DDQN with notification: the θ_0 Q-network, fine-tuned on each notified change.

The paper's DDQN with notification. When the observation flags a change, the agent collects
transitions in the planning model handed over (at ``detailed`` it has the new θ), ε-greedy from
the current state and back to the current state whenever a simulated episode ends, and makes
Double-DQN updates on them; it then acts greedily. Fixed from NS-Gym: ε is used (NS-Gym collects
greedily), a restart stays under the new θ at the current state (NS-Gym's ``env.reset()`` went
back to θ_0), and the target network is a separate copy. The updates are those of the θ_0
training (:class:`ns_pz.agents.learning.ddqn.DoubleDQN`, NumPy: no torch needed to act).

**Validated fine-tuning.** Gradient steps on a few hundred transitions gathered around one
state cannot re-learn a Q-function; they move the shared layers, and that flips greedy choices
in states the data never visited. Measured on the quick CliffWalking table (p 1 -> 0.8, five
agent seeds), the exact value of the greedy policy fell from -21.7 to between -480 and -900 with
a fresh Adam at 1e-3, and still to -65 .. -955 with plain SGD at 1e-4, Adam at 1e-4, only the
per-state input weights trained, or a penalty towards the pre-change weights or outputs; at an
unchanged θ one seed in five broke from 88 to -200. So the budget is split into ``checks``
rounds, and after each round the candidate's greedy policy is scored in the handed model:
``evaluation_episodes`` episodes from the current state (at most ``max_episode_steps`` steps
each), every candidate on the same sampled transitions (common random numbers, a generator
seeded once per fine-tuning). The network kept is the best one scored, the pre-change network
included; a candidate replaces it only if its mean return is higher by more than
:data:`ACCEPT_Z` standard errors of the paired differences. Fine-tuning therefore never keeps a
network that does worse where the agent is, as far as the model can tell, and keeps one that
does better when the data show it (FrozenLake p 0.7 -> 0.4: 0.3 -> 0.7 on some seeds). These
scoring episodes are not part of the budget; ``last_fine_tuning`` reports their steps.

**Budget.** Step counts (``model_steps`` transitions and ``gradient_steps`` updates per
notified change), so results do not depend on the machine, or the paper's wall-clock budget
(``time_budget`` seconds, 0.4 in the paper): then each round interleaves one transition and one
update (once the buffer holds a batch) until its share of the time is spent, as NS-Gym does;
the scoring between rounds is not counted.
Measured equivalence (``python benchmarks/bench_fine_tuning.py --time 0.4 --seeds 3``, quick
CliffWalking, the 2-core development machine shared with other jobs): 0.4 s bought 91 to 125
transitions and 28 to 62 gradient steps per fine-tuning (means over 3 seeds per setting), so
the default 200 transitions and 50 updates are of the same order; the scoring episodes took
another 1 248 (unchanged θ) to 16 647 (p = 0.4, where policies run to the step cap) steps.

**Changes at every step.** The paper's budget is per change, and the scoring above is not
part of it: with 16 scoring episodes of up to ``max_episode_steps`` steps for each of
``checks + 1`` networks, scoring costs far more than the budget it validates (on the quick
CartPole table with a change at every step, scoring was about nine tenths of the agent's time).
``interval`` spaces the fine-tunings at least that many steps apart; a change notified in
between is kept pending and fine-tuned for at the next allowed step, in the model handed then
(the latest θ). Given ``interval`` times the per-change budget, the agent collects and trains
as much per step as on every change, and scores ``interval`` times fewer candidates. The
default, 1, is the paper's rule: every notified change.

The fine-tuned network lasts for the rest of the episode; :meth:`reset` restores the θ_0 one.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
from gymnasium import spaces
from ns_pz.agents.base import Agent
from ns_pz.agents.learning.config import DDQNArgs
from ns_pz.agents.learning.ddqn import DoubleDQN, compiled_step
from ns_pz.agents.learning.features import features
from ns_pz.agents.learning.mlp import one_blas_thread
from ns_pz.agents.learning.q_agent import check_fine_tuning
from ns_pz.agents.learning.replay import ReplayBuffer
from ns_pz.agents.search.compiled import CompiledModel, compile_model, kernels

#: A candidate network replaces the kept one only if its mean scoring return is higher by more
#: than this many standard errors of the paired differences (a one-sided test at about 2.5 %).
ACCEPT_Z = 2.0

#: Transitions the fine-tuning buffer holds (over all fine-tunings of one episode).
BUFFER_CAPACITY = 20_000


def improves(candidate: np.ndarray, kept: np.ndarray, z: float = ACCEPT_Z) -> bool:
    """Whether paired returns ``candidate`` beat ``kept`` by more than ``z`` standard errors.

    Args:
        candidate: ``[episodes]`` returns of the candidate, episode ``i`` on the same sampled
            transitions as ``kept[i]``.
        kept: ``[episodes]`` returns of the kept network (at least 2 episodes).
        z: Standard errors of the mean difference that the mean difference must exceed.
    """
    difference = np.asarray(candidate, dtype=float) - np.asarray(kept, dtype=float)
    mean = float(difference.mean())
    error = float(difference.std(ddof=1)) / math.sqrt(len(difference))
    return mean > 0.0 and mean > z * error


class FineTunedDDQNAgent(Agent):
    """Greedy on a Q-network that is fine-tuned in the handed model after each notified change.

    Args:
        weights: The θ_0 Q-network (exported arrays).
        observation_space: The base environment's observation space.
        args: The DDQN settings (learning rate, γ, τ, batch size, weight decay; the scoring
            episodes are cut at ``max_episode_steps``).
        model_steps: Transitions simulated in the handed model per notified change.
        gradient_steps: Double-DQN updates per notified change.
        epsilon: Exploration of the simulated transitions.
        time_budget: Seconds of simulation and updates per notified change (the paper: 0.4);
            None: the step counts. Set, it replaces them.
        checks: Rounds the budget is split into; the candidate after each is scored.
        evaluation_episodes: Scoring episodes per candidate (at least 2).
        validate: False: no scoring, the last network is kept (the paper's and NS-Gym's
            fine-tuning; with ``checks=1`` exactly this module's behaviour before validation).
        interval: Fewest steps between two fine-tunings (1: on every notified change). A change
            notified sooner is not dropped: the next fine-tuning, as soon as the interval has
            passed, is made in the model handed then (the latest θ).

    Raises:
        ValueError, TypeError: A budget below 0, ε outside [0, 1], a time budget that is not a
            finite number > 0, fewer than 1 check or 2 scoring episodes, an interval below 1.
    """

    def __init__(
        self,
        weights: dict[str, np.ndarray],
        observation_space: Any,
        args: DDQNArgs,
        *,
        model_steps: int,
        gradient_steps: int,
        epsilon: float,
        time_budget: float | None = None,
        checks: int = 5,
        evaluation_episodes: int = 16,
        validate: bool = True,
        interval: int = 1,
    ) -> None:
        check_fine_tuning(
            model_steps,
            gradient_steps,
            epsilon,
            time_budget,
            checks,
            evaluation_episodes,
            validate,
            interval,
        )
        self.validate = validate
        self.interval = interval
        self.weights = weights
        self.space = observation_space
        self.args = args
        self.model_steps, self.gradient_steps, self.epsilon = model_steps, gradient_steps, epsilon
        self.time_budget = None if time_budget is None else float(time_budget)
        self.checks, self.evaluation_episodes = checks, evaluation_episodes
        self.fine_tunings = 0
        self.last_fine_tuning: dict[str, Any] = {}

    @property
    def needs_model(self) -> bool:
        """The handed model is what it fine-tunes in."""
        return True

    def reset(self, rng: np.random.Generator) -> None:
        """Back to the θ_0 network, with a fresh buffer."""
        super().reset(rng)
        self.learner = DoubleDQN.from_weights(self.weights, "q", self.args)
        size = len(features(self.space, self.space.sample()))
        self.buffer = ReplayBuffer(BUFFER_CAPACITY, size)
        self.fine_tunings = 0
        self.last_fine_tuning = {}
        self.pending = False  # a notified change not fine-tuned for yet
        self.wait = 0  # steps until a fine-tuning is allowed again

    def act(self, observation: dict[str, Any], model: Any | None = None) -> int:
        """Fine-tune first if a change is flagged (or pending) and allowed, then act greedily.

        Raises:
            ValueError: A fine-tuning is due and no model was handed over.
        """
        self.pending = self.pending or bool(np.any(observation["env_change"]))
        if self.pending and self.wait <= 0:
            if model is None:
                raise ValueError("DDQN-WN needs the planning model on a notified change")
            with one_blas_thread():  # the same network whatever threads the process has
                self._fine_tune(model)
            self.pending, self.wait = False, self.interval
        self.wait -= 1
        return self.learner.greedy(features(self.space, observation["state"]))

    def _fine_tune(self, model: Any) -> None:
        """Train in rounds from the current state; keep the best-scoring network."""
        start = model.get_state()
        scoring_seed = int(self.rng.integers(2**63))
        learner = self.learner
        kept = learner.params.copy()
        kept_returns, scored = np.zeros(2), 0
        if self.validate:
            kept_returns, scored = self._greedy_returns(model, start, scoring_seed)
        learner.sync_target()
        learner.reset_optimizer()  # a fresh Adam per fine-tuning
        add = self._collector(model, start)
        made = updates = accepted = 0
        for k in range(self.checks):
            if self.time_budget is None:
                share = _share(self.model_steps, k, self.checks)
                add(share)
                made += share
                steps = _share(self.gradient_steps, k, self.checks)
                updates += learner.replay_steps(self.buffer, self.rng, steps)
            else:
                deadline = time.perf_counter() + self.time_budget / self.checks
                while time.perf_counter() < deadline:
                    add(1)
                    made += 1
                    if self.buffer.size >= self.args.batch_size:
                        updates += learner.replay_steps(self.buffer, self.rng, 1)
            if not self.validate:
                kept, accepted = learner.params.copy(), k + 1
                continue
            returns, steps = self._greedy_returns(model, start, scoring_seed)
            scored += steps
            if improves(returns, kept_returns):
                kept, kept_returns = learner.params.copy(), returns
                accepted = k + 1
        learner.params[:] = kept
        self.fine_tunings += 1
        self.last_fine_tuning = {
            "model_steps": made,
            "gradient_steps": updates,
            "accepted_round": accepted,
            "scoring_steps": scored,
            "kept_return": float(np.mean(kept_returns)) if self.validate else None,
        }

    def _collector(self, model: Any, start: Any) -> Callable[[int], None]:
        """A function adding its argument's number of ε-greedy transitions to the buffer.

        The transitions start at ``start`` and go back to it after a terminal one; they go on
        from call to call. Where :meth:`_compiled_family` allows and the greedy action runs
        compiled (:meth:`~ns_pz.agents.learning.ddqn.DoubleDQN.products` on one row), one
        compiled call adds them (``_mlp_kernels.collect_transitions``: the same draws, actions
        and stored bits as :meth:`_transitions`); otherwise :meth:`_transitions` does.
        """
        learner = self.learner
        compiled = None
        if isinstance(self.space, spaces.Box) and learner.products(1) is not None:
            compiled = self._compiled_family(model)
        start_vector = np.empty(0)  # never a network's width
        if compiled is not None:
            start_vector = np.array(compiled.family.to_vector(start), dtype=np.float64)
        if compiled is None or len(start_vector) != learner.widths[0]:
            transitions = self._transitions(model, start)

            def add(count: int) -> None:
                for _ in range(count):
                    self.buffer.add(*next(transitions))

            return add
        state = start_vector.copy()
        num_actions = int(model.action_space.n)
        data, model_rng = compiled.data, compiled.rng

        def add_compiled(count: int) -> None:
            buffer = self.buffer
            if buffer.features.shape[1] != len(state):  # the kernel writes rows unchecked
                raise ValueError(
                    f"the replay buffer holds {buffer.features.shape[1]} features; "
                    f"the model's states have {len(state)}"
                )
            compiled_step().collect_transitions(  # type: ignore[union-attr]  # numba is there
                data, state, start_vector, count, self.epsilon, num_actions,
                learner.products(1), learner.layout, learner.params, buffer.features,
                buffer.actions, buffer.rewards, buffer.next_features, buffer.terminated,
                buffer.next_row, self.rng, model_rng,
            )  # fmt: skip
            buffer.wrote(count)

        return add_compiled

    def _transitions(self, model: Any, start: Any) -> Iterator[tuple[Any, ...]]:
        """ε-greedy transitions from ``start``, back to ``start`` after a terminal one.

        A state's features are computed once: the next state's are the next transition's own.
        """
        observe = model.family.observe
        num_actions = int(model.action_space.n)
        start_x = features(self.space, observe(start))
        state, x = start, start_x
        while True:
            if self.rng.random() < self.epsilon:
                action = int(self.rng.integers(num_actions))
            else:
                action = self.learner.greedy(x)
            next_state, reward, terminal = model.transition(state, action)
            next_x = features(self.space, observe(next_state))
            yield x, action, float(reward), next_x, terminal
            state, x = (start, start_x) if terminal else (next_state, next_x)

    def _greedy_returns(self, model: Any, start: Any, seed: int) -> tuple[np.ndarray, int]:
        """``[evaluation_episodes]`` greedy returns from ``start`` and the steps they took.

        The episodes run side by side (one forward pass per step for all of them) on
        ``model.family.step`` under ``model.theta`` with a generator seeded by ``seed``, so two
        networks scored with one seed meet the same random draws; the handed model's own
        generator and state are left alone. Under a family whose step never draws
        (``deterministic_step``: CartPole) the episodes are copies of one another, so one is
        played for all: the same returns and step count, the family's step and the features paid
        once (on CartPole with two episodes, 17 µs a scoring step against 20–28).
        """
        rng = np.random.default_rng(seed)
        family, theta = model.family, model.theta
        observe, step = family.observe, family.step
        episodes = self.evaluation_episodes
        # A step that never draws plays every episode alike: one is played, and the network
        # still sees a row per episode (a product over fewer rows may round differently).
        played = 1 if getattr(family, "deterministic_step", False) else episodes
        if played == 1:
            compiled = self._compiled_scoring(model)
            if compiled is not None:
                data, vector, blas = compiled
                total, steps = compiled_step().greedy_episode(  # type: ignore[union-attr]
                    data,
                    vector(start),
                    blas,
                    self.learner.layout,
                    self.learner.params,
                    episodes,
                    self.args.max_episode_steps,
                    rng,
                )
                return np.full(episodes, float(total)), int(steps) * episodes
        states = [start] * played
        returns = np.zeros(played)
        live = list(range(played))
        steps = 0
        for _ in range(self.args.max_episode_steps):
            if not live:
                break
            x = np.stack([features(self.space, observe(states[i])) for i in live])
            if played < episodes:
                x = np.repeat(x, episodes, axis=0)
            actions = self.learner.greedy_rows(x).tolist()
            if played < episodes:  # copies of one row: its action
                actions = actions[:1]
            still = []
            for i, action in zip(live, actions, strict=True):
                states[i], reward, terminal = step(states[i], int(action), theta, rng)
                returns[i] += float(reward)
                if not terminal:
                    still.append(i)
            steps += len(live)
            live = still
        if played < episodes:
            return np.repeat(returns, episodes), steps * episodes
        return returns, steps

    def _compiled_scoring(self, model: Any) -> tuple[Any, Any, np.ndarray] | None:
        """``(data, to_vector, blas)`` to score in compiled code, or None for Python.

        Possible where :meth:`_compiled_family` is and the network's products can run compiled
        on the scoring's rows (:meth:`~ns_pz.agents.learning.ddqn.DoubleDQN.products`): the
        same returns, in one call per scoring instead of a NumPy forward pass and a Python step
        per step.
        """
        blas = self.learner.products(self.evaluation_episodes)
        compiled = self._compiled_family(model) if blas is not None else None
        if compiled is None:
            return None
        vector = compiled.family.to_vector
        return compiled.data, lambda state: np.asarray(vector(state), dtype=np.float64), blas

    def _compiled_family(self, model: Any) -> CompiledModel | None:
        """``model`` compiled where its family has a compiled step fit for the DQN kernels.

        That is one of ns_pz's families whose observation is its state vector rounded to
        float32 (CartPole); otherwise None.
        """
        compiled = compile_model(model, "auto")
        if compiled is None or not compiled.family.float32_observation:
            return None
        # the cached kernel serves ns_pz's own families; a subclass elsewhere may step otherwise
        for cls in (type(model.family), type(compiled.data)):
            if not cls.__module__.startswith("ns_pz."):
                return None
        kernels()  # the families' compiled steps register before a kernel that calls them
        return compiled

    def __repr__(self) -> str:
        budget = (
            f"time_budget={self.time_budget}"
            if self.time_budget is not None
            else f"model_steps={self.model_steps}, gradient_steps={self.gradient_steps}"
        )
        return (
            f"FineTunedDDQNAgent({budget}, epsilon={self.epsilon}, checks={self.checks}, "
            f"evaluation_episodes={self.evaluation_episodes}, validate={self.validate}, "
            f"interval={self.interval})"
        )


def _share(total: int, k: int, parts: int) -> int:
    """Round ``k``'s part of ``total`` split into ``parts`` nearly equal whole parts."""
    return total * (k + 1) // parts - total * k // parts
