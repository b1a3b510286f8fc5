"""Notification levels: what the decision agent may be told about changes of θ.

=========  ==========================================  =================================
level      in the observation                          planning model handed to the agent
=========  ==========================================  =================================
none       nothing about θ (fields are zero)           stationary snapshot with θ_0
basic      ``env_change``: one 0/1 flag per parameter  stationary snapshot with θ_0
detailed   flags and ``delta_change``: change sizes    stationary snapshot with current θ
=========  ==========================================  =================================

The observation fields exist at every level, so the observation space never depends on it.
"""

from __future__ import annotations

from enum import StrEnum


class NotificationLevel(StrEnum):
    """How much the decision agent learns about changes of θ."""

    NONE = "none"
    BASIC = "basic"
    DETAILED = "detailed"

    @classmethod
    def parse(cls, value: object) -> NotificationLevel:
        """Accept a level or its name (``"none"``, ``"basic"``, ``"detailed"``).

        Raises:
            ValueError: Any other value.
        """
        if isinstance(value, cls):
            return value
        for level in cls:
            if value == level.value:
                return level
        allowed = ", ".join(repr(level.value) for level in cls)
        raise ValueError(f"notification={value!r} is not a notification level; allowed: {allowed}")

    @property
    def shows_flags(self) -> bool:
        """Whether ``env_change`` is filled."""
        return self is not NotificationLevel.NONE

    @property
    def shows_sizes(self) -> bool:
        """Whether ``delta_change`` is filled and the planning model holds the current θ."""
        return self is NotificationLevel.DETAILED
