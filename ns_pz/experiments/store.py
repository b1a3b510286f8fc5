"""The results directory of one run: the spec it belongs to and every finished trial's row.

Layout::

    DIR/spec.json             the resolved spec and its digest (written first)
    DIR/hyperparameters.json  each agent's hyper-parameters once, under a short key
    DIR/trials/KEY.json       one result row per trial finished since the last pack, atomically
    DIR/trials.jsonl          the packed rows, one per line (rewritten atomically)
    DIR/results.csv           every row, one per episode, rebuilt from the rows above

A row on disk holds ``hyperparameters_key`` (the first 12 hex digits of the SHA-256 of the
hyper-parameters' canonical JSON) in place of the hyper-parameters, which
``hyperparameters.json`` holds once per agent; :meth:`ResultStore.rows` puts them back, so a
row read is the row written. A row that holds its hyper-parameters itself, as stores written
before ``hyperparameters.json`` existed do, is read as it is; packing moves them into the file.

During a run every trial's row is its own file; at the end of the run (and when it stops
early) :meth:`ResultStore.write_csv` packs them into ``trials.jsonl`` and removes them. A file
per trial costs at least a file-system block (4 KiB on most) for a row of a few hundred bytes:
most of what a finished run used to leave on disk.

Every file is written to a temporary name and renamed, so a run killed at any moment (Ctrl-C,
``kill -9``) leaves complete files and at worst a stray temporary one, never a half-written
result (a pack that stops between writing ``trials.jsonl`` and removing the packed trial files
leaves rows twice, and a trial file wins over its packed copy). Every file but a trial's row is
also flushed to disk (``fsync``) before the rename, so a crashed machine leaves them complete
too. A trial's row is not: the runner's one process writes every row, and with ``fsync`` and
a random temporary name a row cost it about 0.9 ms (0.35 ms without, on the development
machine), so the full FrozenLake table's 8,400 rows took it about 7.6 s, while the whole table
took 18.6 s on 16 workers of a 16-core machine. A machine that crashes may lose the rows of its
last seconds or leave their files empty; either counts as not done (an empty file is named as
unreadable), and ``--resume`` plays them again.
Resuming skips the trials that have a row with status ``ok`` and re-runs the rest, errors
included. A row that cannot be read anyway (a disk that filled up, a copy cut short, a hand
edit: not JSON, or JSON that is not a complete result row) is named and treated as not done:
``--resume`` re-runs its trial, and reports list it as skipped (:meth:`ResultStore.unreadable`;
a line of ``trials.jsonl`` is named by its number; the run that packs next drops it, having
named it when it started). Only the files the store names are trial files: ``KEY.json``
holding the row of trial ``KEY``. Any other file in ``trials/`` (``KEY (copy).json``, a
renamed file) is named and ignored, never counted as another episode
(:meth:`ResultStore.strays`). A write that fails (a full disk) names the file and leaves no
temporary file behind.

Only one run at a time writes into a directory (:mod:`ns_pz.experiments.lock`).
"""

from __future__ import annotations

import contextlib
import csv
import hashlib
import json
import os
import re
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

from ns_pz.experiments.lock import refuse_if_locked
from ns_pz.experiments.spec import LEVEL_LABELS, ExperimentSpec, SpecError
from ns_pz.experiments.trials import COLUMNS
from ns_pz.files import as_if_created


