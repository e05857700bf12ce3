"""Comparisons: which groups of classes are told apart, and how they are named.

A comparison is a pair of groups of class names, ``(("A",), ("B", "C"))``,
written ``"A vs B,C"``. By default a scene or a frame is compared in every pair
of classes and, with three or more classes, each class against all the others
(the chapter's Tables 3–4). ``measure`` and ``predict`` both take their groups
from :func:`default_groups`, so a label means the same classes everywhere.
"""

from __future__ import annotations

from itertools import combinations

from inspect_validate.errors import InputError

__all__ = ["default_groups", "find_comparison", "label", "named_groups"]

Group = tuple[int, ...]


def default_groups(n_classes: int) -> list[tuple[Group, Group]]:
    """Index groups: every pair, then (with three or more classes) each against the rest."""
    groups = [((a,), (b,)) for a, b in combinations(range(n_classes), 2)]
    if n_classes >= 3:
        groups += [((i,), tuple(j for j in range(n_classes) if j != i)) for i in range(n_classes)]
    return groups


def named_groups(names) -> tuple[tuple[tuple[str, ...], tuple[str, ...]], ...]:
    """:func:`default_groups` of ``names``, as groups of names."""
    return tuple(
        (tuple(names[i] for i in a), tuple(names[i] for i in b))
        for a, b in default_groups(len(names))
    )


def label(first, second) -> str:
    """``"A vs B,C"``."""
    return f"{','.join(first)} vs {','.join(second)}"


def find_comparison(comparisons, text: str) -> int:
    """Index of the comparison written ``text`` (``"A vs B,C"``; spaces and order
    inside a group do not matter) in a sequence of ``(first, second)`` name groups.

    Raises
    ------
    InputError
        No such comparison; the message lists the ones there are.
    """
    parts = text.split(" vs ") if " vs " in text else text.split("vs")
    if len(parts) == 2:
        want = tuple(frozenset(n.strip() for n in p.split(",") if n.strip()) for p in parts)
        for i, (a, b) in enumerate(comparisons):
            if (frozenset(a), frozenset(b)) == want:
                return i
    known = ", ".join(label(a, b) for a, b in comparisons)
    raise InputError(f"no comparison {text!r}; there are: {known}")
