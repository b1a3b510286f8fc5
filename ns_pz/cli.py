"""The ``ns-pz`` command: run the paper's benchmark, report it, list what is available.

    ns-pz bench run paper                 every shipped spec, quick size, local processes
    ns-pz bench run frozenlake-single --size full --workers 2 --out results
    ns-pz bench run paper --backend ray [--address auto]
    ns-pz bench run SPEC --out DIR --resume   finish an interrupted run
    ns-pz bench table DIR [--format latex]
    ns-pz bench plot DIR
    ns-pz bench estimate paper --size full    time a few seeds per cell, project the run
    ns-pz bench list                      shipped specs
    ns-pz train paper [--size full]       train (or find cached) the networks the specs' agents use
    ns-pz envs                            registered envs, their θ, defaults and bounds
    ns-pz --version

Exit codes: 0 success; 1 some trials failed (their errors are in the results); 2 bad usage or a
spec/results directory that cannot be used; 130 interrupted (finish with ``--resume``).
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import os
import shutil
import signal
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ns_pz import __version__
from ns_pz.envs.registry import registered_envs, spec

if TYPE_CHECKING:
    from ns_pz.experiments.store import ResultStore

EXIT_OK, EXIT_FAILED_TRIALS, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130
#: What an interrupted command leaves, by command.
INTERRUPTED = {
    "run": "finished trials are saved; the same command with --resume continues",
    "train": "networks finished so far are cached; train again to continue",
    "estimate": "nothing was saved (an estimate keeps nothing)",
    "envs": "nothing was saved",
    "table": "nothing was saved",
    "plot": "figures written so far are kept",
    "list": "nothing was saved",
}
PAPER = "paper"

DESCRIPTION = (
    "The ns-pz command: run the NS-Gym paper's benchmark, report it, list what is available."
)
SIZE_HELP = (
    "quick: a smaller run of every table (the specs' quick episodes, horizons, search iterations "
    "and training budgets; minutes on a few cores); full: the paper's sizes (100 episodes per "
    "cell; hours). Default: %(default)s"
)
BACKEND_HELP = (
    "local: worker processes on this machine; ray: a Ray cluster (the ray extra; --address "
    "names it, else Ray starts locally). Default: %(default)s"
)
MUJOCO_NOTE = (
    "(the eleven MuJoCo tasks, ns_pz/InvertedPendulum-v0 ... ns_pz/HumanoidStandup-v0, are "
    'listed here once the mujoco extra is installed: pip install "ns_pz[mujoco]")'
)


def list_envs(out: Callable[[str], None] = print) -> None:
    """Print every registered environment with its parameters, defaults and bounds.

    Without the ``mujoco`` extra a last line says that the MuJoCo tasks exist and how to get them.
    """
    for env_id in registered_envs():
        env_spec = spec(env_id)
        out(f"{env_id}  (time limit {env_spec.max_episode_steps}): {env_spec.description}")
        for param in env_spec.family.params_cls.specs():
            unit = f" {param.unit}" if param.unit else ""
            out(
                f"    {param.name:10s} default {param.default!r}{unit}, allowed {param.allowed()}"
                f"  - {param.doc}"
            )
    if importlib.util.find_spec("mujoco") is None:  # the registry adds them only with it
        out(MUJOCO_NOTE)


def show_envs(args: argparse.Namespace, out: Callable[[str], None]) -> int:
    """``envs``: every registered environment and its θ."""
    list_envs(out)
    return EXIT_OK


def _spec_names(names: Sequence[str]) -> list[str]:
    from ns_pz.experiments import shipped_specs

    result: list[str] = []
    for name in names:
        result += list(shipped_specs()) if name == PAPER else [name]
    return result


def _run_dirs(root: Path) -> list[Path]:
    """``root`` if it is a results directory, else the results directories inside it."""
    if (root / "spec.json").is_file():
        return [root]
    found = sorted(p.parent for p in root.glob("*/spec.json"))
    if not found:
        raise FileNotFoundError(f"{root} holds no results (no spec.json in it or below it)")
    return found


def bench_run(args: argparse.Namespace, out: Callable[[str], None]) -> int:
    """``bench run``: load every spec first (so a bad one stops the run before any trial)."""
    from ns_pz.experiments import SpecError, load_spec, make_backend, run_spec
    from ns_pz.experiments.lock import locked
    from ns_pz.experiments.store import ResultStore

    backend = make_backend(args.backend, args.workers, args.address)
    failed = 0
    with contextlib.ExitStack() as held:  # one run per directory, from the check to the end
        held.enter_context(backend)  # its workers stay up from one spec to the next
        backend.start()  # they start while the specs load (a bad one stops them at once)
        specs = [load_spec(name, args.size) for name in _spec_names(args.specs)]
        root = Path(args.out)
        if (root / "spec.json").is_file():  # a run's own folder: its runs would nest in it
            raise SpecError(
                f"--out {root} is the folder of a run (it holds spec.json); runs go in "
                f"NAME-SIZE folders under --out: give the folder above it "
                f"(--out {root.resolve().parent})"
            )
        targets = [root / f"{experiment.name}-{experiment.size}" for experiment in specs]
        for target in targets:  # every directory is checked before any trial runs
            if targets.count(target) > 1:
                raise SpecError(f"two of the specs would write to {target}; name each spec once")
        for experiment, target in zip(specs, targets, strict=True):
            try:
                ResultStore(target).check(experiment, args.resume)  # writes nothing
            except SpecError as error:
                if args.resume or not (target / "spec.json").is_file():
                    raise
                raise SpecError(f"{error} (its tables again: ns-pz bench table {target})") from None
        for experiment, target in zip(specs, targets, strict=True):
            held.enter_context(locked(target))
            ResultStore(target).check(experiment, args.resume)  # again, now no one else writes
        for experiment, target in zip(specs, targets, strict=True):
            summary = run_spec(experiment, target, backend, resume=args.resume, progress=sys.stderr)
            failed += summary.failed
            out(f"\n{_tables(target, 'markdown', _terminal_width())}\n")
            out(
                f"({summary.ran} trials run, {summary.skipped} already done, {summary.failed} "
                f"failed; results in {target}/results.csv)"
            )
    return EXIT_FAILED_TRIALS if failed else EXIT_OK


def _terminal_width() -> int | None:
    """The terminal's width when stdout is one (tables are split to fit), else ``None``."""
    if not sys.stdout.isatty():
        return None
    return max(40, shutil.get_terminal_size().columns)