class ResultStore:
    """Reads and writes the results directory ``root``."""

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root)
        self.trials_dir = self.root / "trials"
        self.pack_path = self.root / "trials.jsonl"
        self.hyper_path = self.root / "hyperparameters.json"
        self._hyper: dict[str, dict[str, Any]] | None = None  # the file's, once read

    # -- setup ---------------------------------------------------------------------------
    def check(self, spec: ExperimentSpec, resume: bool) -> None:
        """Refuse a directory that cannot take ``spec``'s results; write nothing.

        Raises:
            DirectoryLocked: Another process is running into the directory.
            SpecError: The directory holds results of another spec, trial files without a
                spec.json, or results of this spec while ``resume`` is off (nothing is ever
                mixed or silently overwritten); or ``root`` is a file.
        """
        if self.root.exists() and not self.root.is_dir():
            raise SpecError(f"--out {self.root} is a file, not a directory")
        meta = self.root / "spec.json"
        if not meta.exists():
            if self._holds_rows():
                raise SpecError(
                    f"{self.root} holds trial results but no spec.json; use another --out"
                )
            return
        refuse_if_locked(self.root)  # a run in progress: say so, not "another spec"/--resume
        stored = _read_record(meta)
        if stored.get("digest") != spec.digest():
            raise SpecError(
                f"{self.root} holds results of a different spec (digest "
                f"{stored.get('digest')}; this {spec.name!r} at size {spec.size!r} is "
                f"{spec.digest()}: {_difference(stored.get('spec', {}), spec.to_dict())}). "
                "Use another --out directory."
            )
        if not resume and self._holds_rows():
            raise SpecError(
                f"{self.root} already holds results of this spec; pass --resume to finish "
                "it, or use another --out directory"
            )

    def prepare(self, spec: ExperimentSpec, resume: bool) -> None:
        """:meth:`check`, then make the directory ready for ``spec``."""
        self.check(spec, resume)
        self.trials_dir.mkdir(parents=True, exist_ok=True)
        meta = self.root / "spec.json"
        record = {"name": spec.name, "digest": spec.digest(), "spec": spec.to_dict()}
        _write_atomic(meta, json.dumps(record, indent=2, sort_keys=True))

    def spec_record(self) -> dict[str, Any]:
        """What :meth:`prepare` stored.

        Raises:
            SpecError: ``root`` is not a results directory.
        """
        meta = self.root / "spec.json"
        if not meta.is_file():
            raise SpecError(f"{self.root} is not a results directory (no spec.json)")
        return _read_record(meta)

    def _holds_rows(self) -> bool:
        return self.pack_path.exists() or any(self.trials_dir.glob("*.json"))

    # -- trials ----------------------------------------------------------------------------
    def finished(self, digest: str, rows: list[dict[str, Any]] | None = None) -> set[str]:
        """Keys of the trials of the spec with ``digest`` that have a result with status ``ok``.

        Args:
            digest: The spec's.
            rows: The stored rows if already read (:meth:`scan`); read now if None.

        Raises:
            SpecError: A trial file belongs to another spec.
        """
        done = set()
        for row in self.rows() if rows is None else rows:
            if row["spec_hash"] != digest:
                raise SpecError(
                    f"{self.root}: trial {row['trial']} belongs to spec {row['spec_hash']}, "
                    f"not {digest}; use another --out directory"
                )
            if row["status"] == "ok":
                done.add(row["trial"])
        return done

    def write(self, row: dict[str, Any]) -> None:
        """Store one trial's row (renamed into place, not synced to disk; see the module docstring).

        Its hyper-parameters go to ``hyperparameters.json`` (synced) the first time they appear.
        """
        text = json.dumps(self._stored(row), sort_keys=True)
        _write_renamed(self.trials_dir / f"{row['trial']}.json", text)

    def _stored(self, row: dict[str, Any]) -> dict[str, Any]:
        """``row`` as it goes to disk: its hyper-parameters replaced by their key.

        The key's entry is written to ``hyperparameters.json`` first, so no stored row ever
        names a key the file lacks. Hyper-parameters that are not a JSON object's text stay
        in the row.
        """
        text = row.get("hyperparameters")
        try:
            hyper = json.loads(text) if isinstance(text, str) else None
        except json.JSONDecodeError:
            hyper = None
        if not isinstance(hyper, dict):
            return row
        key = hyperparameters_key(hyper)
        known = self._hyperparameters()
        if key not in known:
            known[key] = hyper
            _write_atomic(self.hyper_path, json.dumps(known, indent=2, sort_keys=True))
        stored = {name: value for name, value in row.items() if name != "hyperparameters"}
        return {**stored, "hyperparameters_key": key}

    def _hyperparameters(self) -> dict[str, dict[str, Any]]:
        """``hyperparameters.json`` (empty if there is none yet), read once.

        Raises:
            SpecError: It is not a JSON object of objects; the message names it.
        """
        if self._hyper is not None:
            return self._hyper
        known: Any = {}
        if self.hyper_path.exists():
            try:
                known = json.loads(self.hyper_path.read_text(encoding="utf-8"))
            except (UnicodeDecodeError, json.JSONDecodeError) as error:
                known = error
            if not isinstance(known, dict) or not all(isinstance(v, dict) for v in known.values()):
                raise SpecError(
                    f"{self.hyper_path} is not a JSON object of hyper-parameters ({known}); the "
                    "rows of this directory name their agents' hyper-parameters in it: restore "
                    "it from a copy, or use another --out directory"
                )
        self._hyper = known
        return known

    def rows(self) -> list[dict[str, Any]]:
        """Every readable stored row, ordered by trial key (see :meth:`unreadable`)."""
        return self.scan()[0]

    def unreadable(self) -> list[tuple[Path, str]]:
        """Trial files that are not a complete result row (cut short, not JSON), with why.

        Their trials count as not done: ``--resume`` runs them again.
        """
        return self.scan()[1]

    def strays(self) -> list[tuple[Path, str]]:
        """Files in ``trials/`` that the store did not name (a copy, a rename), with why.

        They are ignored: never counted, never overwritten, never deleted.
        """
        return self.scan()[2]

    def scan(
        self,
    ) -> tuple[list[dict[str, Any]], list[tuple[Path, str]], list[tuple[Path, str]]]:
        """:meth:`rows`, :meth:`unreadable` and :meth:`strays` from one reading of the files."""
        # Trial files first: a run packing meanwhile removes them only once the pack holds them.
        file_bad: list[tuple[Path, str]] = []
        loose, strays = self._read_trial_files(file_bad)
        packed, bad = self._read_pack()
        bad.extend(file_bad)
        by_key = {row["trial"]: row for row in packed}
        by_key.update((row["trial"], row) for _, row in loose)  # a trial file wins
        return [by_key[key] for key in sorted(by_key)], bad, strays

    def _read_pack(self) -> tuple[list[dict[str, Any]], list[tuple[Path, str]]]:
        """The rows of ``trials.jsonl``, and its unreadable lines named."""
        rows: list[dict[str, Any]] = []
        if not self.pack_path.exists():
            return rows, []
        try:
            lines = self.pack_path.read_text(encoding="utf-8").splitlines()
        except (OSError, UnicodeDecodeError) as error:
            return rows, [(self.pack_path, str(error))]
        bad = []
        for number, line in enumerate(lines, 1):
            row, problem = self._parse(line)
            if problem is None:
                rows.append(row)
            elif line.strip():
                bad.append((self.pack_path, f"line {number}: {problem}"))
        return rows, bad

    def _read_trial_files(
        self, bad: list[tuple[Path, str]]
    ) -> tuple[list[tuple[Path, dict[str, Any]]], list[tuple[Path, str]]]:
        """The rows of ``trials/`` with their files; unreadable files are added to ``bad``."""
        rows, strays = [], []
        for path in sorted(self.trials_dir.glob("*.json")):
            if not _KEY_PATTERN.fullmatch(path.stem):
                strays.append((path, "not a trial file of this store (its name is no trial key)"))
                continue
            try:
                text = path.read_text(encoding="utf-8")
            except FileNotFoundError:
                continue  # packed since the listing
            except (OSError, UnicodeDecodeError) as error:
                bad.append((path, str(error)))
                continue
            row, problem = self._parse(text)
            if problem is not None:
                bad.append((path, problem))
            elif row["trial"] != path.stem:
                strays.append(
                    (path, f"holds trial {row['trial']!r}, whose file is {row['trial']}.json")
                )
            else:
                rows.append((path, row))
        return rows, strays

    def _parse(self, text: str) -> tuple[dict[str, Any], str | None]:
        """A stored row read back (hyper-parameters put back), or why it cannot be."""
        try:
            row = json.loads(text)
        except json.JSONDecodeError as error:
            return {}, str(error)
        if isinstance(row, dict) and "hyperparameters_key" in row:
            key = row.pop("hyperparameters_key")
            known = self._hyperparameters()
            if key not in known:
                return {}, f"its hyperparameters_key {key!r} is not in {self.hyper_path}"
            row["hyperparameters"] = json.dumps(known[key], sort_keys=True)
        problem = row_problem(row)
        if problem is not None:
            return {}, f"not a complete result row: {problem}"
        return row, None

    def pack(self) -> list[dict[str, Any]]:
        """Move the trial files' rows into ``trials.jsonl`` and remove those files.

        Unreadable trial files and strays stay where they are; unreadable lines of
        ``trials.jsonl`` are dropped (their trials count as not done either way).
        Hyper-parameters still inside rows (a store written before ``hyperparameters.json``)
        move into that file.

        Returns:
            The packed rows as stored (hyper-parameters by key), ordered by trial key.
        """
        packed, _ = self._read_pack()
        loose, _ = self._read_trial_files([])
        by_key = {row["trial"]: row for row in packed}
        by_key.update((row["trial"], row) for _, row in loose)
        stored = [self._stored(by_key[key]) for key in sorted(by_key)]
        if not stored and not self.pack_path.exists():
            return stored
        lines = "".join(f"{json.dumps(row, sort_keys=True)}\n" for row in stored)
        _write_atomic(self.pack_path, lines)
        for path, _ in loose:
            path.unlink()
        return stored

    def write_csv(self) -> Path:
        """:meth:`pack` the trial files, then rebuild ``results.csv``; return its path.

        The CSV's ``hyperparameters_key`` column names each row's entry in
        ``hyperparameters.json`` (in place of the hyper-parameters, which made most of its bytes).
        """
        rows = self.pack()
        path = self.root / "results.csv"
        with _temporary(path, "w", newline="") as handle:
            writer = csv.DictWriter(handle, fieldnames=CSV_COLUMNS)
            writer.writeheader()
            for row in rows:
                writer.writerow({column: row.get(column) for column in CSV_COLUMNS})
        os.replace(handle.name, path)
        return path


