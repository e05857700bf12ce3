"""Writing output files: atomically, with the user's permissions, with clear errors; and
the one check that an input file is there to be read (:func:`input_file`).

Every file the tool writes (JSON reports, captured frames, sidecars, manifests)
goes through :func:`atomic_write`: a reader never sees half a file, and a crash
leaves the previous version in place. Output paths given on the command line are
checked up front (:func:`output_file`, :func:`output_folder`) so that a typo
fails before a capture or a long sweep, not after it.
"""

from __future__ import annotations

import contextlib
import errno
import json
import math
import os
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

from inspect_validate.errors import InputError

if TYPE_CHECKING:
    import numpy as np

__all__ = [
    "NotRegularFile",
    "atomic_write",
    "fresh_folder",
    "input_file",
    "json_number",
    "json_ready",
    "output_file",
    "output_folder",
    "regular_opener",
    "regular_text",
    "unused_path",
    "write_json",
]


def _umask() -> int:
    # os.umask can only be read by setting it; done once, restored at once.
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


_FILE_MODE = 0o666 & ~_umask()


#: The outermost folder each :func:`output_folder` call created, in this process: what a
#: refused run removes again where it holds no file (:func:`remove_empty_outputs`).
_CREATED: list[Path] = []


def input_file(path: str | Path, what: str, *, todo: str, largest: int | None = None) -> Path:
    """``path`` as a regular file to read, of at most ``largest`` bytes, else an
    :class:`InputError` naming it, saying whether it is missing, a folder, a device or
    pipe (which never end or block a read) or larger than any such file, and ``todo``
    (what to give instead)."""
    path = Path(path)
    if path.is_file():
        size = path.stat().st_size
        if largest is None or size <= largest:
            return path
        raise InputError(
            f"{size / 2**20:,.0f} MB is larger than any {what} (at most "
            f"{largest / 2**20:,.0f} MB is read); {todo}",
            source=str(path),
        )
    if path.is_dir():
        why = "a folder"
    elif path.exists():
        why = "not a regular file (a device or a pipe)"
    elif path.is_symlink():
        # A link resolving nowhere (or to itself) exists as a name: "not found" would
        # send the user looking for a file the listing shows.
        why = "a symbolic link to nothing (its target is missing, or the links loop)"
    else:
        why = f"{what} not found"
    raise InputError(f"{why}; {todo}", source=str(path))


def regular_text(path: Path) -> str:
    """The text of ``path``, refused with an :class:`OSError` where it is not a regular file
    (a pipe would block the read, a device never end it); for readers that turn an
    ``OSError`` into their own message."""
    if path.exists() and not path.is_file():
        raise OSError("not a regular file")
    return path.read_text()


