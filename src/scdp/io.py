"""Crash-safe output: everything is written to a temporary sibling, then renamed.

A reader never sees a half-written file or folder, and an existing output is
only replaced once the new one is complete.
"""

from __future__ import annotations

import contextlib
import fcntl
import gzip
import json
import os
import shutil
import socket
import tempfile
from pathlib import Path

from scdp.errors import ScdpError


def check_output_path(path: str | os.PathLike, *, force: bool = False, field: str = "--out") -> Path:
    """Refuse an output that exists (without ``force``) or whose folder is not writable."""
    path = Path(path)
    if path.exists() and not force:
        raise ScdpError(field, f"{path} already exists (pass --force to replace it)")
    parent = path.parent if str(path.parent) else Path(".")
    probe = parent
    while not probe.exists():  # the first existing ancestor must be writable
        probe = probe.parent
    try:  # a real probe: os.access says yes to root even on read-only filesystems
        tempfile.TemporaryFile(dir=probe).close()
    except OSError as exc:
        raise ScdpError(field, f"cannot write to {parent} ({exc.strerror or exc})") from None
    return path


def _replace(tmp: Path, path: Path) -> None:
    """Move ``tmp`` onto ``path``; an old ``path`` is removed only after the move succeeds."""
    if path.exists():
        backup = path.with_name(f".{path.name}.old-{os.getpid()}")
        os.replace(path, backup)
        os.replace(tmp, path)
        if backup.is_dir():
            shutil.rmtree(backup)
        else:
            backup.unlink()
    else:
        os.replace(tmp, path)


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike, *, directory: bool = False):
    """Yield a temporary path next to ``path``; rename it onto ``path`` on success.

    On any exception the temporary is removed and ``path`` is left untouched.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent))
    if not directory:
        tmp.rmdir()
    try:
        yield tmp
        _replace(tmp, path)
    except BaseException:
        if tmp.is_dir():
            shutil.rmtree(tmp, ignore_errors=True)
        elif tmp.exists():
            tmp.unlink()
        raise


def write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text)
    return Path(path)


def write_json(path: str | os.PathLike, obj, *, compact: bool = False) -> Path:
    """Write ``obj`` as JSON to ``path`` atomically (indented, or ``compact`` for bulk data); a path
    ending in ``.gz`` is gzip-compressed, byte-identical for the same ``obj`` (no time stamp)."""
    text = (json.dumps(obj, separators=(",", ":")) if compact else json.dumps(obj, indent=2)) + "\n"
    if not str(path).endswith(".gz"):
        return write_text(path, text)
    with atomic_path(path) as tmp:
        tmp.write_bytes(gzip.compress(text.encode(), mtime=0))
    return Path(path)


def write_report(path: str | os.PathLike, text: str, data) -> Path:
    """A benchmark's report: ``text`` (markdown) at ``path`` and ``data`` as JSON beside it (``.json``), each
    written atomically; returns ``path``."""
    write_json(Path(path).with_suffix(".json"), data)
    return write_text(path, text)


def read_json(path: str | os.PathLike):
    """The JSON in ``path`` (gzip-compressed when it ends in ``.gz``); OSError or ValueError if unreadable."""
    data = Path(path).read_bytes()
    return json.loads(gzip.decompress(data) if str(path).endswith(".gz") else data)


def read_json_object(path: str | os.PathLike) -> dict | None:
    """The JSON object in ``path``, or None when it is missing, unreadable or not an object (a record
    that may not have been written yet)."""
    try:
        value = read_json(path)
    except (OSError, ValueError):
        return None
    return value if isinstance(value, dict) else None


@contextlib.contextmanager
def held(lock: str | os.PathLike, *, wait: bool = True):
    """Hold the POSIX record lock on the file ``lock`` (made if absent) while the block runs.

    Two processes, on one machine or on two sharing the folder (NFS passes POSIX locks to its lock
    manager), never hold it at once. The operating system lets go when the holder exits, killed or
    not, so a lost worker leaves no stale lock behind. Held by another: with ``wait``, say who and wait
    for it; without, refuse naming the holder.
    """
    lock = Path(lock)
    lock.parent.mkdir(parents=True, exist_ok=True)
    with open(lock, "a+") as f:
        try:
            fcntl.lockf(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:  # held: BlockingIOError (EAGAIN) or PermissionError (EACCES), as the system says it
            f.seek(0)
            holder = f.read().strip() or "another process"
            if not wait:
                raise ScdpError(str(lock), f"held by {holder}") from None
            print(f"{lock.name}: waiting for {holder}", flush=True)
            fcntl.lockf(f, fcntl.LOCK_EX)
        f.seek(0)
        f.truncate()
        f.write(f"pid {os.getpid()} on {socket.gethostname()}")
        f.flush()
        try:
            yield
        finally:
            fcntl.lockf(f, fcntl.LOCK_UN)
