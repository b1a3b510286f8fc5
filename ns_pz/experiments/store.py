"""The results directory of one run: the spec it belongs to and one file per finished trial.

Layout::

    DIR/spec.json          the resolved spec and its digest (written first)
    DIR/trials/KEY.json    one result row per trial, written atomically
    DIR/results.csv        every row, one per episode, rebuilt from the trial files

Every file is written to a temporary name and renamed, so a run killed at any moment (Ctrl-C,
``kill -9``, a crashed machine) leaves complete trial files and at worst a stray temporary one,
never a half-written result. Resuming skips the trials that have a file with status ``ok`` and
re-runs the rest, errors included. A trial file that cannot be read anyway (a disk that filled
up, a copy cut short, a hand edit: not JSON, or JSON that is not a complete result row) is named
and treated as not done: ``--resume`` re-runs its trial, and reports list it as skipped
(:meth:`ResultStore.unreadable`). Only the files the store names are trial files: ``KEY.json``
holding the row of trial ``KEY``. Any other file in ``trials/`` (``KEY (copy).json``, a
renamed file) is named and ignored, never counted as another episode (:meth:`ResultStore.strays`).
A write that fails (a full disk) names the file and leaves no temporary file behind.

Only one run at a time writes into a directory (:mod:`ns_pz.experiments.lock`).
"""

from __future__ import annotations

import contextlib
import csv
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
            if any(self.trials_dir.glob("*.json")):
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
        if not resume and any(self.trials_dir.glob("*.json")):
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

    # -- trials ----------------------------------------------------------------------------
    def finished(self, digest: str) -> set[str]:
        """Keys of the trials of the spec with ``digest`` that have a result with status ``ok``.

        Raises:
            SpecError: A trial file belongs to another spec.
        """
        done = set()
        for row in self.rows():
            if row["spec_hash"] != digest:
                raise SpecError(
                    f"{self.root}/trials/{row['trial']}.json belongs to spec {row['spec_hash']}, "
                    f"not {digest}; use another --out directory"
                )
            if row["status"] == "ok":
                done.add(row["trial"])
        return done

    def write(self, row: dict[str, Any]) -> None:
        """Store one trial's row (atomically)."""
        _write_atomic(self.trials_dir / f"{row['trial']}.json", json.dumps(row, sort_keys=True))

    def rows(self) -> list[dict[str, Any]]:
        """Every readable stored row, ordered by trial key (see :meth:`unreadable`)."""
        return self._scan()[0]

    def unreadable(self) -> list[tuple[Path, str]]:
        """Trial files that are not a complete result row (cut short, not JSON), with why.

        Their trials count as not done: ``--resume`` runs them again.
        """
        return self._scan()[1]

    def strays(self) -> list[tuple[Path, str]]:
        """Files in ``trials/`` that the store did not name (a copy, a rename), with why.

        They are ignored: never counted, never overwritten, never deleted.
        """
        return self._scan()[2]

    def _scan(
        self,
    ) -> tuple[list[dict[str, Any]], list[tuple[Path, str]], list[tuple[Path, str]]]:
        rows, bad, strays = [], [], []
        for path in sorted(self.trials_dir.glob("*.json")):
            if not _KEY_PATTERN.fullmatch(path.stem):
                strays.append((path, "not a trial file of this store (its name is no trial key)"))
                continue
            try:
                row = json.loads(path.read_text(encoding="utf-8"))
            except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
                bad.append((path, str(error)))
                continue
            problem = row_problem(row)
            if problem is not None:
                bad.append((path, f"not a complete result row: {problem}"))
            elif row["trial"] != path.stem:
                strays.append(
                    (path, f"holds trial {row['trial']!r}, whose file is {row['trial']}.json")
                )
            else:
                rows.append(row)
        return rows, bad, strays

    def write_csv(self) -> Path:
        """Rebuild ``results.csv`` from the trial files; return its path."""
        path = self.root / "results.csv"
        rows = self.rows()
        with _temporary(path, "w", newline="") as handle:
            writer = csv.DictWriter(handle, fieldnames=COLUMNS)
            writer.writeheader()
            for row in rows:
                writer.writerow({column: row.get(column) for column in COLUMNS})
        os.replace(handle.name, path)
        return path


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