def _tables(run_dir: Path, fmt: str, width: int | None = None) -> str:
    from ns_pz.experiments.optimum import optimum_for
    from ns_pz.experiments.report import table
    from ns_pz.experiments.store import ResultStore

    store = ResultStore(run_dir)
    record = store.spec_record()
    title = f"{record['spec']['title']} [{record['name']}, {record['spec']['size']}]"
    spec_record = record["spec"]
    rows = _readable_rows(store)
    return table(rows, title, fmt, optimum_for(spec_record), spec_record, width=width)


def _readable_rows(store: ResultStore) -> list[dict[str, Any]]:
    """The stored rows; the files of ``trials/`` left out named on stderr, with why."""
    rows, unreadable, strays = store.scan()
    for path, reason in unreadable:
        print(
            f"ns-pz: skipped {path}: unreadable ({reason}); `bench run --resume` re-runs it",
            file=sys.stderr,
        )
    for path, reason in strays:
        print(f"ns-pz: skipped {path}: {reason}", file=sys.stderr)
    return rows


def _each_run(root: Path, report_fn: Callable[[Path], None]) -> int:
    """Call ``report_fn`` on each results directory under ``root``; skip unreadable ones.

    A directory whose ``spec.json`` cannot be used is named on stderr with the reason, and the
    others are still reported.

    Returns:
        ``EXIT_OK``, or ``EXIT_USAGE`` if no directory could be reported.
    """
    from ns_pz.experiments import SpecError

    reported = 0
    for run_dir in _run_dirs(root):
        try:
            report_fn(run_dir)
        except SpecError as error:
            print(f"ns-pz: skipped {run_dir}: {error}", file=sys.stderr)
            continue
        reported += 1
    return EXIT_OK if reported else EXIT_USAGE


