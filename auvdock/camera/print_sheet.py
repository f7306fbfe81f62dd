"""The dock's marker panel printed at true scale: one sheet, or tiled over A4 / Letter pages.

:func:`write_pages` (what ``auvdock markers`` writes) tiles a :class:`auvdock.camera.layout.MarkerLayout`'s
panel at true scale (1 m of the dock frame = 1000 mm on paper) over A4 or Letter pages (:func:`plan_pages`
chooses the orientation and where the pages join, away from the markers' black squares when it can), each
page exactly the paper size with crop marks, page labels and a 100 mm check bar; :func:`write_sheet` draws
the whole panel on one page of its own size (for a plotter or a print shop). The panel is drawn as the
approaching vehicle sees it: right = +y_d, up = -z_d, each marker with its white quiet zone and a dashed
cut line. Output is PDF, PNG or JPEG, named by the file suffix (:func:`sheet_format`); page sizes are mm
(:data:`PAPER_MM`) or inches (:func:`sheet_size_in`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from auvdock.camera.layout import Marker, MarkerLayout, marker_image

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = [
    "PAPER_MM",
    "SHEET_FORMATS",
    "SheetPage",
    "SheetPlan",
    "plan_pages",
    "sheet_format",
    "sheet_size_in",
    "write_pages",
    "write_sheet",
]

# ---------------------------------------------------------------------------------------------------------
# One sheet: the whole panel on a page of its own size
# ---------------------------------------------------------------------------------------------------------

_IN = 0.0254  # m per inch
_PAD_M = 0.008  # around the quiet zones, room for labels and cut lines
_MARGIN_IN = 0.4
_BOTTOM_IN = 0.9  # scale bar
_TOP_IN = 0.5  # title
_SCALE_BAR_M = 0.1
_CUT_M = 0.001  # dashed cut line around a marker, outside its quiet zone


def _panel_box(layout: MarkerLayout) -> tuple[float, float, float, float]:
    """(y_min, y_max, z_min, z_max) in m of all quiet zones plus padding, in the dock frame."""
    ys, zs = [], []
    for m in layout.markers:
        half = layout.quiet_zone_side_m(m) / 2.0
        y, z = m.position_dock_m[1], m.position_dock_m[2]
        ys += [y - half, y + half]
        zs += [z - half, z + half]
    return min(ys) - _PAD_M, max(ys) + _PAD_M, min(zs) - _PAD_M, max(zs) + _PAD_M


def sheet_size_in(layout: MarkerLayout) -> tuple[float, float]:
    """Page (width, height) in inches of :func:`write_sheet`'s output.

    The panel area is the markers' bounding box in (y_d, z_d) (quiet zones plus 8 mm) at true scale
    (m / 0.0254), plus margins; the page is at least wide enough for the 100 mm scale bar.
    """
    y0, y1, z0, z1 = _panel_box(layout)
    width = max((y1 - y0) / _IN, _SCALE_BAR_M / _IN + 1.0) + 2 * _MARGIN_IN
    height = (z1 - z0) / _IN + _BOTTOM_IN + _TOP_IN
    return width, height


def _marker_label(m: Marker) -> str:
    label = f"id {m.id}  {m.size_m * 1000:g} mm"
    if any(m.rpy_deg):
        label += "  rpy ({:g}, {:g}, {:g}) deg".format(*m.rpy_deg)
    return label


def _draw_markers(ax: Axes, layout: MarkerLayout, *, clip: bool = False) -> None:
    """Every marker with its quiet zone, dashed cut line (1 mm outside) and label, in dock (y, -z) axes."""
    from matplotlib.patches import Rectangle

    cells = layout.cells
    for m in layout.markers:
        half = layout.quiet_zone_side_m(m) / 2.0
        y, z = m.position_dock_m[1], m.position_dock_m[2]
        img = marker_image(layout, m.id, cells + 2)
        ax.imshow(
            img,
            cmap="gray",
            vmin=0,
            vmax=255,
            interpolation="none",
            extent=(y - half, y + half, -(z + half), -(z - half)),
            aspect="auto",
        )
        cut = half + _CUT_M
        ax.add_patch(
            Rectangle((y - cut, -(z + cut)), 2 * cut, 2 * cut, fill=False, lw=0.4, ec="0.6", ls=(0, (4, 3)))
        )
        text = ax.text(y, -(z + cut) - 0.001, _marker_label(m), ha="center", va="top", fontsize=6)
        if clip:
            text.set_clip_on(True)


def write_sheet(layout: MarkerLayout, path: str | Path, pdf: bool = True, *, dpi: int = 300) -> Path:
    """Write a printable sheet of the layout at TRUE scale (print at 100 %, no fit-to-page).

    The sheet shows the panel as the approaching vehicle sees it (right = +y_d, up = -z_d). Each marker is
    drawn with its quiet zone at its metric extent, centred at its (y_d, z_d) position, upright, with a dashed
    cut line 1 mm outside the quiet zone and a label (id, black-square size, rpy if non-zero). Out-of-plane
    tilts and roll in ``rpy_deg`` are NOT drawn: mount the cut-out marker with that attitude. A 100 mm scale
    bar labelled "100 mm: check print scale" sits in the bottom margin.

    Parameters
    ----------
    layout : MarkerLayout
    path : str or Path
        Output file; its suffix names the format (see :func:`sheet_format`: ``.pdf``, ``.png``, ``.jpg`` /
        ``.jpeg``; ValueError for any other). Without a suffix, ``.pdf`` (``pdf=True``) or ``.png`` is
        appended.
    pdf : bool
        Format when ``path`` has no suffix.
    dpi : int
        Raster resolution of a PNG or JPEG, dots per inch (the PDF page size does not depend on it).

    Returns
    -------
    Path
        The file written. Output is deterministic (no creation date in the PDF).
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    path, fmt = sheet_format(path, pdf)
    y0, y1, z0, z1 = _panel_box(layout)
    width_in, height_in = sheet_size_in(layout)
    panel_w_in, panel_h_in = (y1 - y0) / _IN, (z1 - z0) / _IN

    fig = Figure(figsize=(width_in, height_in))
    FigureCanvasAgg(fig)
    ax = fig.add_axes(
        (_MARGIN_IN / width_in, _BOTTOM_IN / height_in, panel_w_in / width_in, panel_h_in / height_in)
    )
    ax.set_axis_off()
    _draw_markers(ax, layout)
    ax.set_xlim(y0, y1)
    ax.set_ylim(-z1, -z0)

    inch = fig.dpi_scale_trans
    bar_y = 0.45
    bar_x1 = _MARGIN_IN + _SCALE_BAR_M / _IN
    ax.plot([_MARGIN_IN, bar_x1], [bar_y, bar_y], color="k", lw=1.5, transform=inch, clip_on=False)
    for xb in (_MARGIN_IN, bar_x1):
        ax.plot([xb, xb], [bar_y - 0.06, bar_y + 0.06], color="k", lw=1.0, transform=inch, clip_on=False)
    fig.text(_MARGIN_IN, bar_y + 0.1, "100 mm: check print scale", transform=inch, fontsize=8, va="bottom")
    fig.text(
        _MARGIN_IN,
        height_in - 0.25,
        f"auvdock dock markers ({layout.dictionary}), panel seen from the vehicle; print at 100 %",
        transform=inch,
        fontsize=8,
        va="center",
    )
    _save_raster_or_pdf(fig, path, fmt, dpi)
    return path


