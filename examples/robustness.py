"""How robust is a controller? Score two CartPole controllers over θ and against natures.

Two fixed linear controllers (no training needed: swap in any SB3 model or ns_pz agent) are
scored by ``ns_pz.evaluate_robustness`` on θ_0, over a grid of pole lengths and masses, and
against a suite of natures: a pole that grows, and domain randomisation over a held-out test
part of a θ set. Both meet the same seeds, so the difference is theirs.
"""

import ns_pz
from ns_pz.nature import (
    ContinuousScheduler,
    DomainRandomisation,
    IncrementUpdate,
    ScriptedNature,
    ThetaSet,
)


def cautious(observation):
    """Pushes against the lean and the cart's drift."""
    x, velocity, angle, spin = observation["state"]
    return int(0.1 * x + 0.3 * velocity + angle + 0.5 * spin > 0)


def twitchy(observation):
    """Reacts to the pole's angle alone."""
    return int(observation["state"][2] > 0)


lengths = ThetaSet.grid({"length": [0.3, 0.5, 0.8, 1.2, 1.6, 2.0]})
train, test = lengths.split(1 / 3, seed=0)  # train on one part, report the held-out one
natures = {
    "pole grows": ScriptedNature({"length": IncrementUpdate(ContinuousScheduler(start=1), k=0.01)}),
    "held-out lengths": DomainRandomisation(test),
}
for name, controller in (("cautious", cautious), ("twitchy", twitchy)):
    report = ns_pz.evaluate_robustness(
        controller,
        "ns_pz/CartPole-v0",
        grid={"length": [0.25, 1.0, 2.0], "masspole": [0.05, 0.5]},
        natures=natures,
        episodes=10,
        seed=0,
        max_episode_steps=200,
    )
    print(f"{name} controller (test lengths {[m['length'] for m in test]}):")
    print(report.table(), end="\n\n")