CSV_COLUMNS = tuple(
    "hyperparameters_key" if column == "hyperparameters" else column for column in COLUMNS
)
"""Columns of ``results.csv``: a row's, the hyper-parameters given by their key."""


def hyperparameters_key(hyper: dict[str, Any]) -> str:
    """The key of ``hyper`` in ``hyperparameters.json``: 12 hex digits of its JSON's SHA-256."""
    text = json.dumps(hyper, sort_keys=True)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:12]


def _difference(old: dict[str, Any], new: dict[str, Any]) -> str:
    """The top-level fields that differ between two spec records."""
    fields = sorted(k for k in set(old) | set(new) if old.get(k) != new.get(k))
    return f"{', '.join(fields)} differ" if fields else "same fields, another ns_pz version"


_KEY_PATTERN = re.compile(r"[A-Za-z0-9.=_-]+")
"""A trial key: what :func:`~ns_pz.experiments.trials.expand` builds from slugs and numbers."""

_TEXT_FIELDS = ("trial", "spec_hash", "setting", "notification", "agent")
"""Fields every row holds as a string; :meth:`ResultStore.finished` and the reports read them."""


def row_problem(row: Any) -> str | None:
    """What makes ``row`` unusable as a result row, or ``None`` if it is a complete one.

    Every row names its trial, spec, cell and agent, and has status ``"ok"`` or ``"error"``;
    an ``ok`` row also has a numeric return, an integer length and its change and alarm times
    (JSON lists of integers, or ``null``).
    """
    if not isinstance(row, dict):
        return f"a {type(row).__name__}, not an object"
    for key in _TEXT_FIELDS:
        if not isinstance(row.get(key), str):
            return f"{key} is {row.get(key)!r}, not a string" if key in row else f"no {key}"
    if row.get("status") not in ("ok", "error"):
        return f"status is {row.get('status')!r}, not 'ok' or 'error'"
    if row["status"] == "error":
        return None
    value = row.get("return")
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return f"return is {value!r}, not a number"
    length = row.get("length")
    if isinstance(length, bool) or not isinstance(length, int):
        return f"length is {length!r}, not an integer"
    for key in ("change_times", "alarm_times"):
        times = row.get(key)
        if times is None:
            continue
        try:
            parsed = json.loads(times) if isinstance(times, str) else None
        except json.JSONDecodeError:
            parsed = None
        if not isinstance(parsed, list) or not all(
            isinstance(t, int) and not isinstance(t, bool) for t in parsed
        ):
            return f"{key} is {times!r}, not a JSON list of integers"
    return None


