"""Monitors and notification levels: the oracle, imperfect oracles, detectors, and scoring."""

from ns_pz.monitor.cusum import TabularCusumMonitor
from ns_pz.monitor.drift import PredictionErrorMonitor
from ns_pz.monitor.features import MonitorFeatures
from ns_pz.monitor.learned import PolicyMonitor
from ns_pz.monitor.monitors import Monitor, OracleMonitor
from ns_pz.monitor.noisy import NoisyOracleMonitor
from ns_pz.monitor.notification import NotificationLevel
from ns_pz.monitor.scoring import (
    DetectionReward,
    DetectionSummary,
    EpisodeDetection,
    detection_metrics,
    detection_reward,
    score_episode,
)

__all__ = [
    "DetectionReward",
    "DetectionSummary",
    "EpisodeDetection",
    "Monitor",
    "MonitorFeatures",
    "NoisyOracleMonitor",
    "NotificationLevel",
    "OracleMonitor",
    "PolicyMonitor",
    "PredictionErrorMonitor",
    "TabularCusumMonitor",
    "detection_metrics",
    "detection_reward",
    "score_episode",
]
