"""Trained networks on disk: keyed, written atomically, checked on load, shared by processes.

An artefact is a directory ``<cache>/<learner>/<key>/`` holding ``weights.npz`` (the network's
arrays, numpy only, so using a trained agent never needs torch) and ``manifest.json``: the
format, the learner, the full request the key was computed from, the code version and the
SHA-256 of ``weights.npz``. The key is a hash of the request (learner, environment family,
θ_0, hyper-parameters, seed, code version), so a change to any of them names another artefact.

* Written atomically: everything goes into a temporary sibling directory, renamed into place
  in one step; a crash leaves no half-written artefact under the key.
* Checked on load: a manifest of another format, learner or request, or weights whose hash
  differs, raise :class:`ArtefactError`, never a silently used network.
* Shared: :func:`load_or_train` takes an exclusive file lock per key while it trains, so two
  workers asking for the same missing artefact train it once; the second waits and loads.

The cache folder is ``$NS_PZ_CACHE_DIR/artefacts`` if that variable is set, else
``$XDG_CACHE_HOME/ns_pz/artefacts``, else ``~/.cache/ns_pz/artefacts``.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import io
import json
import os
import shutil
import tempfile
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ns_pz.errors import NSPZError
from ns_pz.files import as_if_created

FORMAT = "ns_pz-artefact"
FORMAT_VERSION = 1
CACHE_ENV_VAR = "NS_PZ_CACHE_DIR"
WEIGHTS = "weights.npz"
MANIFEST = "manifest.json"


class ArtefactError(NSPZError, RuntimeError):
    """An artefact on disk is corrupt, foreign, or does not match the request."""


@dataclass(frozen=True)
class ArtefactRequest:
    """What identifies one trained network.

    Attributes:
        learner: The learner that trains it (``"ddqn"``, ``"alphazero"``).
        family: ``repr`` of the environment family it is trained on (names its map/variant).
        theta0: The θ it is trained under, as ``{name: value}`` (JSON data).
        args: The learner's hyper-parameters, as JSON data.
        seed: The training seed.
        code_version: The learner's code version; bump it when training changes.
    """

    learner: str
    family: str
    theta0: Mapping[str, Any]
    args: Mapping[str, Any]
    seed: int
    code_version: str

    def record(self) -> dict[str, Any]:
        """The request as JSON data (what the key hashes and the manifest stores)."""
        record = {
            "learner": self.learner,
            "family": self.family,
            "theta0": dict(self.theta0),
            "args": dict(self.args),
            "seed": self.seed,
            "code_version": self.code_version,
        }
        return json.loads(json.dumps(record, allow_nan=False))  # tuples become lists, as stored

    @property
    def key(self) -> str:
        """A short hash naming the artefact (20 hex digits of SHA-256 over :meth:`record`)."""
        text = json.dumps(self.record(), sort_keys=True, allow_nan=False)
        return hashlib.sha256(text.encode()).hexdigest()[:20]


def cache_dir() -> Path:
    """The folder artefacts live in (see the module docstring for how it is chosen)."""
    root = os.environ.get(CACHE_ENV_VAR)
    if root:
        return Path(root) / "artefacts"
    xdg = os.environ.get("XDG_CACHE_HOME")
    base = Path(xdg) if xdg else Path.home() / ".cache"
    return base / "ns_pz" / "artefacts"


def artefact_path(request: ArtefactRequest, root: Path | None = None) -> Path:
    """The directory of ``request``'s artefact (it may not exist)."""
    return (root or cache_dir()) / request.learner / request.key


def exists(request: ArtefactRequest, root: Path | None = None) -> bool:
    """Whether an artefact is stored under ``request``'s key (not whether it is valid)."""
    return (artefact_path(request, root) / MANIFEST).is_file()


