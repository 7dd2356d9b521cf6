"""The two ways a part description can be answered before any work starts."""


class PartWarning(UserWarning):
    """A part was accepted after a change the caller should know about (e.g. a
    non-convex part replaced by its convex hull)."""


class PartError(ValueError):
    """A part description that cannot be used; the message names the field and the fix."""


#: Sizes (largest extent, m) of the parts nudge expects: a 0.1 mm chip to a 5 m panel.
PLAUSIBLE_SIZE_M = (1e-4, 5.0)


def warn_implausible_size(size_m: float, field: str = "vertices") -> None:
    """Warn (:class:`PartWarning`) when a part ``size_m`` metres across (its
    largest extent) is implausible for coordinates in metres, saying what was
    assumed: a part written in millimetres would otherwise plan metres of
    pushing without a word.  Planning goes on; tolerances inside nudge are
    relative to the part's size, so a plan stays exact at any scale."""
    import warnings

    lo, hi = PLAUSIBLE_SIZE_M
    if lo <= size_m <= hi:
        return
    hint = ("if they are millimetres, divide them by 1000" if size_m > hi
            else "if they are in another unit, convert them to metres")
    warnings.warn(f"{field}: the part is {size_m:.3g} m across, implausible for a part in metres "
                  f"(expected {lo:g} m to {hi:g} m); the coordinates are read as metres - "
                  f"{hint}", PartWarning, stacklevel=3)
