"""``auvdock markers`` and ``auvdock calibrate``: the dock's marker sheet and the camera file.

A live calibration waits on :data:`clock` (the wall clock; a test may set a
:class:`auvdock.clock.SimClock`, which paces video files and image folders too).
"""

from __future__ import annotations

from pathlib import Path

import typer
import yaml
from rich import box
from rich.table import Table

from ..clock import Clock, wall_clock
from .app import app, console, fail_input, load_or_exit

#: The clock a live calibration waits on.
clock: Clock = wall_clock


def _load_layout(path: Path):
    """A marker layout from a mission file (its dock.markers) or a layout YAML file."""
    from ..camera.layout import MarkerLayout

    if not path.is_file():
        fail_input(f"{path}: no such file")
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as e:
        fail_input(f"{path}: not YAML ({str(e).splitlines()[0]})")
    if isinstance(data, dict) and "markers" in data and "name" not in data:
        try:
            return MarkerLayout.from_dict(data)
        except ValueError as e:
            fail_input(f"{path}: {e}")
    return load_or_exit(path).dock.marker_layout()


@app.command()
def markers(
    layout: Path = typer.Argument(
        ..., help="Mission file (its dock.markers, or the default layout) or layout YAML."
    ),
    out: Path | None = typer.Option(
        None, "--out", "-o", help="Sheet file (default: <name>_markers.pdf/.png)."
    ),
    pdf: bool = typer.Option(True, "--pdf/--png", help="Printable PDF (default) or PNG."),
) -> None:
    """Print the dock's marker sheet at true scale (check the 100 mm bar after printing)."""
    from ..camera.layout import sheet_size_in, write_sheet

    lay = _load_layout(layout)
    target = out or Path(f"{layout.stem}_markers.{'pdf' if pdf else 'png'}")
    written = write_sheet(lay, target, pdf=pdf)
    w_in, h_in = sheet_size_in(lay)
    t = Table(title=f"{lay.dictionary} markers", box=box.SIMPLE)
    for col in ("id", "size", "position in the dock frame (m)", "rpy (deg)"):
        t.add_column(col)
    for mk in lay.markers:
        t.add_row(
            str(mk.id),
            f"{mk.size_m * 1000:.0f} mm",
            ", ".join(f"{v:+.3f}" for v in mk.position_dock_m),
            ", ".join(f"{v:g}" for v in mk.rpy_deg),
        )
    console.print(t)
    console.print(f"sheet: {written} ({w_in * 25.4:.0f} x {h_in * 25.4:.0f} mm; print at 100 %, no scaling)")


def _parse_board(board: str) -> tuple[int, int]:
    try:
        cols, rows = (int(v) for v in board.lower().split("x"))
    except ValueError:
        fail_input(f"--board {board}: expected COLSxROWS inner corners, e.g. 9x6")
        raise AssertionError("unreachable") from None
    if cols < 2 or rows < 2:
        fail_input(f"--board {board}: need at least 2x2 inner corners")
    return cols, rows


@app.command()
def calibrate(
    source: str = typer.Argument(
        ..., help="Folder of images, a video file, or a live camera (udp:5600, /dev/video0, v4l2:0)."
    ),
    board: str = typer.Option(..., "--board", help="Checkerboard inner corners, COLSxROWS (e.g. 9x6)."),
    square: float = typer.Option(..., "--square", min=1e-4, help="Checkerboard square side, m."),
    out: Path = typer.Option(Path("camera.yaml"), "--out", "-o", help="Camera file to write."),
    frames: int = typer.Option(
        25, "--frames", min=5, help="Live camera: board views to collect (0.5 s apart)."
    ),
    every: int = typer.Option(1, "--every", min=1, help="Video file: use every Nth frame."),
) -> None:
    """OpenCV checkerboard calibration: writes the camera file missions point to (camera.calibration)."""
    from ..camera.calibration import calibrate as run_calibration
    from ..camera.calibration import find_corners, image_sources
    from ..camera.model import save_camera

    cols, rows = _parse_board(board)
    images = []
    if Path(source).exists():
        try:
            images = list(image_sources(source, every=every))
        except ValueError as e:
            fail_input(str(e))
    else:
        from ..camera.video import open_source

        try:
            src = open_source(source, clock=clock)
        except (OSError, ValueError, RuntimeError) as e:
            fail_input(f"{source}: {e}")
            raise AssertionError("unreachable") from None
        last = 0.0
        with src, console.status(f"collecting {frames} views of the {cols}x{rows} board from {source}") as st:
            deadline = clock.now() + 60.0 + frames
            while len(images) < frames and clock.now() < deadline:
                f = src.read(timeout_s=1.0)
                if f is None or f.t_capture - last < 0.5:
                    continue
                if find_corners(f.image, cols, rows) is not None:
                    images.append(f.image)
                    last = f.t_capture
                    st.update(f"board views: {len(images)}/{frames}")
    try:
        cam = run_calibration(images, cols, rows, square)
    except ValueError as e:
        fail_input(f"{source}: {e}")
        raise AssertionError("unreachable") from None
    save_camera(cam, out)
    K = cam.K
    console.print(
        f"{cam.n_views} views, RMS reprojection error {cam.rms_px:.3f} px; fx {K[0, 0]:.1f} fy {K[1, 1]:.1f} "
        f"cx {K[0, 2]:.1f} cy {K[1, 2]:.1f} px; image {cam.width}x{cam.height}"
    )
    console.print(f"camera file: {out} (set camera.calibration: {out} in the mission)")