def _save_raster_or_pdf(fig: Figure, path: Path, fmt: str, dpi: int) -> None:
    if fmt == "pdf":
        fig.savefig(path, format="pdf", metadata={"CreationDate": None})
    elif fmt == "jpeg":
        fig.savefig(path, format="jpeg", dpi=dpi, pil_kwargs={"quality": _JPEG_QUALITY})
    else:
        fig.savefig(path, format="png", dpi=dpi)


# ---------------------------------------------------------------------------------------------------------
# Pages: the panel tiled at true scale over A4 / Letter
# ---------------------------------------------------------------------------------------------------------

#: Paper sizes, (width, height) in mm, portrait.
PAPER_MM: dict[str, tuple[float, float]] = {"a4": (210.0, 297.0), "letter": (215.9, 279.4)}

#: Output formats by file suffix (lower case): what :func:`write_pages` and :func:`write_sheet` write.
SHEET_FORMATS: dict[str, str] = {".pdf": "pdf", ".png": "png", ".jpg": "jpeg", ".jpeg": "jpeg"}

_PAPER_NAMES = {"a4": "A4", "letter": "Letter"}
_JPEG_QUALITY = 95
_MM = 0.001  # m per mm
_PAGE_MARGIN_MM = 10.0  # every side; the crop marks and join labels sit in it
_HEADER_MM = 14.0  # below the top margin: title, page label, instructions
_FOOTER_MM = 20.0  # above the bottom margin: the 100 mm check bar
_CROP_MM = (1.0, 5.0)  # crop marks: from, to (mm outside a page's panel corner)
_JOIN_TICK_EVERY_M = 0.02  # alignment ticks along the joins, at multiples of this in the dock frame
_JOIN_TICK_MM = 3.0
_LABEL_M = 0.004  # height a marker's label takes below its cut line
_LABEL_CHAR_M = 0.0013  # width of a label character (6 pt), for keeping joins off labels
_STEP_M = 0.0005  # join positions are searched on this grid
# Costs of a page layout (see _joins): a join through a black square is worse than 10 more pages.
_PAGE_COST, _BLACK_COST, _WHITE_COST, _LABEL_COST = 100.0, 1000.0, 10.0, 2.0


