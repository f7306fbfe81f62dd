"""Success rates of a group of runs, with Wilson score intervals (the one definition sweeps and their
findings use)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

__all__ = ["Z95", "wilson_interval", "success_rate", "failed"]

#: Two-sided 95 % standard-normal quantile.
Z95 = 1.959964


def wilson_interval(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion ``successes / n``.

    ``(p + z^2/2n -+ z sqrt(p(1-p)/n + z^2/4n^2)) / (1 + z^2/n)`` with ``p = successes / n``;
    exactly 0 (1) at the lower (upper) end when ``successes`` is 0 (n).  ``n = 0`` gives
    (0, 1): nothing is known.

    Raises
    ------
    ValueError
        If not ``0 <= successes <= n``.
    """
    if n < 0 or successes < 0 or successes > n:
        raise ValueError(f"need 0 <= successes <= n, got {successes} of {n}")
    if n == 0:
        return 0.0, 1.0
    p = successes / n
    z2 = z * z
    denom = 1.0 + z2 / n
    centre = (p + z2 / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z2 / (4 * n * n)) / denom
    lo = 0.0 if successes == 0 else max(0.0, centre - half)
    hi = 1.0 if successes == n else min(1.0, centre + half)
    return lo, hi


def success_rate(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """``{"n", "docked", "rate", "lo", "hi", "errors"}`` of some runs (rate NaN for none; errors:
    the runs that failed)."""
    n = len(rows)
    k = sum(1 for r in rows if r["docked"])
    lo, hi = wilson_interval(k, n)
    return {
        "n": n,
        "docked": k,
        "rate": k / n if n else math.nan,
        "lo": lo,
        "hi": hi,
        "errors": sum(1 for r in rows if failed(r)),
    }


def failed(r: dict[str, Any]) -> bool:
    return r.get("status", "done") != "done" or bool(r.get("error"))