def save(
    request: ArtefactRequest,
    weights: Mapping[str, np.ndarray],
    info: Mapping[str, Any] | None = None,
    root: Path | None = None,
) -> Path:
    """Store ``weights`` under ``request``'s key, atomically; an existing artefact is kept.

    Args:
        request: What the weights were trained for.
        weights: Arrays by name.
        info: Extra JSON data for the manifest (training time, final returns, ...).
        root: The cache folder (default :func:`cache_dir`).

    Returns:
        The artefact's directory.
    """
    final = artefact_path(request, root)
    final.parent.mkdir(parents=True, exist_ok=True)
    buffer = io.BytesIO()
    arrays: dict[str, Any] = {name: np.asarray(array) for name, array in weights.items()}
    np.savez(buffer, **arrays)
    payload = buffer.getvalue()
    manifest = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "key": request.key,
        "request": request.record(),
        "weights_sha256": hashlib.sha256(payload).hexdigest(),
        "info": dict(info or {}),
    }
    staging = Path(tempfile.mkdtemp(prefix=f".{request.key}-", dir=final.parent))
    as_if_created(staging, folder=True)  # a shared cache must be readable by its other users
    try:
        (staging / WEIGHTS).write_bytes(payload)
        (staging / MANIFEST).write_text(json.dumps(manifest, indent=2, sort_keys=True))
        try:
            os.rename(staging, final)
        except OSError:
            if not exists(request, root):  # not a concurrent writer of the same key
                raise
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return final


def load(request: ArtefactRequest, root: Path | None = None) -> dict[str, np.ndarray]:
    """The weights stored under ``request``'s key, after checking the manifest and the hash.

    Raises:
        ArtefactError: No artefact, or one that is corrupt (unreadable manifest, weights whose
            hash differs) or foreign (another format, or made for another request).
    """
    where = artefact_path(request, root)
    manifest = read_manifest(where)
    if manifest.get("format") != FORMAT or manifest.get("format_version") != FORMAT_VERSION:
        raise ArtefactError(
            f"{where} is not an ns_pz artefact of format {FORMAT} v{FORMAT_VERSION} "
            f"(format={manifest.get('format')!r}, version={manifest.get('format_version')!r})"
        )
    if manifest.get("request") != request.record() or manifest.get("key") != request.key:
        raise ArtefactError(
            f"{where} was made for another request: {manifest.get('request')!r}, not "
            f"{request.record()!r}; delete it (ns-pz train rebuilds it)"
        )
    try:
        payload = (where / WEIGHTS).read_bytes()
    except OSError as error:
        raise ArtefactError(f"{where / WEIGHTS} cannot be read: {error}") from None
    if hashlib.sha256(payload).hexdigest() != manifest.get("weights_sha256"):
        raise ArtefactError(
            f"{where / WEIGHTS} is corrupt (its SHA-256 differs from the manifest's); "
            "delete the folder and train again (ns-pz train)"
        )
    with np.load(io.BytesIO(payload), allow_pickle=False) as archive:
        return {name: archive[name] for name in archive.files}


def read_manifest(where: Path) -> dict[str, Any]:
    """The manifest of the artefact in ``where``.

    Raises:
        ArtefactError: It is missing or is not a JSON object.
    """
    try:
        manifest = json.loads((where / MANIFEST).read_text())
    except FileNotFoundError:
        raise ArtefactError(f"no artefact at {where}; train it first (ns-pz train)") from None
    except (OSError, ValueError) as error:
        raise ArtefactError(f"{where / MANIFEST} is unreadable: {error}") from None
    if not isinstance(manifest, dict):
        raise ArtefactError(f"{where / MANIFEST} is not a JSON object")
    return manifest


@contextlib.contextmanager
def key_lock(request: ArtefactRequest, root: Path | None = None) -> Iterator[None]:
    """Hold an exclusive lock on ``request``'s key (blocks while another process holds it)."""
    folder = artefact_path(request, root).parent
    folder.mkdir(parents=True, exist_ok=True)
    with open(folder / f".{request.key}.lock", "a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


Trainer = Callable[[], tuple[Mapping[str, np.ndarray], Mapping[str, Any]]]


def load_or_train(
    request: ArtefactRequest, train: Trainer, root: Path | None = None
) -> tuple[dict[str, np.ndarray], bool]:
    """The artefact of ``request``, trained with ``train()`` first if it is missing.

    Under the key's lock, so concurrent callers train it once. ``train()`` returns the weights
    and the manifest's ``info``.

    Returns:
        The weights, and whether this call trained them.

    Raises:
        ArtefactError: A stored artefact is corrupt or foreign (it is not overwritten).
    """
    if exists(request, root):
        return load(request, root), False
    with key_lock(request, root):
        if exists(request, root):  # another process trained it while we waited
            return load(request, root), False
        weights, info = train()
        save(request, weights, info, root)
    return load(request, root), True
