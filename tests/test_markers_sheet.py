"""``auvdock markers`` (issue 19): A4 / Letter pages at true scale with a 100 mm bar on each, tiled when the
panel is larger than a page; the --out suffix names the format; bad --out / --paper exit 2 with one line."""

from __future__ import annotations

import re
import zlib
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from auvdock.camera.layout import Marker, MarkerLayout, aruco_dictionary, default_layout
from auvdock.camera.print_sheet import PAPER_MM, plan_pages, write_pages
from auvdock.cli import app

ROOT = Path(__file__).resolve().parents[1]
MISSION = ROOT / "missions" / "tank_0p6hz.yaml"
PT_PER_MM = 72 / 25.4
A4_PT = (595.28, 841.89)
LETTER_PT = (612.0, 792.0)
BAR_PT = 100 * PT_PER_MM  # 283.46 pt
runner = CliRunner()


def _media_boxes(data: bytes) -> list[tuple[float, float]]:
    """(width, height) in pt of every page of a PDF."""
    boxes = re.findall(rb"/MediaBox\s*\[\s*([^\]]*)\]", data)
    assert len(boxes) == len(re.findall(rb"/Type\s*/Page\b", data))
    return [
        (float(b.split()[2]) - float(b.split()[0]), float(b.split()[3]) - float(b.split()[1])) for b in boxes
    ]


def _bars(data: bytes) -> list[list[tuple[float, float, float]]]:
    """Per page content stream: its horizontal straight segments ``x0 y m x1 y l`` of 100 mm +- 0.01 pt,
    as (x0, x1, y) in pt."""
    found = []
    for raw in re.findall(rb"stream\r?\n(.*?)\r?\nendstream", data, re.S):
        try:
            text = zlib.decompress(raw).decode("latin-1")
        except zlib.error:
            continue  # images, fonts
        segs = re.findall(r"(-?[\d.]+) (-?[\d.]+) m\n(-?[\d.]+) (-?[\d.]+) l\n", text)
        bars = [
            (float(x0), float(x1), float(y0))
            for x0, y0, x1, y1 in segs
            if float(y0) == float(y1) and abs(abs(float(x1) - float(x0)) - BAR_PT) < 0.01
        ]
        found.append(bars)
    return [b for b in found if b]


def _markers(out: Path, *args: str, layout: Path = MISSION):
    return runner.invoke(app, ["markers", str(layout), "-o", str(out), *args])


