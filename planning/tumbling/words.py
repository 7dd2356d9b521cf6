"""Tumble sequences ("words") and their free reduction (Sec. II-B, III).

A **word** is a tuple of face indices: the faces that land, in order, starting
implicitly from a current face ``start_face`` (not part of the word).  The word
``(f1, ..., fk)`` from face ``F`` is the walk ``F -> f1 -> ... -> fk`` on the
face-adjacency graph; the empty word ``()`` is the empty walk.  Faces are plain
hashable labels (ints in nudge: indices of the part's faces).  A valid tumble
never lands the face already on the plane, so consecutive faces differ.

Public API
----------
``concat(*words) -> tuple``
``end_face(word, start_face)``
``inverse(word, start_face) -> tuple``
``power(word, n, start_face) -> tuple``
``purge(word, start_face, adjacency=None) -> tuple``
``is_walk(word, start_face, adjacency) -> bool``
``junction_cancel(word, start_face) -> int``     (``|p|`` of a loop ``p c p^-1``)
``loop_power_length(word_len, junction_cancel, n) -> int``   (``|purge(w^n)|``)
"""

from __future__ import annotations

from typing import Hashable, Iterable, Mapping, Sequence

__all__ = ["concat", "end_face", "inverse", "is_walk", "power", "purge", "junction_cancel",
           "loop_power_length", "WORD_CAP"]

Word = tuple


def concat(*words: Sequence[Hashable]) -> Word:
    """Concatenation ``w1 w2 ...`` as one tuple (the group law on loops).

    Pure concatenation: it is a walk only if each word starts from the face the
    previous one ends on (always true for loops at the same face)."""
    out: list = []
    for w in words:
        out.extend(w)
    return tuple(out)


def end_face(word: Sequence[Hashable], start_face: Hashable) -> Hashable:
    """The face on the plane after the word: its last face, or ``start_face``
    for the empty word."""
    return word[-1] if len(word) else start_face


def inverse(word: Sequence[Hashable], start_face: Hashable) -> Word:
    """The reverse walk back to ``start_face``.

    For ``w = (f1, ..., fk)`` from ``F`` returns ``(f_{k-1}, ..., f1, F)``
    (``()`` for ``k = 0``): it starts from ``end_face(w, F) = fk`` and ends on
    ``F``.  Guarantees ``purge(concat(w, inverse(w, F)), F) == ()`` and
    ``inverse(inverse(w, F), fk) == w``."""
    w = tuple(word)
    if not w:
        return ()
    return tuple(reversed(w[:-1])) + (start_face,)


def power(word: Sequence[Hashable], n: int, start_face: Hashable) -> Word:
    """``w^n``: ``n`` copies of ``w`` (``n > 0``), ``()`` (``n = 0``), or
    ``|n|`` copies of ``inverse(w, start_face)`` (``n < 0``).

    For ``|n| >= 2`` the word must be a loop (end on ``start_face``), otherwise
    the copies would not chain into a walk: ``ValueError``.  ``n = +-1`` is
    allowed for any word.  No reduction is applied (see :func:`purge`)."""
    if int(n) != n:
        raise ValueError(f"n must be an integer, got {n!r}")
    n = int(n)
    w = tuple(word)
    if abs(n) >= 2 and w and w[-1] != start_face:
        raise ValueError(
            f"power(word, {n}) needs a closed word (ending on start_face={start_face!r}); "
            f"this one ends on {w[-1]!r}"
        )
    if n < 0:
        w = inverse(w, start_face)
    return w * abs(n)


def is_walk(
    word: Sequence[Hashable], start_face: Hashable, adjacency: Mapping[Hashable, Iterable[Hashable]]
) -> bool:
    """True iff every tumble in ``start_face -> f1 -> ... -> fk`` goes between
    adjacent faces: ``f_{i+1} in adjacency[f_i]`` (``adjacency`` maps a face to
    its neighbours; it should be symmetric)."""
    prev = start_face
    for f in word:
        nbrs = adjacency.get(prev, ())
        if f not in nbrs:
            return False
        prev = f
    return True


def purge(
    word: Sequence[Hashable],
    start_face: Hashable,
    adjacency: Mapping[Hashable, Iterable[Hashable]] | None = None,
) -> Word:
    """Remove every trivial (palindromic) back-and-forth: the free reduction of
    the walk.

    Repeatedly cancels any immediate return ``a -> b -> a`` (face ``b`` then
    straight back to ``a``) to ``a`` -- including one through ``start_face`` --
    until none remains; done in one left-to-right pass with a stack, which
    yields the unique reduced walk (the face-adjacency graph's path groupoid
    is free, so the result does not depend on the order of cancellation).

    Guarantees: the result ends on the same face as ``word``; it contains no
    ``a -> b -> a``; it is no longer than ``word``; ``purge`` is idempotent;
    ``purge(concat(w, inverse(w, F)), F) == ()``; if ``word`` is a walk then so
    is the result (its tumbles are a subset of the original ones).  A word that
    reduces to the empty walk returns ``()``.

    ``ValueError`` if two consecutive faces are equal (not a tumble), or, when
    ``adjacency`` is given, if ``word`` is not a walk from ``start_face``.
    """
    w = tuple(word)
    if adjacency is not None and not is_walk(w, start_face, adjacency):
        raise ValueError("word is not a walk from start_face on the given adjacency")
    stack = [start_face]
    prev = start_face
    for f in w:
        if f == prev:
            raise ValueError(f"consecutive equal faces {f!r}: not a tumble")
        prev = f
        if len(stack) >= 2 and stack[-2] == f:
            stack.pop()
        else:
            stack.append(f)
    return tuple(stack[1:])


# --------------------------------------------------------------------------
# lengths of loop powers (without building them)
# --------------------------------------------------------------------------
#: Words longer than this (before purging) are not materialised by the
#: analysis: they are handled by their length and their effect (motion
#: algebra) only.
WORD_CAP = 100_000


def junction_cancel(word: Sequence[Hashable], start_face: Hashable) -> int:
    """``|p|`` for a reduced loop ``w = p c p^-1`` at ``start_face`` (the
    tumbles that cancel where two copies of ``w`` meet): ``(2|w| - |purge(w w)|) / 2``."""
    w = tuple(word)
    if not w:
        return 0
    return (2 * len(w) - len(purge(w + w, start_face))) // 2


def loop_power_length(word_len: int, junction_cancel: int, n: int) -> int:
    """Length of ``purge(w^n)`` for a reduced loop ``w = p c p^-1`` with
    ``|w| = word_len`` and ``|p| = junction_cancel``:
    ``|n| (|w| - 2|p|) + 2|p|`` (0 for ``n = 0`` or the empty loop)."""
    if n == 0 or word_len == 0:
        return 0
    return abs(n) * (word_len - 2 * junction_cancel) + 2 * junction_cancel
