"""A mission whose TRUTH vehicle differs from the controller's model (plant-only model error)."""

from __future__ import annotations

from typing import Any

import numpy as np


def plant(m: Any, **scale: float) -> Any:
    """The mission ``m`` with its vehicle's parameters scaled (``buoyancy_N=1.03``, ...): give it to
    ``simulate`` as the truth while the autopilot is built from ``m``."""
    p = m.build_vehicle().model.params
    ov = {}
    for name, factor in scale.items():
        base = getattr(p, name)
        ov[f"vehicle.overrides.{name}"] = (
            (np.asarray(base) * factor).tolist() if np.ndim(base) else base * factor
        )
    return m.with_updates(**ov)