def _read_record(meta: Path) -> dict[str, Any]:
    """``spec.json``, or a :class:`SpecError` naming it and what is wrong."""
    try:
        record = json.loads(meta.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise SpecError(
            f"{meta} is not valid JSON ({error}); use another --out directory"
        ) from None
    if not isinstance(record, dict) or not isinstance(record.get("spec"), dict):
        raise SpecError(f"{meta} is not a spec record (no 'spec'); use another --out directory")
    problem = _spec_problem(record["spec"])
    if problem is not None:
        raise SpecError(
            f"{meta} is not a complete spec record ({problem}); use another --out directory"
        )
    return record


def _spec_problem(spec: dict[str, Any]) -> str | None:
    """What the reports would miss in a stored spec, or ``None``."""
    missing = [key for key in ExperimentSpec.RECORD_FIELDS if key not in spec]
    if missing:
        return f"'spec' has no {', '.join(repr(key) for key in missing)}"
    for key in ("settings", "notifications"):
        if not isinstance(spec[key], list) or not all(isinstance(v, str) for v in spec[key]):
            return f"spec.{key} is {spec[key]!r}, not a list of strings"
    unknown = [level for level in spec["notifications"] if level not in LEVEL_LABELS]
    if unknown:
        return f"spec.notifications holds {unknown!r}; allowed: {', '.join(LEVEL_LABELS)}"
    agents = spec["agents"]
    if not isinstance(agents, list) or not all(
        isinstance(a, dict) and isinstance(a.get("label"), str) for a in agents
    ):
        return f"spec.agents is {agents!r}, not a list of agents with labels"
    try:
        ExperimentSpec.from_dict(spec)
    except (KeyError, TypeError, ValueError) as error:
        return f"spec cannot be read back: {type(error).__name__}: {error}"
    return None


def _write_atomic(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file and a rename.

    Raises:
        OSError: The write failed (a full disk, no permission); the message names ``path``,
            and the temporary file is removed.
    """
    with _temporary(path, "w") as handle:
        handle.write(text)
    os.replace(handle.name, path)


def _write_renamed(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file and a rename, without ``fsync``.

    Only one run writes into a results directory, so the temporary name needs no random part:
    ``.NAME.tmp`` beside ``path`` (a stray one left by a kill is overwritten by the next write,
    and no reader takes it for a row). A new file gets the permissions ``open`` gives; one that
    replaces another keeps the old one's.

    Raises:
        OSError: The write failed; the message names ``path``, and the temporary file is removed.
    """
    temporary = path.with_name(f".{path.name}.tmp")
    try:
        with open(temporary, "w", encoding="utf-8") as handle:
            handle.write(text)
        if path.exists():
            as_if_created(temporary, replacing=path)
        os.replace(temporary, path)
    except BaseException as error:
        with contextlib.suppress(OSError):
            os.unlink(temporary)
        if isinstance(error, OSError):
            reason = error.strerror or str(error)
            raise OSError(error.errno, f"cannot write {path}: {reason}") from error
        raise


@contextlib.contextmanager
def _temporary(path: Path, mode: str, **options: Any) -> Iterator[IO[str]]:
    """A temporary file beside ``path``, flushed to disk and given ``path``'s permissions.

    On any failure it is removed and an ``OSError`` names ``path``.
    """
    handle = tempfile.NamedTemporaryFile(  # noqa: SIM115 - closed below, removed on failure
        mode, dir=path.parent, prefix=f".{path.name}.", suffix=".tmp", delete=False, **options
    )
    try:
        with handle:
            yield handle
            handle.flush()
            os.fsync(handle.fileno())
        as_if_created(handle.name, replacing=path)
    except BaseException as error:
        with contextlib.suppress(OSError):
            os.unlink(handle.name)
        if isinstance(error, OSError):
            reason = error.strerror or str(error)
            raise OSError(error.errno, f"cannot write {path}: {reason}") from error
        raise
