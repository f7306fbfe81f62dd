"""Terminal tables whose numbers are never split, at any terminal width (80 columns included).

Rich shrinks a table that is wider than the terminal by wrapping its cells, which cuts numbers
and intervals in the middle ("20.0 / 0 s", "51.0-..."). :func:`fitted_table` instead keeps every
cell on one line and shows the columns that fit, in the order of importance the caller gives,
with the headers broken at their spaces; the columns left out are named in the caption (the
files the command writes have them all).
"""

from __future__ import annotations

from collections.abc import Sequence

from rich.table import Table
from rich.text import Text

__all__ = ["fitted_table"]

#: What one column costs besides its text: a border and one space of padding each side.
_COLUMN_OVERHEAD = 3


def _needed(header: str, cells: Sequence[str]) -> int:
    widest_word = max((len(w) for w in header.split()), default=0)
    return max([widest_word, *(len(c) for c in cells)])


def fitted_table(
    title: str,
    header: Sequence[str],
    rows: Sequence[Sequence[str]],
    width: int,
    *,
    priority: Sequence[int] | None = None,
    left: Sequence[str] = ("case", "controller", "solver", "mission"),
    where: str = "",
    row_styles: Sequence[str | None] | None = None,
) -> Table:
    """A table of ``rows`` (strings) that fits ``width`` terminal columns with no cell wrapped.

    Parameters
    ----------
    title : str
        The table's title.
    header : sequence of str
        Column headers; they break at their spaces (``"closest approach m"`` on three lines).
    rows : sequence of sequences of str
        The cells, one row per run.
    width : int
        The terminal's width in columns.
    priority : sequence of int, optional
        Column indices, most important first (default: left to right); the columns are shown
        in their original order.
    left : sequence of str
        Headers of left-aligned (text) columns; the others are right-aligned numbers.
    where : str
        Where the columns left out can be read (e.g. ``"summary.md"``), for the caption.
    row_styles : sequence of str or None, optional
        A rich style per row (``"green"``, ``"red"``, None).
    """
    order = list(priority) if priority is not None else list(range(len(header)))
    order += [i for i in range(len(header)) if i not in order]
    need = [_needed(h, [r[i] for r in rows]) + _COLUMN_OVERHEAD for i, h in enumerate(header)]
    shown: set[int] = set()
    used = 1  # the table's right border
    for i in order:
        if used + need[i] <= width or not shown:
            shown.add(i)
            used += need[i]
    cols = sorted(shown)
    dropped = [header[i] for i in range(len(header)) if i not in shown]
    caption = None
    if dropped:
        caption = f"not shown at {width} columns: {', '.join(dropped)}" + (f" (in {where})" if where else "")
    t = Table(title=Text(title, style="table.title"), caption=caption)  # Text: user text is no markup
    for i in cols:
        t.add_column(
            header[i].replace(" ", "\n"),
            justify="left" if header[i] in left else "right",
            no_wrap=True,
            min_width=need[i] - _COLUMN_OVERHEAD,
        )
    for k, r in enumerate(rows):
        t.add_row(*(Text(r[i]) for i in cols), style=row_styles[k] if row_styles is not None else None)
    return t