def sheet_format(path: str | Path, pdf: bool = True) -> tuple[Path, str]:
    """The file a sheet goes to and its format, ``"pdf"``, ``"png"`` or ``"jpeg"``, named by the suffix.

    Suffixes (any case): ``.pdf``, ``.png``, ``.jpg``, ``.jpeg`` (:data:`SHEET_FORMATS`). Without a suffix,
    ``.pdf`` (``pdf=True``) or ``.png`` is appended. Any other suffix raises ValueError, e.g.
    ``"unsupported format '.gif' (use .pdf, .png, .jpg or .jpeg)"``.
    """
    path = Path(path)
    if not path.suffix:
        path = path.with_suffix(".pdf" if pdf else ".png")
    fmt = SHEET_FORMATS.get(path.suffix.lower())
    if fmt is None:
        raise ValueError(f"unsupported format {path.suffix!r} (use .pdf, .png, .jpg or .jpeg)")
    return path, fmt


@dataclass(frozen=True)
class SheetPage:
    """One page of a :class:`SheetPlan`: the part of the panel it shows, in the dock frame.

    ``number`` counts from 1, row by row from the top left; ``row`` and ``column`` from 0. ``y_m`` is the
    page's range of y_d (left to right as printed), ``z_m`` its range of z_d (top to bottom).
    """

    number: int
    row: int
    column: int
    y_m: tuple[float, float]
    z_m: tuple[float, float]


