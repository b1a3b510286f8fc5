"""Benchmark experiments: specs, trials, runner, backends, results and reports.

This package sits at the top of the stack, beside the command line: it runs the agents of
``ns_pz.agents`` on the environments of ``ns_pz.envs``. ``import ns_pz`` does not load it.
"""

from ns_pz.experiments.backends import LocalBackend, RayBackend, make_backend
from ns_pz.experiments.runner import RunSummary, run_spec
from ns_pz.experiments.spec import ExperimentSpec, SpecError, load_spec, shipped_specs
from ns_pz.experiments.store import ResultStore
from ns_pz.experiments.trials import Trial, expand, run_trial

__all__ = [
    "ExperimentSpec",
    "LocalBackend",
    "RayBackend",
    "ResultStore",
    "RunSummary",
    "SpecError",
    "Trial",
    "expand",
    "load_spec",
    "make_backend",
    "run_spec",
    "run_trial",
    "shipped_specs",
]
