"""Reading a sweep file: its schema, its base mission, its fields and every expanded mission."""

from __future__ import annotations

from pathlib import Path

from pydantic import ValidationError

from auvdock.config.catalog import resolve
from auvdock.config.mission import MissionError, load_mission, read_yaml_file
from auvdock.schema.strict import first_error
from auvdock.sweep.expand import expand_sweep
from auvdock.sweep.schema import Sweep, SweepError, check_fields

__all__ = ["load_sweep"]


def load_sweep(path: str | Path) -> Sweep:
    """Read and validate a sweep file, its base mission and every expanded mission.

    ``path`` is a file or the name of a shipped sweep (``current_speed``).  The base
    mission is a file relative to the sweep file, or a shipped mission's name.

    Raises
    ------
    SweepError
        ``<file>: <field.path>: <problem>`` on a missing file, a YAML error, an unknown key,
        an unknown mission field, a bad distribution, a missing or invalid base mission,
        or the first expanded mission that does not validate.
    """
    p = resolve(path, "sweep")
    data, text = read_yaml_file(p, SweepError)
    if not isinstance(data, dict):
        raise SweepError(p, "", "a sweep file must hold a YAML mapping (key: value pairs)")
    try:
        sweep = Sweep.model_validate(data)
    except ValidationError as e:
        raise SweepError(p, *first_error(Sweep, e)) from None
    sweep._path = p
    sweep._text = text
    if sweep.name is None:
        sweep.name = p.stem
    base = Path(sweep.base)
    if not base.is_absolute():
        base = p.parent / base
    if not base.is_file():
        shipped = resolve(sweep.base)
        if not shipped.is_file():
            raise SweepError(p, "base", f"mission file not found: {base}")
        base = shipped
    try:
        sweep._base = load_mission(base)
    except MissionError as e:
        raise SweepError(p, "base", str(e)) from None
    if sweep.fixed:  # set for every run: the base mission as the sweep flies it
        try:
            sweep._base = sweep._base.with_updates(sweep.fixed, where=p)
        except MissionError as e:
            raise SweepError(p, f"fixed.{e.field}" if e.field else "fixed", e.problem) from None
    check_fields(sweep)
    expand_sweep(sweep)  # every expanded mission validates, or the first bad one is reported
    return sweep