def bench_table(args: argparse.Namespace, out: Callable[[str], None]) -> int:
    """``bench table``: the tables of every run under DIR."""
    width = _terminal_width() if args.width is None else (args.width or None)
    return _each_run(
        Path(args.dir), lambda run_dir: out(_tables(run_dir, args.format, width) + "\n")
    )


def bench_plot(args: argparse.Namespace, out: Callable[[str], None]) -> int:
    """``bench plot``: figures into each run's ``plots/`` folder, or into ``--out``."""
    from ns_pz.experiments.optimum import optimum_for
    from ns_pz.experiments.report import plot
    from ns_pz.experiments.store import ResultStore

    run_dirs = _run_dirs(Path(args.dir))
    figsize = _figsize(args.figsize)

    def plot_run(run_dir: Path) -> None:
        store = ResultStore(run_dir)
        record = store.spec_record()
        rows = _readable_rows(store)
        spec_record = record["spec"]
        optimum = optimum_for(spec_record)
        target = run_dir / "plots"
        if args.out is not None:  # one folder per run inside it when there are several
            target = Path(args.out) / run_dir.name if len(run_dirs) > 1 else Path(args.out)
        for path in plot(
            rows,
            spec_record["title"],
            target,
            spec_record,
            optimum,
            fmt=args.format,
            figsize=figsize,
            dpi=args.dpi,
        ):
            out(str(path))

    return _each_run(Path(args.dir), plot_run)


def _figsize(text: str | None) -> tuple[float, float] | None:
    """``"10x4"`` as ``(10.0, 4.0)``; ``None`` stays ``None``.

    Raises:
        ValueError: Not two positive numbers joined by ``x``.
    """
    if text is None:
        return None
    try:
        width, height = (float(part) for part in text.lower().split("x"))
    except ValueError:
        width = height = 0.0
    if not (width > 0 and height > 0):
        raise ValueError(f"--figsize={text!r} must be WIDTHxHEIGHT in inches, e.g. 10x4")
    return width, height


def bench_estimate(args: argparse.Namespace, out: Callable[[str], None]) -> int:
    """``bench estimate``: time a little training and a few capped trials; project the run."""
    from ns_pz.agents.learning.artefacts import cache_dir
    from ns_pz.experiments import load_spec
    from ns_pz.experiments.estimate import (
        estimate,
        estimate_training,
        plan,
        projection_lines,
        stand_in_cache,
    )

    specs = [load_spec(name, args.size) for name in _spec_names(args.specs)]
    out(plan(specs, args.samples, args.cell_seconds, args.probe_seconds).text())
    user_cache = cache_dir()
    with stand_in_cache() as stand_ins:  # the user's networks are only read
        networks, stand_in_agents = estimate_training(
            specs, stand_ins, user_cache, args.probe_seconds, sys.stderr
        )
        for network in networks:
            if network.cached:  # a run here would load it: not part of the projection
                out(f"training: {network.label}: cached (trained in {network.seconds:.1f} s)")
            else:
                out(
                    f"training: {network.label}: projected {network.seconds:.0f} s (timed "
                    f"{network.timed:,} of {network.total:,} {network.unit})"
                )
        costs = {}
        out(
            "| spec | setting | notification | agent | s/trial | CPU s/trial | trials "
            "| projected s (1 core) |"
        )
        out("|---|---|---|---|---|---|---|---|")
        for experiment in specs:
            labels = {label for name, label in stand_in_agents if name == experiment.name}
            costs[experiment.name] = estimate(
                experiment, args.samples, sys.stderr, args.cell_seconds, at_horizon=labels
            )
            for cost in costs[experiment.name]:
                at = "≤ " if cost.at_horizon else ""
                out(
                    f"| {experiment.name} | {cost.setting} | {cost.notification} | {cost.agent} "
                    f"| {at}{cost.seconds_per_trial:.3f} | {at}{cost.cpu_seconds_per_trial:.3f} "
                    f"| {cost.trials} | {at}{cost.total_seconds:.0f} |"
                )
    out(
        "\n≤: an episode cut at --cell-seconds, or played by a partly trained stand-in network, "
        "projected from its time per step to the horizon (an upper bound)."
    )
    for line in projection_lines(specs, networks, costs, args.workers):
        out(line)
    return EXIT_OK


