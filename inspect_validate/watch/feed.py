"""The running line's frames as its own vision program writes them into a folder, for
``watch --production --frames DIR``.

A file is taken once, in the folder's order (by name, as a camera program numbers its
frames), and only when it is whole: its size and modification time unchanged for
``settle_s`` (a writer still at it changes them; one that writes to a temporary name and
renames it, the safe way, shows a whole file at once, and names starting with ``.`` are
not images here). Files already in the folder when the watch starts are not new and are
left alone. A cycle takes ``parts`` frames; when more than twice that wait (frames land
faster than they are measured), the oldest are skipped and counted, so the queue never
grows and the memory stays bounded.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

from inspect_validate.interruption import stop_if_requested

__all__ = ["FolderFeed"]


@dataclass
class FolderFeed:
    """New whole image files of ``folder``, ``parts`` at a time (module description).

    Attributes
    ----------
    skipped : int
        Frames passed over so far because they landed faster than the watch measures.
    """

    folder: Path
    parts: int
    settle_s: float = 0.2
    poll_s: float = 0.05
    skipped: int = 0
    _seen: set[str] = field(default_factory=set)
    _changing: dict[str, tuple[int, int, float]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self._seen = {p.name for p in self._images()}

    def _images(self) -> list[Path]:
        from inspect_validate.images import _IMAGE_SUFFIXES

        try:
            entries = list(self.folder.iterdir())
        except OSError:
            return []  # a folder moved away for a moment: nothing new yet
        return sorted(
            p for p in entries if p.suffix.lower() in _IMAGE_SUFFIXES and not p.name.startswith(".")
        )

    def ready(self) -> list[Path]:
        """The new files that are whole now, in the folder's order (not yet taken)."""
        now, out = time.monotonic(), []
        for path in self._images():
            if path.name in self._seen:
                continue
            try:
                st = path.stat()
            except OSError:
                continue  # renamed or removed between the listing and now
            size, mtime = st.st_size, st.st_mtime_ns
            before = self._changing.get(path.name)
            if before is None or before[:2] != (size, mtime):
                self._changing[path.name] = (size, mtime, now)
            elif size > 0 and now - before[2] >= self.settle_s:
                out.append(path)
        return out

    def take(self) -> tuple[list[Path], int]:
        """Wait for ``parts`` whole new files and take them; the files and how many older
        ones were skipped for them (more than twice ``parts`` waiting). A stop request
        ends the wait (:func:`~inspect_validate.interruption.stop_if_requested`)."""
        while True:
            stop_if_requested()
            waiting = self.ready()
            if len(waiting) >= self.parts:
                break
            time.sleep(self.poll_s)
        skip = max(0, len(waiting) - 2 * self.parts)
        taken = waiting[skip : skip + self.parts]
        for path in waiting[: skip + self.parts]:
            self._seen.add(path.name)
            self._changing.pop(path.name, None)
        self.skipped += skip
        return taken, skip
