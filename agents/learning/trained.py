"""The trained networks agents use: which artefact an agent needs, and getting it.

An agent bound to an environment needs networks trained on that environment's θ_0
(:class:`Needed`: the artefact request and how to train it). :func:`obtain` loads it from the
cache, training it first (under the key's lock) if it is missing. Both learners train in NumPy
(:mod:`.mlp`), so neither training nor loading needs torch.
"""

from __future__ import annotations

import importlib
import sys
import time
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, TextIO

import numpy as np
from gymnasium import spaces
from ns_pz.agents.learning.artefacts import ArtefactRequest, exists, load_or_train
from ns_pz.agents.learning.config import AlphaZeroArgs, DDQNArgs
from ns_pz.agents.learning.features import feature_size
from ns_pz.agents.learning.mlp import one_blas_thread

from ns_pz import __version__
from ns_pz.views import NSGymEnv
from ns_pz.workers import new_pool, stop_pool

#: Bump a learner's number when its training changes what it produces.
CODE_VERSIONS = {"ddqn": "4", "alphazero": "5"}


@dataclass(frozen=True)
class Needed:
    """An artefact an agent needs: its request and what training it takes.

    Picklable, so a pool of processes can train several at once.

    Attributes:
        request: The artefact's identity (its key).
        env: An environment of the family at the θ_0 to train on (its nature is not used).
        args: The learner's settings, family defaults filled in.
        label: One line for progress messages.
    """

    request: ArtefactRequest
    env: NSGymEnv
    args: DDQNArgs | AlphaZeroArgs
    label: str

    @property
    def work(self) -> tuple[int, str]:
        """How much training it takes: ``(total, unit)``, unit ``"steps"`` or ``"episodes"``."""
        if isinstance(self.args, DDQNArgs):
            return self.args.total_steps, "steps"
        return self.args.episodes, "episodes"

    def train(
        self, progress: Callable[[int, int], bool] | None = None
    ) -> tuple[Mapping[str, np.ndarray], Mapping[str, Any]]:
        """Train the network now (in NumPy): ``(weights, info)``.

        Args:
            progress: Called with ``(done, total)`` in :attr:`work`'s unit as training goes;
                returning True stops it there (the network so far is returned).
        """
        env = training_env(self.env, self.args.max_episode_steps)
        with one_blas_thread():
            if isinstance(self.args, DDQNArgs):
                ddqn = importlib.import_module("ns_pz.agents.learning.ddqn")
                return ddqn.train_ddqn(env, self.args, self.args.seed, progress)
            alphazero = importlib.import_module("ns_pz.agents.learning.alphazero")
            return alphazero.train_alphazero(env, self.args, self.args.seed, progress)


def training_env(env: NSGymEnv, max_episode_steps: int) -> NSGymEnv:
    """A stationary copy of ``env``'s family at its θ_0 (no nature), for training."""
    return NSGymEnv(env.family, params=env.base_params, max_episode_steps=max_episode_steps)


#: Fields that only matter when acting, so they are not part of an artefact's key.
DECISION_ONLY = frozenset({"search_iterations"})


def _request(learner: str, env: NSGymEnv, args: Any) -> ArtefactRequest:
    if not isinstance(env.action_space, spaces.Discrete):
        raise TypeError(f"{learner} needs a Discrete action space; {env!r} has {env.action_space}")
    feature_size(env.family.observation_space)  # a TypeError for spaces a network cannot take
    training_args = {k: v for k, v in asdict(args).items() if k not in DECISION_ONLY}
    return ArtefactRequest(
        learner=learner,
        family=repr(env.family),
        theta0=env.base_params.as_dict(),
        args=training_args,
        seed=args.seed,
        code_version=f"{__version__}/{learner}-{CODE_VERSIONS[learner]}",
    )


def ddqn_needed(env: NSGymEnv, args: DDQNArgs) -> Needed:
    """The Double-DQN Q-network trained on ``env``'s θ_0 with ``args`` (widths resolved)."""
    args = args.for_family(env.family)
    label = f"DDQN {env.family!r} θ0={_theta_text(env)} {args.total_steps} steps"
    return Needed(_request("ddqn", env, args), env, args, label)


def alphazero_needed(env: NSGymEnv, args: AlphaZeroArgs) -> Needed:
    """The AlphaZero policy/value network trained by self-play on ``env``'s θ_0."""
    args = args.for_family(env.family)
    label = f"AlphaZero {env.family!r} θ0={_theta_text(env)} {args.episodes} episodes"
    return Needed(_request("alphazero", env, args), env, args, label)


def _theta_text(env: NSGymEnv) -> str:
    def short(value: Any) -> Any:
        return [round(v, 4) for v in value] if isinstance(value, tuple) else value

    return str({name: short(value) for name, value in env.base_params.as_dict().items()})


def obtain(needed: Needed, root: Path | None = None) -> dict[str, np.ndarray]:
    """The weights of ``needed``, trained now (once across processes) if not cached."""
    weights, _ = load_or_train(needed.request, needed.train, root)
    return weights


def prepare(
    needs: list[Needed],
    root: Path | None = None,
    report: Callable[[Needed, float, bool], None] | None = None,
    workers: int = 1,
    progress: TextIO | None = None,
) -> float:
    """Make sure every artefact in ``needs`` is cached (each distinct key trained once).

    Args:
        needs: Artefacts, possibly repeated.
        root: The cache folder (default: the user cache).
        report: Called per distinct artefact with its seconds and whether it was trained.
        workers: Processes training distinct artefacts at once (1: here, one after another).
        progress: Where each training draws its progress line (steps or episodes done, rate,
            elapsed, ETA); ``None``: none. Training processes of a pool write plain lines to
            their own stderr (lines of several trainings redrawn in place would mix).

    Returns:
        Seconds spent training, summed over artefacts (CPU time of one core each).
    """
    distinct = list({need.request.key: need for need in needs}.values())
    if workers > 1 and sum(not exists(n.request, root) for n in distinct) > 1:
        pool = new_pool(min(workers, len(distinct)))
        clean = False
        count = len(distinct)
        try:
            shown = [progress is not None] * count
            results = list(pool.map(_prepare_in_pool, distinct, [root] * count, shown))
            clean = True
        finally:
            stop_pool(pool, clean)  # interrupted: the training workers stop now
    else:
        results = [_prepare_one(need, root, progress) for need in distinct]
    spent = 0.0
    for need, (seconds, trained) in zip(distinct, results, strict=True):
        spent += seconds if trained else 0.0
        if report is not None:
            report(need, seconds, trained)
    return spent


def _prepare_in_pool(need: Needed, root: Path | None, shown: bool) -> tuple[float, bool]:
    """:func:`_prepare_one` in a pool's process: plain progress lines on its stderr."""
    return _prepare_one(need, root, sys.stderr if shown else None, in_place=False)


def _prepare_one(
    need: Needed, root: Path | None, progress: TextIO | None, in_place: bool | None = None
) -> tuple[float, bool]:
    start = time.perf_counter()
    if progress is None:
        _, trained = load_or_train(need.request, need.train, root)
        return time.perf_counter() - start, trained
    from ns_pz.experiments.progress import Progress  # not at import: experiments import us

    total, unit = need.work
    bar = Progress(total, 0, f"training {need.label}", progress, unit=unit, in_place=in_place)

    def advance(done: int, total: int) -> bool:
        bar.advance(to=done)
        return False

    def train() -> tuple[Mapping[str, np.ndarray], Mapping[str, Any]]:
        try:
            return need.train(advance)
        finally:
            bar.close()

    _, trained = load_or_train(need.request, train, root)
    return time.perf_counter() - start, trained