def train(args: argparse.Namespace, out: Callable[[str], None]) -> int:
    """``train``: build every network the specs' learning agents need (cached ones are kept)."""
    from ns_pz.agents.learning.artefacts import cache_dir
    from ns_pz.experiments import load_spec
    from ns_pz.experiments.runner import train_artefacts
    from ns_pz.experiments.trials import expand

    specs = [load_spec(name, args.size) for name in _spec_names(args.specs)]
    total = 0.0
    for experiment in specs:
        for cost in train_artefacts(experiment, expand(experiment), sys.stderr, args.workers):
            state = "trained now" if cost.trained_now else "cached"
            total += cost.seconds if cost.trained_now else 0.0
            out(f"{experiment.name}: {cost.label}: {state} ({cost.seconds:.1f} s)")
    out(f"\n{total:.0f} s of training in this call; artefacts in {cache_dir()}")
    return EXIT_OK


def bench_list(args: argparse.Namespace, out: Callable[[str], None]) -> int:
    """``bench list``: the shipped specs with their titles and agents."""
    from ns_pz.experiments import load_spec, shipped_specs

    for name, path in shipped_specs().items():
        experiment = load_spec(path, "quick")
        agents = ", ".join(a.label for a in experiment.agents)
        out(f"{name:24s} {experiment.title}\n{'':24s} agents: {agents}")
    out(f"\n{PAPER!r} runs all of them.")
    return EXIT_OK


