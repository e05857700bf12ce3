"""The running line's frames as its own vision program writes them into a folder, for
``watch --production --frames DIR``.

A file is taken once, in the folder's order (by name, its numbers by value as a camera
program counts its frames: ``img_9`` before ``img_10``), and only when it is whole: its size and modification time unchanged for
``settle_s`` (a writer still at it changes them; one that writes to a temporary name and
renames it, the safe way, shows a whole file at once, and names starting with ``.`` are
not images here). Files already in the folder when the watch starts are not new and are
left alone. A cycle takes ``parts`` frames; when more than twice that wait (frames land
faster than they are measured), the oldest are dropped and counted, so the queue never
grows. What the feed remembers of files is of those still in the folder (a name gone is
forgotten; a new file of that name is new): its memory is the folder's listing's, however
long the watch runs.

A new file that cannot be a frame (empty once settled, a pipe, a device, a link to one)
is passed over and counted, never opened: reading a pipe or ``/dev/zero`` would block or
never end. A wait of more than ``quiet_s`` says what it waits on, and why nothing is taken
(the folder gone or replaced by a file, only unusable files landing), through ``notify``,
and again whenever that changes.
"""

from __future__ import annotations

import re
import stat
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from inspect_validate.interruption import stop_if_requested

__all__ = ["FolderFeed"]


@dataclass
class FolderFeed:
    """New whole image files of ``folder``, ``parts`` at a time (module description).

    Attributes
    ----------
    dropped : int
        Frames left unmeasured so far because they landed faster than the watch measures.
    unusable : dict
        New files passed over because they cannot be frames, of those still in the
        folder: name → why.
    passed_over : int
        Files passed over so far because they could not be frames.
    """

    folder: Path
    parts: int
    settle_s: float = 0.2
    poll_s: float = 0.05
    quiet_s: float = 10.0
    notify: Callable[[str], None] | None = None
    dropped: int = 0
    unusable: dict[str, str] = field(default_factory=dict)
    passed_over: int = 0
    _seen: set[str] = field(default_factory=set)
    _changing: dict[str, tuple[int, int, float]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self._seen = {p.name for p in self._images()}

    def _images(self) -> list[Path]:
        from inspect_validate.images import is_image_name

        try:
            entries = list(self.folder.iterdir())
        except OSError:
            return []  # a folder moved away for a moment: nothing new yet
        return sorted((p for p in entries if is_image_name(p)), key=natural_key)

    def _forget_gone(self, present: list[Path]) -> None:
        """Forget the names no longer in the folder (bounded memory: module description)."""
        names = {p.name for p in present}
        self._seen &= names
        for memo in (self._changing, self.unusable):
            for name in [n for n in memo if n not in names]:
                del memo[name]

    def ready(self) -> list[Path]:
        """The new files that are whole now, in the folder's order (not yet taken)."""
        now, out = time.monotonic(), []
        present = self._images()
        if present or self.folder.is_dir():  # not while the folder is away for a moment
            self._forget_gone(present)
        for path in present:
            if path.name in self._seen:
                continue
            try:
                st = path.stat()
            except OSError:
                if path.is_symlink():  # a link to nothing, or a loop of links
                    self._pass_over(path, "a symbolic link to no file")
                continue  # else renamed or removed between the listing and now
            if not stat.S_ISREG(st.st_mode):
                self._pass_over(path, "not a regular file (a pipe, a device or a folder)")
                continue
            size, mtime = st.st_size, st.st_mtime_ns
            before = self._changing.get(path.name)
            if before is None or before[:2] != (size, mtime):
                self._changing[path.name] = (size, mtime, now)
            elif now - before[2] >= self.settle_s:
                if size > 0:
                    out.append(path)
                else:
                    self._pass_over(path, "empty (0 bytes)")
        return out

    def _pass_over(self, path: Path, why: str) -> None:
        self._seen.add(path.name)
        self._changing.pop(path.name, None)
        self.unusable[path.name] = why
        self.passed_over += 1

    def waiting_on(self, found: int) -> str:
        """What a wait with ``found`` whole new frames waits on, and why no more came."""
        where = f"{found} of {self.parts} new frames in {self.folder}"
        if not self.folder.exists():
            return f"{where}: the folder is gone (deleted or moved); frames are taken again once it is back"
        if not self.folder.is_dir():
            return f"{where}: it is a file now, not a folder; put the folder back"
        if self.unusable:
            kinds = Counter(self.unusable.values())
            told = "; ".join(f"{n} {why}" for why, n in kinds.items())
            return f"{where}: new files that cannot be frames were passed over ({told})"
        return f"{where}: no new image file has landed"

    def take(self) -> tuple[list[Path], int]:
        """Wait for ``parts`` whole new files and take them; the files and how many older
        ones were dropped for them (more than twice ``parts`` waiting). A stop request
        ends the wait (:func:`~inspect_validate.interruption.stop_if_requested`)."""
        since, told = time.monotonic(), ""
        while True:
            stop_if_requested()
            waiting = self.ready()
            if len(waiting) >= self.parts:
                break
            if self.notify is not None and time.monotonic() - since >= self.quiet_s:
                why = self.waiting_on(len(waiting))
                if why != told:
                    self.notify(f"waiting for {why}")
                    told = why
            time.sleep(self.poll_s)
        drop = max(0, len(waiting) - 2 * self.parts)
        taken = waiting[drop : drop + self.parts]
        for path in waiting[: drop + self.parts]:
            self._seen.add(path.name)
            self._changing.pop(path.name, None)
        self.dropped += drop
        return taken, drop


def natural_key(path: Path) -> tuple:
    """A file's place in a folder as a camera program numbers its frames: the runs of
    digits in its name by value (``img_9`` before ``img_10``) and before letters (as in
    ASCII and natsort: ``2`` before ``b``), the name's text itself last (``img_09`` and
    ``img_9`` keep one order)."""
    parts = re.split(r"(\d+)", path.name)
    return (tuple((0, int(p), "") if p.isdigit() else (1, 0, p) for p in parts if p), path.name)