def _big_layout(tmp_path: Path) -> tuple[Path, MarkerLayout]:
    """Twelve 100 mm markers over 0.6 x 0.5 m: several pages across and down."""
    lay = MarkerLayout(
        "aruco_4x4_50",
        tuple(Marker(i, 0.1, (0.35, -0.25 + 0.16 * (i % 4), -0.25 + 0.17 * (i // 4))) for i in range(12)),
    )
    path = tmp_path / "big.yaml"
    path.write_text(yaml.safe_dump(lay.to_dict()))
    return path, lay


@pytest.mark.parametrize(("paper", "size_pt"), [(None, A4_PT), ("a4", A4_PT), ("letter", LETTER_PT)])
def test_pages_are_the_paper_size_with_a_true_100_mm_bar_on_each(
    tmp_path: Path, paper: str | None, size_pt: tuple[float, float]
) -> None:
    out = tmp_path / "m.pdf"
    res = _markers(out, *(["--paper", paper] if paper else []))
    assert res.exit_code == 0, res.output + res.stderr
    data = out.read_bytes()
    assert data.startswith(b"%PDF")
    boxes = _media_boxes(data)
    assert len(boxes) == 2  # the default panel (0.19 x 0.33 m) is taller than one page
    for w, h in boxes:
        assert (w, h) == (pytest.approx(size_pt[0], abs=0.01), pytest.approx(size_pt[1], abs=0.01))
    bars = _bars(data)
    assert len(bars) == len(boxes)
    for page_bars in bars:
        ((x0, x1, _),) = page_bars
        assert x1 - x0 == pytest.approx(283.46, abs=0.01)
        assert x0 == pytest.approx(10 * PT_PER_MM, abs=0.01)  # from the left margin
    name = {"letter": "Letter"}.get(paper or "a4", "A4")
    assert f"sheet: {out}: 2 {name} pages (portrait, 1 column x 2 rows); print at 100 %" in res.output
    # deterministic
    assert _markers(tmp_path / "again.pdf", *(["--paper", paper] if paper else [])).exit_code == 0
    assert (tmp_path / "again.pdf").read_bytes() == data


def test_a_large_panel_is_tiled_across_and_down_without_cutting_a_marker(tmp_path: Path) -> None:
    path, lay = _big_layout(tmp_path)
    out = tmp_path / "big.pdf"
    res = _markers(out, layout=path)
    assert res.exit_code == 0, res.output + res.stderr
    plan = plan_pages(lay, "a4")
    assert plan.columns >= 2 and plan.rows >= 2 and plan.split_ids == ()
    assert f"sheet: {out}: {plan.describe()}" in res.output
    data = out.read_bytes()
    boxes = _media_boxes(data)
    assert len(boxes) == plan.columns * plan.rows
    assert all(sorted((w, h)) == [pytest.approx(v, abs=0.01) for v in A4_PT] for w, h in boxes)
    assert len(_bars(data)) == len(boxes)
    # the pages cover the panel edge to edge, each piece within a page's printable area
    w_mm, h_mm = plan.page_mm
    for page in plan.pages:
        assert (page.y_m[1] - page.y_m[0]) * 1000 <= w_mm - 20 + 1e-6
        assert (page.z_m[1] - page.z_m[0]) * 1000 <= h_mm - 54 + 1e-6
    assert [p.number for p in plan.pages] == list(range(1, len(boxes) + 1))
    assert plan.page_at(1, 1).y_m[0] == plan.page_at(0, 1).y_m[0] == plan.page_at(0, 0).y_m[1]
    # no join crosses a marker's quiet zone here
    for m in lay.markers:
        half = lay.quiet_zone_side_m(m) / 2
        y, z = m.position_dock_m[1:]
        assert not any(y - half < c < y + half for c in plan.y_cuts)
        assert not any(z - half < c < z + half for c in plan.z_cuts)


def test_a_marker_larger_than_a_page_is_split_and_said(tmp_path: Path) -> None:
    lay = MarkerLayout("aruco_4x4_50", (Marker(0, 0.25, (0.35, 0.0, 0.0)),))
    path = tmp_path / "huge.yaml"
    path.write_text(yaml.safe_dump(lay.to_dict()))
    res = _markers(tmp_path / "huge.pdf", "--paper", "letter", layout=path)
    assert res.exit_code == 0, res.output + res.stderr
    assert plan_pages(lay, "letter").split_ids == (0,)
    assert "note: a page join crosses the black square of marker 0" in res.output


@pytest.mark.parametrize(
    ("suffix", "magic"),
    [
        (".jpg", b"\xff\xd8\xff"),
        (".jpeg", b"\xff\xd8\xff"),
        (".png", b"\x89PNG\r\n\x1a\n"),
        (".PDF", b"%PDF"),
    ],
)
def test_the_suffix_names_the_format(tmp_path: Path, suffix: str, magic: bytes) -> None:
    out = tmp_path / f"m{suffix}"
    res = _markers(out)
    assert res.exit_code == 0, res.output + res.stderr
    written = [out] if suffix == ".PDF" else [tmp_path / f"m-page{n}{suffix}" for n in (1, 2)]
    assert sorted(tmp_path.iterdir()) == sorted(written)
    for path in written:
        assert path.read_bytes().startswith(magic)


def test_raster_pages_are_the_paper_at_the_dpi_and_markers_at_true_size(tmp_path: Path) -> None:
    lay = default_layout()
    dpi = 100
    paths = write_pages(lay, tmp_path / "m.png", "letter", dpi=dpi)
    w_mm, h_mm = PAPER_MM["letter"]
    found = {}
    for path in paths:
        image = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
        assert abs(image.shape[1] - w_mm / 25.4 * dpi) <= 1 and abs(image.shape[0] - h_mm / 25.4 * dpi) <= 1
        corners, ids, _ = cv2.aruco.ArucoDetector(aruco_dictionary(lay.dictionary)).detectMarkers(image)
        for c, i in zip(corners, [] if ids is None else ids.ravel(), strict=True):
            c = c.reshape(4, 2)
            found[int(i)] = np.linalg.norm(c - np.roll(c, -1, axis=0), axis=1).mean()
    assert sorted(found) == [0, 1, 2, 3, 4]  # every marker whole on one page
    for i, side_px in found.items():
        assert side_px == pytest.approx(lay.marker(i).size_m / 0.0254 * dpi, abs=1.5)


def _one_line_error(res, expected: str) -> None:
    assert res.exit_code == 2, res.output + res.stderr
    assert res.stderr == expected + "\n"
    assert "Traceback" not in res.output + res.stderr
    assert isinstance(res.exception, SystemExit)


def test_out_is_a_directory(tmp_path: Path) -> None:
    res = _markers(tmp_path)
    _one_line_error(
        res,
        f"error: --out {tmp_path}: is a directory (give a file name, e.g. "
        f"{tmp_path / 'tank_0p6hz_markers.pdf'})",
    )
    assert list(tmp_path.iterdir()) == []


def test_out_with_an_unsupported_suffix(tmp_path: Path) -> None:
    out = tmp_path / "m.gif"
    _one_line_error(
        _markers(out), f"error: --out {out}: unsupported format '.gif' (use .pdf, .png, .jpg or .jpeg)"
    )
    assert not out.exists()


def test_out_under_a_file_and_unwritable(tmp_path: Path) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("x")
    _one_line_error(_markers(blocker / "m.pdf"), f"error: --out {blocker}: exists and is not a directory")
    (tmp_path / "m.pdf").mkdir()  # no suffix given: m.pdf is the file, and it is a directory
    res = _markers(tmp_path / "m")
    _one_line_error(
        res,
        f"error: --out {tmp_path / 'm.pdf'}: is a directory (give a file name, e.g. "
        f"{tmp_path / 'm.pdf' / 'tank_0p6hz_markers.pdf'})",
    )


def test_bad_paper(tmp_path: Path) -> None:
    _one_line_error(_markers(tmp_path / "m.pdf", "--paper", "a3"), "error: --paper a3: expected a4 or letter")
    res = _markers(tmp_path / "m.pdf", "--paper", "Letter")
    assert res.exit_code == 0 and "Letter pages" in res.output
