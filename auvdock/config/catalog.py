"""The missions and sweeps shipped with auvdock, found by name from any folder.

They are installed with the package (``auvdock/missions/``; in a source checkout the
top-level ``missions/`` is a link to it), so ``auvdock sim gyre`` works after a plain
``pip install .`` wherever it is run.  :func:`resolve` turns what a user typed into a file:
an existing path wins; otherwise a shipped mission (or sweep) of that name.
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib import resources
from pathlib import Path

__all__ = [
    "PAPER_MISSIONS",
    "SEA_MISSIONS",
    "ShippedFile",
    "missions_dir",
    "shipped_missions",
    "shipped_sweeps",
    "mission_path",
    "resolve",
]

#: The paper's six cases (section VII), as shipped mission names, in case order.
PAPER_MISSIONS = ("still", "diagonal", "south", "east_strong", "gyre", "gyre_fast")
#: The cases in a sea that ``compare --sea`` adds beside them: the wave basin, PacWave's most common sea.
SEA_MISSIONS = ("basin_regular", "pacwave_common_10m")


@dataclass(frozen=True)
class ShippedFile:
    """One shipped mission or sweep: its name (the file stem), path and first comment line."""

    name: str
    path: Path
    kind: str  # "mission" or "sweep"
    summary: str


def missions_dir() -> Path:
    """The installed ``missions`` folder of the package."""
    return Path(str(resources.files("auvdock") / "missions"))


def _summary(path: Path) -> str:
    """The mission's ``description`` (or the sweep's first comment line), for listings."""
    import yaml

    try:
        text = path.read_text()
        data = yaml.safe_load(text)
    except (OSError, yaml.YAMLError):
        return ""
    if isinstance(data, dict) and isinstance(data.get("description"), str) and data["description"].strip():
        return " ".join(data["description"].split())
    for line in text.splitlines():
        s = line.strip()
        if s.startswith("#") and len(s) > 2:
            return s.lstrip("# ").strip()
    return ""


def shipped_missions() -> list[ShippedFile]:
    """Every shipped mission, sorted by name."""
    return [ShippedFile(p.stem, p, "mission", _summary(p)) for p in sorted(missions_dir().glob("*.yaml"))]


def shipped_sweeps() -> list[ShippedFile]:
    """Every shipped sweep, sorted by name."""
    return [
        ShippedFile(p.stem, p, "sweep", _summary(p))
        for p in sorted((missions_dir() / "sweeps").glob("*.yaml"))
    ]


def mission_path(name: str) -> Path:
    """The shipped mission file ``name`` (e.g. ``"gyre"``); KeyError naming the known ones."""
    p = missions_dir() / f"{name}.yaml"
    if not p.is_file():
        known = ", ".join(f.name for f in shipped_missions())
        raise KeyError(f"no shipped mission {name!r} (shipped: {known})")
    return p


def resolve(given: str | Path, kind: str = "mission") -> Path:
    """The file a user means: ``given`` if it exists, else the shipped ``kind`` of that name.

    ``kind`` is ``"mission"`` or ``"sweep"``.  A name that is neither an existing path nor a
    shipped file is returned unchanged, so that the caller's "file not found" names it.
    """
    p = Path(given)
    if p.exists():
        return p
    stem = p.name[:-5] if p.name.endswith(".yaml") else p.name
    if p.parent != Path(".") or not stem:
        return p
    folder = missions_dir() if kind == "mission" else missions_dir() / "sweeps"
    shipped = folder / f"{stem}.yaml"
    return shipped if shipped.is_file() else p
