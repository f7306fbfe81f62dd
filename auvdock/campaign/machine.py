"""The machine figures come from: one description for campaign files, sweeps and ``auvdock bench``."""

from __future__ import annotations

import os
import platform
from typing import Any

__all__ = ["machine_info", "machine_line"]


def machine_info() -> dict[str, Any]:
    """Platform, CPU, core count and the versions that matter for timings (stored in results files)."""
    import casadi
    import numpy as np

    return {
        "platform": platform.platform(),
        "system": platform.system(),
        "machine": platform.machine(),
        "processor": platform.processor(),
        "cpu_count": os.cpu_count(),
        "python": platform.python_version(),
        "casadi": casadi.__version__,  # type: ignore[attr-defined]  # set at import, not in its stub
        "numpy": np.__version__,
    }


def machine_line(info: dict[str, Any] | None = None) -> str:
    """:func:`machine_info` as one line.

    E.g. ``Linux x86_64 (x86_64), 2 cores, Python 3.11.7, CasADi 3.8.2``.
    """
    m = info or machine_info()
    cpu = m.get("processor") or m.get("machine")
    return (
        f"{m.get('system', '')} {m.get('machine', '')} ({cpu}), {m.get('cpu_count')} cores, "
        f"Python {m.get('python')}, CasADi {m.get('casadi')}"
    )
