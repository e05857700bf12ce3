"""The package's import graph has no cycle, counting the imports inside functions too
(a deferred import hides a cycle from Python, not from a reader)."""

import ast
from collections import defaultdict
from pathlib import Path

import pytest
from conftest import ROOT


def _modules() -> dict[str, Path]:
    """Module name → file, the camera/ folder under its installed name."""
    mods = {}
    for base in ("inspect_validate", "camera"):
        for path in (ROOT / base).rglob("*.py"):
            parts = list(path.relative_to(ROOT).with_suffix("").parts)
            if parts[0] == "camera":
                parts = ["inspect_validate", *parts]
            if parts[-1] == "__init__":
                parts = parts[:-1]
            mods[".".join(parts)] = path
    return mods


def _edges(depth: int) -> dict[str, set[str]]:
    """Imports between the units of ``depth`` name parts (2: inspect_validate.camera…)."""
    mods = _modules()

    def owner(name: str) -> str | None:
        while name and name not in mods:
            name = name.rpartition(".")[0]
        return name or None

    def unit(name: str) -> str:
        return ".".join(name.split(".")[:depth])

    edges = defaultdict(set)
    for name, path in mods.items():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                targets = [node.module, *(f"{node.module}.{a.name}" for a in node.names)]
            else:
                continue
            for target in targets:
                found = owner(target) if target.startswith("inspect_validate") else None
                if found is None:
                    continue
                a, b = unit(name), unit(found)
                # a package's __init__ re-exports its modules: not a dependency of theirs
                if a != b and not b.startswith(a + ".") and a != "inspect_validate":
                    edges[a].add(b)
    return edges


def _cycles(edges) -> list[list[str]]:
    index, low, stack, on, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in edges.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in list(edges):
        if v not in index:
            visit(v)
    return found


@pytest.mark.parametrize("depth", [2, 3, 9])
def test_no_import_cycle(depth):
    # depth 2: packages (camera, model, verification…), 3: their subpackages, 9: modules
    assert _cycles(_edges(depth)) == []


def test_the_checker_finds_a_cycle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


# What the device layer may use of the rest: exit-code errors, atomic files, reading
# image files (the replay camera), the strict-model base of its settings, and the
# constants module (numbers only, importing nothing: the longest exposure a camera is set
# to is the same bound the scene and the model read), and the stop a signal asked for
# (interruption, importing nothing: a capture stops at its next frame).
DEVICE_LAYER_MAY_IMPORT = {
    "inspect_validate",  # the version
    "inspect_validate.constants",
    "inspect_validate.errors",
    "inspect_validate.files",
    "inspect_validate.images",
    "inspect_validate.interruption",
    "inspect_validate.config",
    "inspect_validate.strict_yaml",  # config's YAML dialect
}


def test_the_device_layer_imports_nothing_of_the_science():
    """camera/ (installed as inspect_validate.camera) is devices only: grabbers, light
    controllers, the capture sequence and its folder. It imports no model, scene,
    statistics, station or verification, counting imports inside functions."""
    mods = _modules()
    device = {name for name in mods if name.startswith("inspect_validate.camera")}
    edges = _edges(9)
    wrong = {
        (name, target)
        for name in device
        for target in edges.get(name, ())
        if not target.startswith("inspect_validate.camera")
        and target not in DEVICE_LAYER_MAY_IMPORT
    }
    assert not wrong, sorted(wrong)
    # nor through what it may import: those modules stay among themselves
    through = {
        (name, target)
        for name in DEVICE_LAYER_MAY_IMPORT - {"inspect_validate"}
        for target in edges.get(name, ())
        if target not in DEVICE_LAYER_MAY_IMPORT
    }
    assert not through, sorted(through)


def test_the_layer_check_sees_a_forbidden_import(tmp_path, monkeypatch):
    """The check above fails on a device module that imports the model (a copy of the
    tree with one such import added)."""
    import shutil

    import conftest

    copy = tmp_path / "tree"
    for part in ("inspect_validate", "camera"):
        shutil.copytree(ROOT / part, copy / part)
    grabber = copy / "camera" / "grabbers" / "v4l2.py"
    grabber.write_text(
        grabber.read_text() + "\n\ndef _f():\n    from inspect_validate.model import predict\n"
    )
    monkeypatch.setattr(conftest, "ROOT", copy)
    monkeypatch.setitem(globals(), "ROOT", copy)
    with pytest.raises(AssertionError, match=r"inspect_validate\.model"):
        test_the_device_layer_imports_nothing_of_the_science()


def _private_imports(mods: dict[str, Path]) -> list[str]:
    """``from A import _name`` of a module's private name by another module (a private
    submodule, ``from inspect_validate.stats import _region_kernels``, is the package's
    own and allowed)."""
    found = []
    for name, path in mods.items():
        for node in ast.walk(ast.parse(path.read_text())):
            if not (isinstance(node, ast.ImportFrom) and node.module):
                continue
            if not node.module.startswith(("inspect_validate", "camera")):
                continue
            for alias in node.names:
                private = alias.name.startswith("_") and not alias.name.startswith("__")
                if private and f"{node.module}.{alias.name}" not in mods:
                    found.append(f"{name}:{node.lineno} imports {node.module}.{alias.name}")
    return found


def test_no_module_imports_another_modules_private_name(tmp_path):
    """A name one module keeps private is used by it alone: a helper two modules share is
    public (or moved). The check sees one where it is planted."""
    mods = _modules()
    assert _private_imports(mods) == []
    planted = tmp_path / "planted.py"
    planted.write_text("from inspect_validate.camera.capture import _repeats\n")
    assert _private_imports({"planted": planted}) == [
        "planted:1 imports inspect_validate.camera.capture._repeats"
    ]


def test_a_package_docstring_that_lists_modules_lists_every_one_and_no_other():
    """Where a package's docstring names its modules (``:mod:`.name```), the names are the
    package's modules, all of them (a moved or added module fails here, not in a reader's
    hands)."""
    import re

    for init in [*(ROOT / "inspect_validate").rglob("__init__.py"), *(ROOT / "camera").rglob("__init__.py")]:  # fmt: skip
        named = set(
            re.findall(r":mod:`\.(\w+)`", ast.get_docstring(ast.parse(init.read_text())) or "")
        )
        if not named:
            continue
        have = {
            p.stem if p.suffix == ".py" else p.name
            for p in init.parent.iterdir()
            if (p.suffix == ".py" or (p / "__init__.py").exists()) and not p.name.startswith("_")
        }
        assert named == have, (
            f"{init.parent.name}: lists {sorted(named - have)}, lacks {sorted(have - named)}"
        )


def test_every_test_file_the_code_cites_exists():
    """A docstring or comment sending a reader to ``tests/…py`` sends them somewhere."""
    import re

    for path in [*(ROOT / "inspect_validate").rglob("*.py"), *(ROOT / "camera").rglob("*.py")]:
        for cited in re.findall(r"tests/[\w/]+\.py", path.read_text()):
            assert (ROOT / cited).is_file(), f"{path.relative_to(ROOT)} cites {cited}"