@dataclass(frozen=True)
class SheetPlan:
    """How :func:`write_pages` tiles a layout's panel over pages of one paper size (see :func:`plan_pages`).

    ``y_cuts`` (left to right) and ``z_cuts`` (top to bottom) are the panel's edges and the joins between
    page columns and rows, m in the dock frame; ``split_ids`` are the markers whose black square a join
    crosses (empty unless a marker is larger than a page's printable area, or the layout leaves no room).
    """

    paper: str
    landscape: bool
    y_cuts: tuple[float, ...]
    z_cuts: tuple[float, ...]
    split_ids: tuple[int, ...] = ()

    @property
    def paper_name(self) -> str:
        """``"A4"`` or ``"Letter"``."""
        return _PAPER_NAMES[self.paper]

    @property
    def page_mm(self) -> tuple[float, float]:
        """Page (width, height) in mm as printed (landscape pages are wider than high)."""
        w, h = PAPER_MM[self.paper]
        return (h, w) if self.landscape else (w, h)

    @property
    def columns(self) -> int:
        return len(self.y_cuts) - 1

    @property
    def rows(self) -> int:
        return len(self.z_cuts) - 1

    @property
    def pages(self) -> tuple[SheetPage, ...]:
        """All pages, row by row from the top left."""
        return tuple(
            SheetPage(
                r * self.columns + c + 1,
                r,
                c,
                (self.y_cuts[c], self.y_cuts[c + 1]),
                (self.z_cuts[r], self.z_cuts[r + 1]),
            )
            for r in range(self.rows)
            for c in range(self.columns)
        )

    def page_at(self, row: int, column: int) -> SheetPage | None:
        """The page at (row, column), or None outside the grid."""
        if 0 <= row < self.rows and 0 <= column < self.columns:
            return self.pages[row * self.columns + column]
        return None

    def describe(self) -> str:
        """E.g. ``"2 A4 pages (portrait, 1 column x 2 rows)"``."""
        n = self.rows * self.columns
        orientation = "landscape" if self.landscape else "portrait"
        if n == 1:
            return f"1 {self.paper_name} page ({orientation})"
        cols = f"{self.columns} column{'s' if self.columns > 1 else ''}"
        rows = f"{self.rows} row{'s' if self.rows > 1 else ''}"
        return f"{n} {self.paper_name} pages ({orientation}, {cols} x {rows})"


@dataclass(frozen=True)
class _Extent:
    """What a marker occupies on the panel, as (lo, hi) intervals in m along y_d and z_d."""

    id: int
    black_y: tuple[float, float]
    black_z: tuple[float, float]
    cut_y: tuple[float, float]  # quiet zone plus the cut line
    cut_z: tuple[float, float]
    label_y: tuple[float, float]
    label_z: tuple[float, float]


def _extents(layout: MarkerLayout) -> list[_Extent]:
    out = []
    for m in layout.markers:
        y, z = m.position_dock_m[1], m.position_dock_m[2]
        black = m.size_m / 2.0
        cut = layout.quiet_zone_side_m(m) / 2.0 + _CUT_M
        label = len(_marker_label(m)) * _LABEL_CHAR_M / 2.0
        out.append(
            _Extent(
                m.id,
                (y - black, y + black),
                (z - black, z + black),
                (y - cut, y + cut),
                (z - cut, z + cut),
                (y - label, y + label),
                (z + cut, z + cut + _LABEL_M),
            )
        )
    return out


def _joins(
    lo: float,
    hi: float,
    length: float,
    black: list[tuple[float, float]],
    white: list[tuple[float, float]],
    label: list[tuple[float, float]],
) -> tuple[tuple[float, ...], float]:
    """Split [lo, hi] into pieces no longer than ``length``: (edges, cost of the joins).

    Minimises (dynamic programming on a 0.5 mm grid) the pieces' count plus the cost of each join: through
    a black square (worse than 10 more pieces), a quiet zone or a label, or close (< 5 mm) to one.
    """
    if hi - lo <= length:
        return (lo, hi), 0.0
    n = math.ceil((hi - lo) / _STEP_M)
    xs = lo + (hi - lo) * np.arange(n + 1) / n
    cost = np.zeros(n + 1)
    for weight, intervals in ((_BLACK_COST, black), (_WHITE_COST, white), (_LABEL_COST, label)):
        for a, b in intervals:
            cost += weight * ((xs > a) & (xs < b))
    edges = np.array([e for a, b in (*white, *label) for e in (a, b)])
    if edges.size:
        gap = np.abs(xs[:, None] - edges[None, :]).min(axis=1)
        cost += np.clip(1.0 - gap / 0.005, 0.0, 1.0)
    cost[-1] = 0.0
    window = math.floor(length / ((hi - lo) / n) + 1e-9)
    if window < 1:
        raise ValueError(f"page too small: {length * 1000:g} mm of panel per page")
    best = np.full(n + 1, np.inf)
    best[0] = 0.0
    prev = np.zeros(n + 1, dtype=int)
    for j in range(1, n + 1):
        i0 = max(0, j - window)
        k = i0 + int(np.argmin(best[i0:j]))
        best[j] = best[k] + _PAGE_COST + cost[j]
        prev[j] = k
    idx = [n]
    while idx[-1] > 0:
        idx.append(int(prev[idx[-1]]))
    cuts = [float(xs[i]) for i in reversed(idx)]
    cuts[0], cuts[-1] = lo, hi
    return tuple(cuts), float(best[n] - _PAGE_COST * (len(cuts) - 1))


