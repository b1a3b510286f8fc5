"""A nature driven by any policy over nature's observation: a trained adversary, put anywhere.

:class:`PolicyNature` is a :class:`~ns_pz.nature.policies.Nature`, so it goes wherever a
schedule goes — ``gym.make(..., nature=...)``, :func:`ns_pz.make`, :func:`ns_pz.make_vec`,
:func:`ns_pz.single_agent` — and sees and acts exactly as a learner in nature's seat does,
through the one :class:`~ns_pz.nature.interface.NatureInterface` of the process it drives.
"""

from __future__ import annotations

import weakref
from typing import TYPE_CHECKING, Any

import numpy as np

from ns_pz.checks import flag
from ns_pz.nature.interface import DEFAULT_STEP, NATURE_ACTIONS, NatureInterface, check_default_step
from ns_pz.nature.policies import Nature, Proposal
from ns_pz.params import Params
from ns_pz.seat_policies import (
    call_policy,
    check_policy,
    check_policy_spaces,
    is_recurrent,
)

if TYPE_CHECKING:
    from ns_pz.process import NSProcess


class PolicyNature(Nature):
    """Nature played by a policy: a callable ``obs -> action`` or an SB3-style model.

    Args:
        policy: The policy; SB3 models are asked with ``predict(obs, deterministic=...)``.
        action: The action convention the policy was trained with: ``"normalized"`` (default,
            as :func:`ns_pz.single_agent` trains) or ``"delta"``.
        observes_state: Whether its observation includes the agent's state and last action.
        default_step: Allowance of a parameter without a Lipschitz bound, as a fraction of its
            size at θ_0 (as in training).
        deterministic: Passed to ``predict``; sampling (``False``) draws from nature's generator,
            so one seed reproduces it.

    An SB3 model's own spaces are checked against nature's seat in the environment it is put
    in: a model trained with another ``action`` or ``observes_state`` is refused at its first
    move (where the two conventions' bounds coincide, as on a grid's slip vector, nothing tells
    them apart).

    Raises:
        TypeError / ValueError: An argument outside its allowed values, or a recurrent model
            (sb3-contrib's ``RecurrentPPO``), whose state nature's seat does not carry.
    """

    def __init__(
        self,
        policy: Any,
        *,
        action: str = "normalized",
        observes_state: bool = False,
        default_step: float = DEFAULT_STEP,
        deterministic: bool = True,
    ) -> None:
        check_policy(policy, "nature", "PolicyNature(policy)")
        if is_recurrent(policy):
            raise TypeError(
                f"PolicyNature(policy={policy!r}): a recurrent model needs its state carried "
                "from one move to the next, which PolicyNature does not do; train nature with "
                "a feed-forward policy, or give nature's observation the history it needs"
            )
        if action not in NATURE_ACTIONS:
            raise ValueError(f"action={action!r}; allowed: {NATURE_ACTIONS}")
        self.policy = policy
        self.action = action
        self.observes_state = flag("observes_state", observes_state)
        self.default_step = check_default_step(default_step)
        self.deterministic = flag("deterministic", deterministic)
        # The interfaces (one per environment it drives) its spaces were checked against.
        self._checked: weakref.WeakSet[NatureInterface] = weakref.WeakSet()

    def act(self, process: NSProcess) -> Proposal:
        """Observe ``process`` as a learner in nature's seat would, and decode the action.

        Raises:
            ValueError: The policy's own spaces are not nature's in this environment.
        """
        interface = process.nature_interface(self.action, self.observes_state, self.default_step)
        if interface not in self._checked:
            check_policy_spaces(
                self.policy,
                interface.observation_space,
                interface.action_space,
                "PolicyNature's policy",
                f" (action={self.action!r}, observes_state={self.observes_state}: was it "
                "trained with other ones, or on another environment?)",
            )
            self._checked.add(interface)
        observation = interface.observe(process)
        action = call_policy(
            self.policy, observation, deterministic=self.deterministic, rng=process.nature_rng
        )
        return interface.proposal(np.asarray(action), process.theta)

    def __getstate__(self) -> dict[str, Any]:
        """Pickled without the checked interfaces (weak references; checked again after)."""
        state = dict(self.__dict__)
        del state["_checked"]
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._checked = weakref.WeakSet()

    def propose(
        self, t: int, theta: Params, budget_left: float, memory: Any, rng: np.random.Generator
    ) -> Proposal:
        """Not available: a policy nature reads the whole observation (see :meth:`act`).

        Raises:
            TypeError: Always.
        """
        raise TypeError(
            "PolicyNature acts through act(process); it has no state-free propose(). Put it in "
            "an environment (nature=PolicyNature(...)) instead of calling propose() directly."
        )

    def __repr__(self) -> str:
        return (
            f"PolicyNature({self.policy!r}, action={self.action!r}, "
            f"observes_state={self.observes_state!r})"
        )