def output_folder(path: str | Path) -> Path:
    """Create ``path`` (and parents) as a folder, or raise an error naming what is in the way."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise InputError("is a file, not a folder; give a folder for the output", source=str(path))
    missing = [p for p in (path, *path.parents) if not p.exists()]
    try:
        path.mkdir(parents=True, exist_ok=True)
        if missing:
            _CREATED.append(missing[-1])
    except (FileExistsError, NotADirectoryError):
        raise InputError(
            "cannot create this folder: part of the path is a file", source=str(path)
        ) from None
    except OSError as exc:
        raise InputError(f"cannot create this folder ({exc.strerror})", source=str(path)) from None
    return path


def unused_path(path: Path) -> Path:
    """``path``, or where something is already there ``<path>-2``, ``<path>-3``…: the
    name a folder set aside takes (two set aside within one second of each other)."""
    free, k = path, 1
    while free.exists() or free.is_symlink():
        k += 1
        free = path.with_name(f"{path.name}-{k}")
    return free


def fresh_folder(
    path: str | Path, *, derived: frozenset[str], keep: Iterable[str | Path | None] = ()
) -> Path | None:
    """Empty ``path`` for a run that writes its outputs there again, losing nothing.

    The files an earlier run wrote there and a run makes anew (their names in
    ``derived``, in the folder or its subfolders, and the temporary files of a write
    that was killed) are removed, so a run killed while writing leaves its own files,
    never a mix of two runs'. Where the folder holds anything else, such as the frames
    an earlier run captured into it, the folder is set aside whole, renamed to
    ``<name>-<time it was last written>`` beside it, and that path is returned. A
    folder holding a path of ``keep`` (what this run reads) stays where it is, and only
    its derived files are removed.

    Returns
    -------
    Path or None
        Where the earlier folder now is, or None where nothing was set aside.
    """
    import time

    path = Path(path)
    if not path.is_dir() or path.is_symlink():
        return None  # absent, or refused as output (output_folder) with a clear message

    def is_derived(p: Path) -> bool:
        return p.name in derived or (p.name.startswith(".") and p.name.endswith(".tmp"))

    def is_kept(p: Path) -> bool:  # resolved, as the paths to keep are
        return any(k == p or k in p.parents or p in k.parents for k in kept)

    root = path.resolve()
    kept = [Path(k).resolve() for k in keep if k is not None]
    entries = list(root.rglob("*"))  # under the resolved folder, as ``kept`` is
    inside = [p for p in entries if not p.is_dir() or p.is_symlink()]
    if any(root == k or root in k.parents for k in kept) or all(map(is_derived, inside)):
        for p in inside:
            if is_derived(p) and not is_kept(p):
                p.unlink(missing_ok=True)
        for sub in sorted((d for d in entries if d.is_dir() and not is_kept(d)), reverse=True):
            with contextlib.suppress(OSError):
                sub.rmdir()  # a camera's report folder left empty
        return None
    stamp = time.strftime("%Y%m%dT%H%M%S", time.localtime(path.stat().st_mtime))
    aside = unused_path(path.with_name(f"{path.name}-{stamp}"))
    try:
        path.rename(aside)
    except OSError as exc:
        raise InputError(
            f"holds an earlier run's files that could not be set aside ({exc.strerror}); "
            "move them, or give another folder",
            source=str(path),
        ) from None
    return aside


@contextlib.contextmanager
def cleaned_outputs() -> Iterator[None]:
    """Within it, a run that fails (an error, Ctrl-C, a failed verdict's exit) removes the
    folders it created that hold no file: a run refused before it wrote anything must not
    leave folders that block a rerun or look like results. A folder with any file in it,
    a frame, a manifest, is kept."""
    import shutil

    start = len(_CREATED)
    try:
        yield
    except BaseException:
        for top in reversed(_CREATED[start:]):
            try:
                if top.is_dir() and not any(p.is_file() or p.is_symlink() for p in top.rglob("*")):
                    shutil.rmtree(top)
            except OSError:
                continue  # not ours to fight over: left as it is
        raise
    finally:
        del _CREATED[start:]


def output_file(path: str | Path) -> Path:
    """Check that ``path`` can be written as a file (creating its folder)."""
    path = Path(path)
    if path.is_dir():
        raise InputError("is a folder; give a file name for the output", source=str(path))
    output_folder(path.parent)
    return path


def atomic_write(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` through a temporary file and a rename.

    The file gets the permissions a plain ``open()`` would give (0666 less the
    umask), not the 0600 of a temporary file, and is flushed to disk before the
    rename.

    A symbolic link is written through (its target replaced, the link kept), and a
    device, pipe or terminal (``/dev/stdout``, ``/dev/null``, a FIFO) is written to as a
    stream: a rename would put a regular file in its place.

    Raises
    ------
    InputError
        The path is a folder, lies under a file, or cannot be written.
    """
    path = output_file(path)
    if path.exists() and not path.is_file():
        try:
            fd = _stream_fd(path)
            os.set_blocking(fd, True)
            with open(fd, "wb") as f:
                f.write(data)
        except OSError as exc:
            why = exc.strerror or str(exc)
            if exc.errno == errno.ENXIO:
                why = (
                    f"a pipe no program read within {READER_WAIT_S:g} s; start its reader "
                    "first, or give a file"
                )
            raise InputError(f"cannot write ({why})", source=str(path)) from None
        return path
    if path.is_symlink():
        path = path.resolve()
    try:
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    except OSError as exc:
        raise InputError(f"cannot write here ({exc.strerror})", source=str(path)) from None
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fchmod(f.fileno(), _FILE_MODE)
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except OSError as exc:  # a full disk, a vanished mount, a quota
        Path(tmp).unlink(missing_ok=True)
        raise InputError(
            f"cannot write ({exc.strerror or exc}); free space or choose another folder",
            source=str(path),
        ) from None
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


#: How long an output that is a FIFO waits for a reader to open it, s (one started beside
#: the command may come a moment later; none at all blocked devices --json FIFO for good).
READER_WAIT_S = 10.0


def _stream_fd(path: Path) -> int:
    """A descriptor to write ``path`` (a device, pipe or terminal) as a stream: a FIFO's
    reader is waited for :data:`READER_WAIT_S`, then ENXIO is raised."""
    import time

    deadline = time.monotonic() + READER_WAIT_S
    while True:
        try:
            return os.open(path, os.O_WRONLY | os.O_NONBLOCK)
        except OSError as exc:
            if exc.errno != errno.ENXIO or time.monotonic() >= deadline:
                raise
            time.sleep(0.05)


class NotRegularFile(OSError):
    """:func:`regular_opener` found a FIFO, socket, device or folder in a file's place."""


def regular_opener(path: str, flags: int) -> int:
    """An ``opener`` for :func:`open` of a file the tool keeps writing (a lock, a journal):
    never through a symbolic link (``ELOOP``, so its target is not written over), never
    blocking on a FIFO (``ENXIO`` where nobody reads it), and only a regular file
    (:class:`NotRegularFile`)."""
    import stat

    fd = os.open(path, flags | os.O_NOFOLLOW | os.O_NONBLOCK)
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        raise NotRegularFile(f"{Path(path).name} is not a regular file; remove it")
    os.set_blocking(fd, True)
    return fd


def exclusive_lock(lock_path: Path, *, holder: str, what: str, remedy: str, source: Path) -> TextIO:
    """An exclusive ``flock`` on ``lock_path`` (created if need be), held until the
    returned file is closed, with this process's id written in it; a second taker is
    refused at once naming the first.

    Raises
    ------
    InputError
        The lock is held (naming the holder's pid, ``what`` it guards and ``remedy``),
        or the lock file cannot be made; naming ``source``.
    """
    import fcntl

    name = Path(lock_path).name
    while True:
        try:
            handle = open(lock_path, "a+", opener=regular_opener)
        except NotRegularFile:
            raise InputError(
                f"cannot lock {what}: {name} is not a regular file (a FIFO, socket or "
                "device in the lock's place); remove it",
                source=str(source),
            ) from None
        except OSError as exc:
            why = exc.strerror or str(exc)
            if exc.errno == errno.ELOOP:
                why = f"{name} is a symbolic link, not a lock file; remove it"
            raise InputError(f"cannot lock {what} ({why})", source=str(source)) from None
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            handle.seek(0)
            pid = handle.read().strip() or "another process"
            handle.close()
            raise InputError(
                f"another {holder} ({pid}) is writing {what}; stop it first, or give {remedy}",
                source=str(source),
            ) from None
        # A holder that removes its lock file on release (release_lock) may have done so
        # between our open and our flock: then this lock is on a file nobody else sees.
        try:
            if os.stat(lock_path).st_ino == os.fstat(handle.fileno()).st_ino:
                break
        except FileNotFoundError:
            pass
        handle.close()
    handle.seek(0)
    handle.truncate()
    handle.write(f"pid {os.getpid()}")
    handle.flush()
    return handle


def release_lock(handle: TextIO) -> None:
    """Release a lock of :func:`exclusive_lock` and remove its file (a folder of results
    is left without it)."""
    Path(handle.name).unlink(missing_ok=True)  # before the release: no taker sees it freed
    handle.close()


def json_number(x: float | np.floating | None) -> float | str | None:
    """A number for JSON: ±inf as "inf"/"-inf", NaN and None as null."""
    if x is None:
        return None
    x = float(x)
    if math.isnan(x):
        return None
    return x if math.isfinite(x) else ("inf" if x > 0 else "-inf")


def json_ready(obj: Any) -> Any:
    """``obj`` with every float (also numpy scalars) passed through :func:`json_number`."""
    import numpy as np  # once a document, not once per value of it

    def ready(o: Any) -> Any:
        if isinstance(o, dict):
            return {k: ready(v) for k, v in o.items()}
        if isinstance(o, (list, tuple)):
            return [ready(v) for v in o]
        if isinstance(o, (float, np.floating)):
            return json_number(o)
        if isinstance(o, np.integer):
            return int(o)
        if isinstance(o, np.bool_):
            return bool(o)
        return o

    return ready(obj)


def write_json(doc: dict, path: str | Path) -> Path:
    """Write ``doc`` (made :func:`json_ready`) atomically: a reader never sees half a file.
    ``-`` is standard output."""
    text = json.dumps(json_ready(doc), indent=2, allow_nan=False) + "\n"
    if str(path) == "-":
        import sys

        sys.stdout.write(text)
        sys.stdout.flush()
        return Path("-")
    return atomic_write(path, text.encode())