def plan_pages(layout: MarkerLayout, paper: str = "a4") -> SheetPlan:
    """Tile the panel (true scale) over ``paper`` pages: orientation, and where the pages join.

    The panel is the markers' cut squares (quiet zone plus 1 mm) and labels, seen from the vehicle. Each
    page prints a piece of it inside 10 mm margins, below a 14 mm header and above a 20 mm footer (A4
    portrait: 190 x 243 mm of panel per page; Letter: 195.9 x 225.4 mm). The joins between pages are
    full-width lines, placed to cross no black square (if at all possible), then as few pages as possible,
    then no quiet zone or label; portrait is preferred over landscape at equal cost.

    Parameters
    ----------
    layout : MarkerLayout
    paper : str
        ``"a4"`` or ``"letter"`` (any case); ValueError otherwise.
    """
    key = paper.lower() if isinstance(paper, str) else paper
    if key not in PAPER_MM:
        raise ValueError(f"paper: {paper!r} is not supported; choose from {', '.join(PAPER_MM)}")
    ext = _extents(layout)
    y_lo = min(min(e.cut_y[0], e.label_y[0]) for e in ext)
    y_hi = max(max(e.cut_y[1], e.label_y[1]) for e in ext)
    z_lo = min(e.cut_z[0] for e in ext)
    z_hi = max(e.label_z[1] for e in ext)
    best: tuple[tuple[Any, ...], SheetPlan] | None = None
    for landscape in (False, True):
        w, h = PAPER_MM[key]
        if landscape:
            w, h = h, w
        tile_w = (w - 2 * _PAGE_MARGIN_MM) * _MM
        tile_h = (h - 2 * _PAGE_MARGIN_MM - _HEADER_MM - _FOOTER_MM) * _MM
        y_cuts, y_cost = _joins(
            y_lo, y_hi, tile_w, [e.black_y for e in ext], [e.cut_y for e in ext], [e.label_y for e in ext]
        )
        z_cuts, z_cost = _joins(
            z_lo, z_hi, tile_h, [e.black_z for e in ext], [e.cut_z for e in ext], [e.label_z for e in ext]
        )
        split = tuple(
            e.id
            for e in ext
            if any(e.black_y[0] < c < e.black_y[1] for c in y_cuts[1:-1])
            or any(e.black_z[0] < c < e.black_z[1] for c in z_cuts[1:-1])
        )
        plan = SheetPlan(key, landscape, y_cuts, z_cuts, split)
        score = (len(split), plan.rows * plan.columns, y_cost + z_cost, landscape)
        if best is None or score < best[0]:
            best = (score, plan)
    assert best is not None
    return best[1]


