"""Every public function of the library is typed: each parameter and the return
(the command line's click callbacks and the compiled kernels' private modules aside).
mypy in .ci/run checks the types; this checks that there are types to check."""

import ast

from conftest import ROOT


def _incomplete() -> list[str]:
    found = []
    for root in ("inspect_validate", "camera"):
        for path in sorted((ROOT / root).rglob("*.py")):
            parts = path.relative_to(ROOT).parts
            if "cli" in parts or any(p.startswith("_") and p != "__init__.py" for p in parts):
                continue
            tree = ast.parse(path.read_text())
            owners = [(None, n) for n in tree.body] + [
                (c.name, n)
                for c in tree.body
                if isinstance(c, ast.ClassDef) and not c.name.startswith("_")
                for n in c.body
            ]
            for owner, node in owners:
                if not isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                    continue
                if node.name.startswith("_") and node.name not in ("__init__", "__call__"):
                    continue
                args = node.args
                params = [*args.posonlyargs, *args.args, *args.kwonlyargs]
                params += [a for a in (args.vararg, args.kwarg) if a is not None]
                bare = [
                    a.arg for a in params if a.annotation is None and a.arg not in ("self", "cls")
                ]
                if bare or (node.returns is None and node.name != "__init__"):
                    name = f"{owner}.{node.name}" if owner else node.name
                    found.append(f"{path.relative_to(ROOT)}:{node.lineno} {name} {bare}")
    return found


def test_every_public_function_is_typed():
    missing = _incomplete()
    assert not missing, "public functions without types:\n" + "\n".join(missing)