def _parser() -> argparse.ArgumentParser:
    from ns_pz.experiments.estimate import CELL_SECONDS, MIN_STEPS, OVERRUN, PROBE_SECONDS

    parser = argparse.ArgumentParser(
        prog="ns-pz",
        description=DESCRIPTION,
        epilog="Exit codes: 0 ok, 1 some trials failed, 2 usage error, 130 interrupted.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    commands = parser.add_subparsers(dest="command", required=True)
    commands.add_parser("envs", help="list registered environments and their parameters")
    bench = commands.add_parser("bench", help="run and report the paper's benchmark")
    actions = bench.add_subparsers(dest="action", required=True)

    run = actions.add_parser("run", help="run specs (shipped names, files, or 'paper' for all)")
    run.add_argument("specs", nargs="+", metavar="SPEC", help="spec name or TOML file; 'paper'")
    run.add_argument("--size", choices=("quick", "full"), default="quick", help=SIZE_HELP)
    run.add_argument("--backend", choices=("local", "ray"), default="local", help=BACKEND_HELP)
    run.add_argument("--address", default=None, help="Ray cluster address (default: start Ray)")
    run.add_argument(
        "--workers",
        type=int,
        default=os.cpu_count() or 1,
        help="processes (local) or CPUs of a local Ray (default: all cores)",
    )
    run.add_argument("--out", default="ns-pz-results", help="results root (default: %(default)s)")
    run.add_argument("--resume", action="store_true", help="finish a run in --out")

    show = actions.add_parser("table", help="print the tables of a results directory")
    show.add_argument("dir", help="a run directory, or a folder of them")
    show.add_argument(
        "--format", choices=("markdown", "latex"), default="markdown", help="default: %(default)s"
    )
    show.add_argument(
        "--width",
        type=int,
        default=None,
        help="split a Markdown table wider than this many characters into parts (0: never; "
        "default: the terminal's width when printing to one, else never)",
    )

    figures = actions.add_parser("plot", help="write figures of a results directory")
    figures.add_argument("dir", help="a run directory, or a folder of them")
    figures.add_argument(
        "--out",
        default=None,
        help="folder for the figures (default: each run's plots/ folder; with several runs, "
        "one subfolder per run)",
    )
    figures.add_argument(
        "--format", choices=("png", "pdf", "svg"), default="png", help="default: %(default)s"
    )
    figures.add_argument(
        "--figsize",
        default=None,
        metavar="WxH",
        help="size of each figure in inches, e.g. 10x4 (default: from the agents and cells)",
    )
    figures.add_argument("--dpi", type=int, default=120, help="PNG resolution (default: 120)")

    cost = actions.add_parser(
        "estimate", help="time a few seeds of every cell and project the run's wall time"
    )
    cost.add_argument("specs", nargs="+", metavar="SPEC", help="spec name or TOML file; 'paper'")
    cost.add_argument("--size", choices=("quick", "full"), default="full", help=SIZE_HELP)
    cost.add_argument(
        "--samples", type=int, default=2, help="seeds timed per cell (default: %(default)s)"
    )
    cost.add_argument(
        "--cell-seconds",
        type=float,
        default=CELL_SECONDS,
        help="cap on the seconds spent timing one agent in one cell; an episode cut at it is "
        f"projected to the horizon (it runs on to {MIN_STEPS} steps, up to {OVERRUN:g} times "
        "the cap, so that a cost paid every few steps is averaged) (default: %(default)s)",
    )
    cost.add_argument(
        "--probe-seconds",
        type=float,
        default=PROBE_SECONDS,
        help="seconds of training timed per network not in the cache (default: %(default)s)",
    )
    cost.add_argument(
        "--workers",
        type=int,
        default=os.cpu_count() or 1,
        help="worker processes to project the run's wall time for (default: all cores)",
    )

    actions.add_parser("list", help="list the shipped specs")

    trainer = commands.add_parser(
        "train", help="train the networks the specs' learning agents use (cached per θ_0)"
    )
    trainer.add_argument("specs", nargs="+", metavar="SPEC", help="spec name or TOML file; 'paper'")
    trainer.add_argument("--size", choices=("quick", "full"), default="quick", help=SIZE_HELP)
    trainer.add_argument(
        "--workers", type=int, default=os.cpu_count() or 1, help="networks trained at once"
    )
    return parser


def main(argv: Sequence[str] | None = None, out: Callable[[str], None] = print) -> int:
    """Entry point of ``ns-pz``; returns the exit code."""
    from ns_pz.experiments.spec import SpecError

    parser = _parser()
    args = parser.parse_args(argv)
    action = args.command if args.command in ("envs", "train") else args.action
    if action in ("run", "estimate", "train") and args.workers < 1:
        parser.error(f"--workers={args.workers} must be >= 1")
    if action == "estimate" and args.samples < 1:
        parser.error(f"--samples={args.samples} must be >= 1")
    if action == "estimate" and not min(args.cell_seconds, args.probe_seconds) > 0:
        parser.error(
            f"--cell-seconds={args.cell_seconds} and --probe-seconds={args.probe_seconds} "
            "must be > 0"
        )
    # Agents named "module:builder" may live in the working directory. It goes last on the
    # path, so a source checkout there never shadows the installed ns_pz (workers inherit it).
    if os.getcwd() not in sys.path:
        sys.path.append(os.getcwd())
    handlers: dict[str, Callable[[argparse.Namespace, Callable[[str], None]], int]] = {
        "envs": show_envs,
        "run": bench_run,
        "table": bench_table,
        "plot": bench_plot,
        "list": bench_list,
        "estimate": bench_estimate,
        "train": train,
    }
    previous = signal.signal(signal.SIGTERM, _interrupt)  # a scheduler's stop, like Ctrl-C
    try:
        return handlers[action](args, out)
    except BrokenPipeError:  # the reader went away (``ns-pz bench list | head``)
        sys.stderr.close()
        return EXIT_OK
    except (SpecError, ValueError, OSError, RuntimeError, ImportError) as error:
        print(f"ns-pz: error: {error}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print(f"\nns-pz: interrupted; {INTERRUPTED[action]}", file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        signal.signal(signal.SIGTERM, previous)


def _interrupt(signum: int, frame: object) -> None:
    """SIGTERM handler: stop as Ctrl-C does (finished trials are kept)."""
    raise KeyboardInterrupt


if __name__ == "__main__":
    sys.exit(main())
