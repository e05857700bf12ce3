"""Comparisons: which groups of classes are told apart, and how a group of several is weighted.

A comparison is a pair of groups of class names, ``(("A",), ("B", "C"))``,
written ``"A vs B,C"``. By default every pair of classes is compared and, with
three or more classes, each class against all the others (the chapter's
Tables 3–4). ``measure``, ``predict``, ``analyze-spectra`` and ``verify`` all
read one :class:`Comparisons`, so a label means the same numbers everywhere.

A group of several classes is a **mixture** of its classes, weighted by

* ``equal`` (default): each class counts the same, whatever its area;
* class **priors** (``{A: 0.7, B: 0.2, C: 0.1}``): how often each class occurs
  on the line, normalised within the group;
* ``pixels``: by the pixel count of each class's region — pooling the pixels,
  as the chapter does for its Table 3 (measurement only: a scene has no pixels).

How far the two groups of each comparison are apart is
:mod:`inspect_validate.separations`'.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from itertools import combinations
from typing import TYPE_CHECKING, Literal

import numpy as np
from numpy.typing import ArrayLike

from inspect_validate.errors import InputError

if TYPE_CHECKING:
    pass

__all__ = [
    "Comparisons",
    "RankBy",
    "default_groups",
    "find_comparison",
    "label",
    "named_groups",
]

Group = tuple[int, ...]
Weighting = Literal["equal", "pixels"]
"""How the classes of a group are weighted, besides class priors."""
RankBy = Literal["error", "snr_db", "cnr_db"]
"""What combinations are ranked by: ε Gauss (lowest first), SNR_dB or CNR_dB (highest first)."""


def default_groups(n_classes: int) -> list[tuple[Group, Group]]:
    """Index groups: every pair, then (with three or more classes) each against the rest."""
    return _pairs(n_classes) + _rest(n_classes)


def _pairs(n):
    return [((a,), (b,)) for a, b in combinations(range(n), 2)]


def _rest(n):
    if n < 3:
        return []
    return [((i,), tuple(j for j in range(n) if j != i)) for i in range(n)]


def named_groups(names: Sequence[str]) -> tuple[tuple[tuple[str, ...], tuple[str, ...]], ...]:
    """:func:`default_groups` of ``names``, as groups of names."""
    return tuple(
        (tuple(names[i] for i in a), tuple(names[i] for i in b))
        for a, b in default_groups(len(names))
    )


def label(first: Iterable[str], second: Iterable[str]) -> str:
    """``"A vs B,C"``."""
    return f"{','.join(first)} vs {','.join(second)}"


def _parse(text: str) -> tuple[frozenset, frozenset] | None:
    parts = text.split(" vs ") if " vs " in text else text.split("vs")
    if len(parts) != 2:
        return None
    first, second = (frozenset(n.strip() for n in p.split(",") if n.strip()) for p in parts)
    return (first, second) if first and second else None


def find_comparison(comparisons: Iterable[tuple[Sequence[str], Sequence[str]]], text: str) -> int:
    """Index of the comparison written ``text`` (``"A vs B,C"``; spaces and order
    inside a group do not matter) in a sequence of ``(first, second)`` name groups.

    Raises
    ------
    InputError
        No such comparison; the message lists the ones there are.
    """
    want = _parse(text)
    for i, (a, b) in enumerate(comparisons):
        if (frozenset(a), frozenset(b)) == want:
            return i
    known = ", ".join(label(a, b) for a, b in comparisons)
    raise InputError(f"no comparison {text!r}; there are: {known}")


@dataclass(frozen=True)
class Comparisons:
    """The comparisons of a set of classes and the weighting of groups.

    Attributes
    ----------
    classes : tuple of str
        Class names, in the order of the class axis of every array.
    groups : tuple of (tuple of int, tuple of int)
        Class indices of the two sides of each comparison.
    weights : ``"equal"``, ``"pixels"`` or tuple of float
        Group weighting; a tuple holds one prior per class.
    """

    classes: tuple[str, ...]
    groups: tuple[tuple[Group, Group], ...]
    weights: str | tuple[float, ...] = "equal"

    @classmethod
    def of(
        cls,
        classes: Sequence[str],
        groups: str | Sequence[str] = "default",
        weights: str | Mapping[str, float] = "equal",
        *,
        source: str | None = None,
    ) -> Comparisons:
        """The comparisons a ``comparisons:`` section asks for: its ``groups`` and
        ``weights`` as :class:`~inspect_validate.scene_file.ComparisonsSpec` reads them
        (default: every pair and each class against the rest, equal weights); unknown
        class names are errors naming ``source``."""
        classes = tuple(classes)
        n = len(classes)
        if groups == "default":
            found = default_groups(n)
        elif groups == "pairs":
            found = _pairs(n)
        elif groups == "rest":
            found = _rest(n) or _pairs(n)
        else:
            found = []
            for text in [groups] if isinstance(groups, str) else groups:
                sides = _parse(text)
                if sides is None:
                    raise InputError(
                        f"comparisons.groups: {text!r} is not 'A vs B' or 'A vs B,C'", source=source
                    )
                unknown = sorted((sides[0] | sides[1]) - set(classes))
                if unknown or sides[0] & sides[1]:
                    why = (
                        f"no class {unknown[0]!r} (there are {', '.join(classes)})"
                        if unknown
                        else "a class is on both sides"
                    )
                    raise InputError(f"comparisons.groups: {text!r}: {why}", source=source)
                one, other = (tuple(i for i in range(n) if classes[i] in s) for s in sides)
                found.append((one, other))
        if isinstance(weights, Mapping):
            priors = weights
            unknown = sorted(set(priors) - set(classes))
            missing = [c for c in classes if c not in priors]
            if unknown or missing:
                what = f"no class {unknown[0]!r}" if unknown else f"no prior for {missing[0]!r}"
                raise InputError(
                    f"comparisons.weights: {what}; give one prior per class ({', '.join(classes)})",
                    source=source,
                )
            return cls(classes, tuple(found), tuple(float(priors[c]) for c in classes))
        if weights not in ("equal", "pixels"):
            raise InputError(
                f"comparisons.weights: {weights!r} is not 'equal', 'pixels' or class priors",
                source=source,
            )
        return cls(classes, tuple(found), weights)

    @property
    def named(self) -> tuple[tuple[tuple[str, ...], tuple[str, ...]], ...]:
        """Each comparison as ``(first names, second names)``."""
        return tuple(
            (tuple(self.classes[i] for i in a), tuple(self.classes[i] for i in b))
            for a, b in self.groups
        )

    @property
    def pairs(self) -> tuple[int, ...]:
        """Positions of the comparisons of one class against one class (ε in closed form);
        the others compare a group, a Gaussian mixture."""
        return tuple(j for j, (a, b) in enumerate(self.groups) if len(a) == len(b) == 1)

    @property
    def labels(self) -> tuple[str, ...]:
        return tuple(label(a, b) for a, b in self.named)

    @property
    def weighting(self) -> str:
        """``"equal"``, ``"pixels"`` or ``"priors"``."""
        return self.weights if isinstance(self.weights, str) else "priors"

    def index(self, text: str) -> int:
        """Position of the comparison written ``text`` (see :func:`~inspect_validate.comparisons.find_comparison`)."""
        return find_comparison(self.named, text)

    def subset(self, texts: Iterable[str]) -> Comparisons:
        """Only the comparisons written ``texts`` (each as :meth:`index` reads it), in that order."""
        return Comparisons(
            self.classes, tuple(self.groups[self.index(t)] for t in texts), self.weights
        )

    def with_pixels(self, pixels: ArrayLike) -> Comparisons:
        """These comparisons with ``pixels`` weighting turned into priors from the regions'
        pixel counts, for a prediction of the same regions; others unchanged."""
        if self.weights != "pixels":
            return self
        return Comparisons(self.classes, self.groups, tuple(np.asarray(pixels, float).tolist()))

    def class_weights(self, pixels: ArrayLike | None = None) -> np.ndarray:
        """Unnormalised weight of each class, (K,).

        Parameters
        ----------
        pixels : array_like, optional
            Pixel count of each class's region; needed for ``pixels`` weighting.
        """
        if self.weights == "equal":
            return np.ones(len(self.classes))
        if self.weights == "pixels":
            if pixels is None:
                raise InputError(
                    "comparisons.weights: 'pixels' weights classes by their region's pixel "
                    "count, which only a measurement has; use 'equal' or class priors "
                    "({A: 0.5, B: 0.5}) for a prediction"
                )
            return np.asarray(pixels, dtype=np.float64)
        return np.asarray(self.weights, dtype=np.float64)
