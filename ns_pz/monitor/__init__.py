"""Monitors and notification levels."""

from ns_pz.monitor.learned import PolicyMonitor
from ns_pz.monitor.monitors import Monitor, OracleMonitor
from ns_pz.monitor.notification import NotificationLevel

__all__ = ["Monitor", "NotificationLevel", "OracleMonitor", "PolicyMonitor"]
