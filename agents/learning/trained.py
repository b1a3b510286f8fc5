"""The trained networks agents use: which artefact an agent needs, and getting it.

An agent bound to an environment needs networks trained on that environment's θ_0
(:class:`Needed`: the artefact request and how to train it). :func:`obtain` loads it from the
cache, training it first (under the key's lock) if it is missing. Training imports torch
(the ``learn`` extra); loading does not.
"""

from __future__ import annotations

import importlib
import time
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
from ns_pz.agents.learning.artefacts import ArtefactRequest, Trainer, load_or_train
from ns_pz.agents.learning.config import AlphaZeroArgs, DDQNArgs

from ns_pz import __version__
from ns_pz.views import NSGymEnv

#: Bump a learner's number when its training changes what it produces.
CODE_VERSIONS = {"ddqn": "1", "alphazero": "1"}


@dataclass(frozen=True)
class Needed:
    """An artefact an agent needs: its request and how to train it.

    Attributes:
        request: The artefact's identity (its key).
        train: ``train() -> (weights, info)``; imports torch when called.
        label: One line for progress messages.
    """

    request: ArtefactRequest
    train: Trainer
    label: str


def training_env(env: NSGymEnv, max_episode_steps: int) -> NSGymEnv:
    """A stationary copy of ``env``'s family at its θ_0 (no nature), for training."""
    return NSGymEnv(env.family, params=env.base_params, max_episode_steps=max_episode_steps)


#: Fields that only matter when acting, so they are not part of an artefact's key.
DECISION_ONLY = frozenset({"search_iterations"})


def _request(learner: str, env: NSGymEnv, args: Any) -> ArtefactRequest:
    training_args = {k: v for k, v in asdict(args).items() if k not in DECISION_ONLY}
    return ArtefactRequest(
        learner=learner,
        family=repr(env.family),
        theta0=env.base_params.as_dict(),
        args=training_args,
        seed=args.seed,
        code_version=f"{__version__}/{learner}-{CODE_VERSIONS[learner]}",
    )


def _torch_module(name: str) -> Any:
    try:
        return importlib.import_module(f"ns_pz.agents.learning.{name}")
    except ImportError as error:
        raise ImportError(
            f"training needs torch ({error}); on a CPU-only machine: "
            "pip install torch==2.13.0 && pip install 'ns_pz[learn]'"
        ) from None


def ddqn_needed(env: NSGymEnv, args: DDQNArgs) -> Needed:
    """The Double-DQN Q-network trained on ``env``'s θ_0 with ``args`` (widths resolved)."""
    args = args.for_family(env.family)

    def train() -> tuple[Mapping[str, np.ndarray], Mapping[str, Any]]:
        module = _torch_module("ddqn")
        return module.train_ddqn(training_env(env, args.max_episode_steps), args, args.seed)

    label = f"DDQN {env.family!r} θ0={env.base_params.as_dict()} {args.total_steps} steps"
    return Needed(_request("ddqn", env, args), train, label)


def alphazero_needed(env: NSGymEnv, args: AlphaZeroArgs) -> Needed:
    """The AlphaZero policy/value network trained by self-play on ``env``'s θ_0."""
    args = args.for_family(env.family)

    def train() -> tuple[Mapping[str, np.ndarray], Mapping[str, Any]]:
        module = _torch_module("alphazero")
        return module.train_alphazero(training_env(env, args.max_episode_steps), args, args.seed)

    label = f"AlphaZero {env.family!r} θ0={env.base_params.as_dict()} {args.episodes} episodes"
    return Needed(_request("alphazero", env, args), train, label)


def obtain(needed: Needed, root: Path | None = None) -> dict[str, np.ndarray]:
    """The weights of ``needed``, trained now (once across processes) if not cached."""
    weights, _ = load_or_train(needed.request, needed.train, root)
    return weights


def prepare(
    needs: list[Needed],
    root: Path | None = None,
    report: Callable[[Needed, float, bool], None] | None = None,
) -> float:
    """Make sure every artefact in ``needs`` is cached (each distinct key trained once).

    Args:
        needs: Artefacts, possibly repeated.
        root: The cache folder (default: the user cache).
        report: Called per distinct artefact with its seconds and whether it was trained.

    Returns:
        Seconds spent training.
    """
    seen: set[str] = set()
    spent = 0.0
    for need in needs:
        if need.request.key in seen:
            continue
        seen.add(need.request.key)
        start = time.perf_counter()
        _, trained = load_or_train(need.request, need.train, root)
        seconds = time.perf_counter() - start
        spent += seconds if trained else 0.0
        if report is not None:
            report(need, seconds, trained)
    return spent