def _free_segments(lo: float, hi: float, blocked: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """[lo, hi] minus the blocked intervals."""
    out, start = [], lo
    for a, b in sorted(blocked):
        if b <= start:
            continue
        if a >= hi:
            break
        if a > start:
            out.append((start, a))
        start = max(start, b)
    if start < hi:
        out.append((start, hi))
    return out


def _page_figure(layout: MarkerLayout, plan: SheetPlan, page: SheetPage) -> Figure:
    """The figure of one page, exactly the paper size, panel piece at true scale (1 m = 1000 mm)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.transforms import Affine2D

    W, H = plan.page_mm
    fig = Figure(figsize=(W / 25.4, H / 25.4))
    FigureCanvasAgg(fig)
    mm = Affine2D().scale(1.0 / 25.4) + fig.dpi_scale_trans  # page coordinates in mm from the bottom left
    (y0, y1), (z0, z1) = page.y_m, page.z_m
    left, top = _PAGE_MARGIN_MM, H - _PAGE_MARGIN_MM - _HEADER_MM
    right, bottom = left + (y1 - y0) / _MM, top - (z1 - z0) / _MM

    ax = fig.add_axes((left / W, bottom / H, (right - left) / W, (top - bottom) / H))
    ax.set_axis_off()
    _draw_markers(ax, layout, clip=True)
    ax.set_xlim(y0, y1)
    ax.set_ylim(-z1, -z0)

    def line(xs: tuple[float, float], ys: tuple[float, float], lw: float, color: str = "k") -> None:
        fig.add_artist(Line2D(xs, ys, transform=mm, lw=lw, color=color, solid_capstyle="butt"))

    def text(x: float, y: float, s: str, size: float, **kw: Any) -> None:
        fig.text(x, y, s, transform=mm, fontsize=size, **kw)

    # crop marks at the four corners of the panel piece
    a, b = _CROP_MM
    for x, sx in ((left, -1.0), (right, 1.0)):
        for y, sy in ((bottom, -1.0), (top, 1.0)):
            line((x + sx * a, x + sx * b), (y, y), 0.3)
            line((x, x), (y + sy * a, y + sy * b), 0.3)

    # joins: a faint cut guide and alignment ticks on the edge (off the markers' cut squares), and the
    # neighbour's page number in the margin
    ext = _extents(layout)

    def px(y: float) -> float:
        return left + (y - y0) / _MM

    def pz(z: float) -> float:
        return top - (z - z0) / _MM

    joins = []
    for dr, dc, where in ((-1, 0, "above"), (0, -1, "to the left"), (0, 1, "to the right"), (1, 0, "below")):
        other = plan.page_at(page.row + dr, page.column + dc)
        if other is None:
            continue
        joins.append(f"page {other.number} {where}")
        vertical = dc != 0
        at = (y1 if dc > 0 else y0) if vertical else (z1 if dr > 0 else z0)
        lo, hi = (z0, z1) if vertical else (y0, y1)
        blocked = [
            (e.cut_z if vertical else e.cut_y)
            for e in ext
            if (e.cut_y if vertical else e.cut_z)[0] < at < (e.cut_y if vertical else e.cut_z)[1]
        ]
        inward = -1.0 if (dc > 0 or dr > 0) else 1.0  # mm direction into this page's piece, across the edge
        for s0, s1 in _free_segments(lo, hi, blocked):
            if vertical:
                line((px(at), px(at)), (pz(s0), pz(s1)), 0.25, "0.7")
            else:
                line((px(s0), px(s1)), (pz(at), pz(at)), 0.25, "0.7")
            k0 = math.ceil((s0 + 0.002) / _JOIN_TICK_EVERY_M)
            k1 = math.floor((s1 - 0.002) / _JOIN_TICK_EVERY_M)
            for k in range(k0, k1 + 1):
                u = k * _JOIN_TICK_EVERY_M
                if vertical:
                    x = px(at)
                    line((x, x + inward * _JOIN_TICK_MM), (pz(u), pz(u)), 0.3)
                else:
                    y = pz(at)
                    line((px(u), px(u)), (y, y - inward * _JOIN_TICK_MM), 0.3)
        label = f"page {other.number} joins here"
        if vertical:
            x = px(at) - inward * 4.0
            text(x, (top + bottom) / 2, label, 6, rotation=90 if dc < 0 else 270, ha="center", va="center")
        else:
            y = pz(at) + inward * 3.5
            text((left + right) / 2, y, label, 6, ha="center", va="center")

    # header: what and where this page is, and how to print and join
    n_pages = plan.rows * plan.columns
    title = f"auvdock dock markers ({layout.dictionary}): page {page.number} of {n_pages}"
    if n_pages > 1:
        title += f" (row {page.row + 1} of {plan.rows}, column {page.column + 1} of {plan.columns})"
    title += f"; {plan.paper_name}, print at 100 % (actual size, no fit to page)"
    text(left, H - _PAGE_MARGIN_MM - 2.5, title, 8, va="center")
    if joins:
        how = "Cut along the crop marks and butt the edges together, ticks aligned: " + ", ".join(joins) + "."
    else:
        how = "Panel as seen from the approaching vehicle; cut each marker out along its dashed line."
    text(left, H - _PAGE_MARGIN_MM - 6.5, how, 6.5, va="center")

    # footer: the 100 mm check bar (butt caps: the ink is exactly 100 mm long), ticks every 10 mm
    by = _PAGE_MARGIN_MM + 5.0
    bar_mm = _SCALE_BAR_M / _MM
    line((left, left + bar_mm), (by, by), 1.0)
    for k in range(11):
        x = left + k * bar_mm / 10
        if k in (0, 10):
            line((x, x), (by - 1.5, by + 2.0), 0.4)
        else:
            line((x, x), (by, by + (1.2 if k == 5 else 0.8)), 0.3)
    check = "100 mm: check print scale (if this bar is not 100 mm, print at 100 % again)"
    text(left, by + 3.0, check, 7, va="bottom")
    w_mm, h_mm = PAPER_MM[plan.paper]
    where = f"{plan.paper_name} {w_mm:g} x {h_mm:g} mm, page {page.number} of {n_pages}"
    text(left + bar_mm + 4.0, by, where, 7, va="center")
    return fig


def write_pages(
    layout: MarkerLayout,
    path: str | Path,
    paper: str = "a4",
    *,
    pdf: bool = True,
    dpi: int = 300,
    plan: SheetPlan | None = None,
) -> list[Path]:
    """Write the layout's panel at TRUE scale on A4 or Letter pages (:func:`plan_pages`), to print at 100 %.

    Every page is exactly the paper size and shows its piece of the panel (markers drawn as in
    :func:`write_sheet`), crop marks at the piece's corners, a header naming the page (number, row and
    column) and its neighbours, and a 100 mm check bar. Where pages join: a faint cut guide, alignment
    ticks every 20 mm of the dock frame (the same on both pages) and "page N joins here" in the margin.

    Parameters
    ----------
    layout : MarkerLayout
    path : str or Path
        Output file; the suffix names the format (:func:`sheet_format`). A PDF holds every page; PNG and
        JPEG write one image per page: ``path`` itself for a single page, else ``<stem>-page<N><suffix>``.
    paper : str
        ``"a4"`` or ``"letter"``.
    pdf : bool
        Format when ``path`` has no suffix.
    dpi : int
        Raster resolution of PNG / JPEG pages, dots per inch (each image is the page at this resolution).
    plan : SheetPlan, optional
        A plan from :func:`plan_pages` for this layout (default: made here for ``paper``).

    Returns
    -------
    list of Path
        The files written. Output is deterministic (no creation date in the PDF).
    """
    path, fmt = sheet_format(path, pdf)
    plan = plan_pages(layout, paper) if plan is None else plan
    pages = plan.pages
    if fmt == "pdf":
        from matplotlib.backends.backend_pdf import PdfPages

        with PdfPages(path, metadata={"CreationDate": None}) as out:
            for page in pages:
                out.savefig(_page_figure(layout, plan, page))
        return [path]
    if len(pages) == 1:
        paths = [path]
    else:
        paths = [path.with_name(f"{path.stem}-page{p.number}{path.suffix}") for p in pages]
    for page, target in zip(pages, paths, strict=True):
        _save_raster_or_pdf(_page_figure(layout, plan, page), target, fmt, dpi)
    return paths
