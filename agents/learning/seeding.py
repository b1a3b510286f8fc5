"""Independent random streams for the learners, all from one training seed (numpy only)."""

from __future__ import annotations

import numpy as np


def training_seeds(seed: int) -> tuple[np.random.Generator, int, int]:
    """Independent streams of one training seed: ``(generator, env seed, initialisation seed)``.

    Spawned from ``numpy.random.SeedSequence(seed)``, so the learner's own draws, the
    environment's episodes and the network initialisation never share a stream (seeding the
    generator and the environment with the same integer gives them the same stream).
    """
    own, env, init = np.random.SeedSequence(seed).spawn(3)
    return (
        np.random.default_rng(own),
        int(env.generate_state(1)[0]),
        int(init.generate_state(1)[0]),
    )
