"""Output files: written whole or not at all, and never in place of what the path names."""

import os
import threading

import pytest

from inspect_validate.files import atomic_write, fresh_folder, write_json


def test_a_symbolic_link_is_written_through(tmp_path):
    """The target is replaced and the link stays (a rename put a regular file in the
    link's place, leaving the target as it was)."""
    target = tmp_path / "shared" / "report.json"
    target.parent.mkdir()
    target.write_text("{}")
    link = tmp_path / "report.json"
    link.symlink_to(target)
    write_json({"verdict": "pass"}, link)
    assert link.is_symlink() and link.resolve() == target
    assert '"verdict": "pass"' in target.read_text()


def test_a_pipe_is_written_as_a_stream_and_stays_a_pipe(tmp_path):
    """--json /dev/stdout is a link to a pipe or terminal: written to, not replaced (as
    root, the rename replaced /dev/stdout itself). A FIFO stands in for it here."""
    fifo = tmp_path / "out"
    os.mkfifo(fifo)
    link = tmp_path / "stdout"
    link.symlink_to(fifo)
    received = []
    # The reader opens the FIFO a moment after the write begins, as a reader started
    # beside the command may (a refusal then was a race the README's command lost once).
    reader = threading.Timer(0.3, lambda: received.append(fifo.read_bytes()))
    reader.start()
    atomic_write(link, b"frame report\n")
    reader.join(timeout=10)
    assert received == [b"frame report\n"]
    assert link.is_symlink() and fifo.is_fifo()


def test_a_regular_file_is_replaced_whole(tmp_path):
    path = tmp_path / "a.json"
    path.write_text("old")
    atomic_write(path, b"new")
    assert path.read_bytes() == b"new"
    assert [p.name for p in tmp_path.iterdir()] == ["a.json"]  # no temporary left


def test_a_folder_is_refused(tmp_path):
    from inspect_validate.errors import InputError

    with pytest.raises(InputError, match="is a folder; give a file name"):
        atomic_write(tmp_path, b"x")


@pytest.mark.parametrize("kind", ["link", "fifo"])
@pytest.mark.parametrize("command", ["capture", "watch"])
def test_a_lock_file_that_is_a_link_or_a_fifo_is_refused_untouched(
    cli, tmp_path, golden, kind, command
):
    """A symbolic link where .capture.lock, .watch.lock or <db>.lock goes is never written
    through (its target's content was replaced by 'pid N'), and a FIFO there does not block
    or read 'cannot lock (None)': each is refused (exit 2) naming the file and what to do."""
    from conftest import copy_station

    station = copy_station(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    target = tmp_path / "precious.txt"
    target.write_text("keep me")
    if command == "capture":
        locks, args = [out / ".capture.lock"], ["capture", station, "--out", out]
    else:
        locks = [out / ".watch.lock", out / "h.sqlite.lock"]
        args = [
            "watch",
            station,
            "--golden",
            golden,
            "--db",
            out / "h.sqlite",
            "--out",
            out,
            "--cycles",
            1,
            "--interval",
            0,
        ]
    for lock in locks:
        for other in locks:
            other.unlink(missing_ok=True)
        if kind == "link":
            lock.symlink_to(target)
        else:
            os.mkfifo(lock)
        code, _, err = cli(args)
        assert code == 2 and lock.name in err and "remove it" in err, err
        assert ("symbolic link" if kind == "link" else "not a regular file") in err
        assert target.read_text() == "keep me"
        assert lock.is_symlink() if kind == "link" else lock.exists()


def test_a_pipe_nobody_reads_is_refused_not_waited_on(tmp_path, monkeypatch):
    """devices --json FIFO with no reader blocked for good: its reader is waited for a
    while (one started beside the command comes a moment later), then it is refused."""
    from inspect_validate import files
    from inspect_validate.errors import InputError

    monkeypatch.setattr(files, "READER_WAIT_S", 0.2)
    fifo = tmp_path / "out.json"
    os.mkfifo(fifo)
    with pytest.raises(InputError, match=r"a pipe no program read within 0\.2 s"):
        write_json({"a": 1}, fifo)
    assert fifo.exists() and not fifo.is_file()


DERIVED = frozenset({"report.html", "junit.xml"})


def test_fresh_folder_removes_only_what_a_run_makes_anew(tmp_path):
    """A folder of derived files (and a killed write's temporary file, and a camera's
    subfolder of them) is emptied in place: no two runs' files side by side."""
    (tmp_path / "r" / "side").mkdir(parents=True)
    for name in ("report.html", "junit.xml", ".report.html.abc.tmp", "side/junit.xml"):
        (tmp_path / "r" / name).write_text("old")
    assert fresh_folder(tmp_path / "r", derived=DERIVED) is None
    assert list((tmp_path / "r").iterdir()) == []


def test_fresh_folder_sets_aside_a_folder_holding_anything_else(tmp_path):
    (tmp_path / "r" / "frames").mkdir(parents=True)
    (tmp_path / "r" / "frames" / "f.tif").write_bytes(b"frame")
    (tmp_path / "r" / "junit.xml").write_text("old")
    aside = fresh_folder(tmp_path / "r", derived=DERIVED)
    assert aside is not None and aside.parent == tmp_path and aside.name.startswith("r-")
    assert (aside / "frames" / "f.tif").read_bytes() == b"frame" and not (tmp_path / "r").exists()
    (tmp_path / "r" / "frames").mkdir(parents=True)
    (tmp_path / "r" / "frames" / "f.tif").write_bytes(b"frame 2")
    again = fresh_folder(tmp_path / "r", derived=DERIVED)
    assert again is not None and again != aside and (again / "frames" / "f.tif").exists()


def test_fresh_folder_leaves_a_folder_this_run_reads_in_place(tmp_path):
    (tmp_path / "r" / "frames").mkdir(parents=True)
    (tmp_path / "r" / "frames" / "f.tif").write_bytes(b"frame")
    (tmp_path / "r" / "junit.xml").write_text("old")
    assert fresh_folder(tmp_path / "r", derived=DERIVED, keep=[tmp_path / "r" / "frames"]) is None
    assert (tmp_path / "r" / "frames" / "f.tif").exists() and not (
        tmp_path / "r" / "junit.xml"
    ).exists()
    assert fresh_folder(tmp_path / "missing", derived=DERIVED) is None
