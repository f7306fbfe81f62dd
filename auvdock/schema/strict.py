"""What every validated input file shares: a strict pydantic base and one-line errors.

Missions (:mod:`auvdock.config.mission`) and sweeps (:mod:`auvdock.sweep`) are pydantic models built
on :class:`Strict` (unknown keys, NaN and inf refused; defaults validated).  A validation
error becomes the one line users see with :func:`first_error`: the dotted field path as the
file spells it (``controller.alpha``, ``grid.flow.speed_m_s``) and the problem, e.g.
``unknown key (allowed: type, horizon_steps, ...)``.  Tags of discriminated unions (the
``optimized`` in pydantic's location ``controller.optimized.alpha``) are not part of the path.
"""

from __future__ import annotations

import types
import typing
from collections.abc import Sequence
from typing import TYPE_CHECKING, Annotated, Any

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, ValidationError

if TYPE_CHECKING:
    from pydantic_core import ErrorDetails

__all__ = [
    "Strict",
    "first_error",
    "field_at",
    "unwrap",
    "fixed_len",
    "PosFloat",
    "NonNegFloat",
    "Vec3",
    "Vec3Pos",
    "Vec6Pos",
    "Vec12",
    "Vec12NonNeg",
]


def fixed_len(n: int) -> AfterValidator:
    """A validator: the list has exactly ``n`` values (``must have n values, got m``)."""

    def check(v: list[Any]) -> list[Any]:
        if len(v) != n:
            raise ValueError(f"must have {n} values, got {len(v)}")
        return v

    return AfterValidator(check)


#: Field types shared by every input file.
PosFloat = Annotated[float, Field(gt=0)]
NonNegFloat = Annotated[float, Field(ge=0)]
Vec3 = Annotated[list[float], fixed_len(3)]
Vec3Pos = Annotated[list[PosFloat], fixed_len(3)]
Vec6Pos = Annotated[list[PosFloat], fixed_len(6)]
Vec12 = Annotated[list[float], fixed_len(12)]
Vec12NonNeg = Annotated[list[NonNegFloat], fixed_len(12)]


class Strict(BaseModel):
    """Base of every input model: unknown keys and non-finite numbers are errors."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, validate_default=True)


def unwrap(ann: Any) -> Any:
    """Strip ``Annotated`` and ``Optional`` from a type annotation."""
    while True:
        origin = typing.get_origin(ann)
        if origin is Annotated:
            ann = typing.get_args(ann)[0]
            continue
        if origin in (typing.Union, types.UnionType):
            args = [a for a in typing.get_args(ann) if a is not type(None)]
            if len(args) == 1:
                ann = args[0]
                continue
        return ann


def _union_members(ann: Any) -> list[Any]:
    if typing.get_origin(ann) in (typing.Union, types.UnionType):
        return [unwrap(a) for a in typing.get_args(ann) if a is not type(None)]
    return []


def _tag_member(ann: Any, tag: Any) -> Any | None:
    """The member of a discriminated union whose literal ``type`` (or other tag) is ``tag``."""
    for member in _union_members(ann):
        for f in getattr(member, "model_fields", {}).values():
            if typing.get_origin(unwrap(f.annotation)) is typing.Literal and tag in typing.get_args(
                unwrap(f.annotation)
            ):
                return member
    return None


def _walk(model: Any, loc: Sequence[Any]) -> tuple[list[Any], Any]:
    """The user-visible path of ``loc`` and the model that holds its last part."""
    shown: list[Any] = []
    current: Any = model
    in_mapping = False
    for i, part in enumerate(loc):
        if isinstance(part, str) and (part.startswith("function-") or part in ("list[float]", "nullable")):
            continue
        member = _tag_member(current, part) if _union_members(current) else None
        if member is not None:  # a discriminated union's tag: not shown
            current = member
            continue
        shown.append(part)
        if i == len(loc) - 1:
            break
        if isinstance(part, int):
            continue
        if in_mapping:  # this part is a key of a dict[str, Model] field
            in_mapping = False
            continue
        fields = getattr(current, "model_fields", None)
        if fields is None or part not in fields:
            current = None
            continue
        current = unwrap(fields[part].annotation)
        if typing.get_origin(current) is dict:
            current = unwrap(typing.get_args(current)[1])
            in_mapping = True
        elif typing.get_origin(current) is list:
            current = unwrap(typing.get_args(current)[0])
    return shown, current


def _holder(model: Any, loc: Sequence[Any]) -> Any:
    """The model in which the (unknown) last key of ``loc`` was found."""
    _, holder = _walk(model, list(loc[:-1]) + ["__key__"])
    if _union_members(holder):
        return None
    return holder


def _problem(model: Any, err: ErrorDetails) -> str:
    kind = err.get("type", "")
    msg = str(err.get("msg", "invalid"))
    if kind == "extra_forbidden":
        holder = _holder(model, tuple(err.get("loc", ())))
        allowed = list(getattr(holder, "model_fields", {})) if holder is not None else []
        return "unknown key" + (f" (allowed: {', '.join(allowed)})" if allowed else "")
    if kind == "finite_number":
        return "must be a finite number (no NaN or inf)"
    if kind == "missing":
        return "is required"
    if kind == "union_tag_invalid":
        ctx = err.get("ctx", {})
        return f"unknown value {ctx.get('tag')!r} (known: {ctx.get('expected_tags')})"
    for prefix in ("Value error, ", "Assertion failed, "):
        if msg.startswith(prefix):
            return msg[len(prefix) :]
    msg = msg[0].lower() + msg[1:] if msg else msg
    if "input" in err and not isinstance(err["input"], dict | list):
        msg += f" (got {err['input']!r})"
    return msg


def first_error(model: type[BaseModel], exc: ValidationError) -> tuple[str, str]:
    """``(field path, problem)`` of the first error of ``exc`` raised validating ``model``."""
    err = exc.errors()[0]
    loc = tuple(err.get("loc", ()))
    shown, _ = _walk(model, loc)
    if err.get("type") == "union_tag_invalid" or err.get("type") == "union_tag_not_found":
        shown = shown + [err.get("ctx", {}).get("discriminator", "type").strip("'")]
    path = ".".join(str(p) for p in shown) if shown else "(top level)"
    return path, _problem(model, err)


def field_at(model: type[BaseModel], path: str) -> tuple[Any, str | None]:
    """The annotation of the dotted field ``path`` of ``model`` and a problem (None if it exists).

    A section that is a union of models (the controller settings, by ``type``) has a field
    when any of its members has it.  A free-form mapping (``dict``) accepts any key below it
    (returned annotation: ``dict``).  The problem names what the section does have, e.g.
    ``unknown field (controller has: type, horizon_steps, ...)``.
    """
    parts = path.split(".")
    current: Any = model
    for i, part in enumerate(parts):
        where = ".".join(parts[:i]) or model.__name__.lower()
        members = _union_members(current) or [current]
        fields: dict[str, Any] = {}
        for m in members:
            fields.update(getattr(m, "model_fields", {}))
        if not fields:
            if typing.get_origin(current) is dict:
                return dict, None
            return None, f"{'.'.join(parts[:i])} is a value, not a section: vary it whole"
        if part not in fields:
            return None, f"unknown field ({where} has: {', '.join(fields)})"
        current = unwrap(fields[part].annotation)
    return current, None
