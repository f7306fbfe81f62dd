"""``auvdock markers`` and ``auvdock calibrate``: files written, figures reported, bad input exits 2."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import yaml
from test_camera import CAM, COLS, ROWS, SQUARE, _board_views
from typer.testing import CliRunner

from auvdock.camera import load_camera
from auvdock.camera.layout import default_layout
from auvdock.camera.print_sheet import plan_pages
from auvdock.cli import app

ROOT = Path(__file__).resolve().parents[1]
runner = CliRunner()


def test_markers_sheet_from_a_mission(tmp_path: Path) -> None:
    out = tmp_path / "sheet.pdf"
    res = runner.invoke(app, ["markers", str(ROOT / "missions" / "tank_0p6hz.yaml"), "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert out.read_bytes().startswith(b"%PDF")
    plan = plan_pages(default_layout(), "a4")
    assert f"sheet: {out}: {plan.describe()}; print at 100 % (actual size, no fit to page)" in res.output
    assert "150 mm" in res.output and "40 mm" in res.output


def test_markers_bad_layout_file(tmp_path: Path) -> None:
    bad = tmp_path / "layout.yaml"
    bad.write_text(yaml.safe_dump({"dictionary": "apriltag_36h11", "markers": [{"id": 0, "size_m": -1.0}]}))
    res = runner.invoke(app, ["markers", str(bad)])
    assert res.exit_code == 2
    assert res.stderr.strip().startswith(f"error: {bad}: markers[0]")


def test_calibrate_folder_writes_the_camera_file(tmp_path: Path) -> None:
    views = tmp_path / "views"
    views.mkdir()
    for k, view in enumerate(_board_views(12, seed=11)):
        cv2.imwrite(str(views / f"v{k:02d}.png"), view)
    out = tmp_path / "camera.yaml"
    res = runner.invoke(
        app,
        ["calibrate", str(views), "--board", f"{COLS}x{ROWS}", "--square", str(SQUARE), "--out", str(out)],
    )
    assert res.exit_code == 0, res.output + res.stderr
    assert "12 views, RMS reprojection error" in res.output
    cam = load_camera(out)
    np.testing.assert_allclose(np.diag(cam.K)[:2], np.diag(CAM.K)[:2], rtol=0.01)


def test_calibrate_bad_input(tmp_path: Path) -> None:
    res = runner.invoke(app, ["calibrate", str(tmp_path), "--board", "9by6", "--square", "0.025"])
    assert res.exit_code == 2
    assert res.stderr.strip() == "error: --board 9by6: expected COLSxROWS inner corners, e.g. 9x6"
    res = runner.invoke(app, ["calibrate", str(tmp_path), "--board", "9x6", "--square", "0.025"])
    assert res.exit_code == 2
    assert (
        res.stderr.strip()
        == f"error: {tmp_path}: no images (.png, .jpg, .jpeg, .bmp, .tif, .tiff) in this directory"
    )
