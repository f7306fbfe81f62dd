"""``auvdock markers`` and ``auvdock calibrate``: the dock's marker sheet and the camera file.

``markers`` tiles the dock's panel at true scale over A4 or Letter pages (``--paper``), in the format the
``--out`` suffix names (PDF, PNG, JPEG). A live calibration waits on the command line's clock
(:class:`auvdock.cli.app.Runtime`: the wall clock; a test may hand in a
:class:`auvdock.runtime.clock.SimClock`): for the first frame at most ``--wait`` seconds, saying every
5 s what it waits for, then exits 2 with one line if no video came.
"""

from __future__ import annotations

from pathlib import Path

import typer
import yaml
from rich import box
from rich.table import Table

from auvdock.cli.app import app, console, exit_interrupted, fail_input, load_or_exit, output_dir, runtime


def _load_layout(path: Path):
    """A marker layout from a mission file (its dock.markers), a shipped mission's name
    (``tank_camera``) or a layout YAML file."""
    from auvdock.camera.layout import MarkerLayout
    from auvdock.config.catalog import resolve

    path = resolve(path)
    if not path.is_file():
        fail_input(f"{path}: no such file (nor a shipped mission of that name)")
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


def _say(line: str) -> None:
    console.print(line, markup=False, highlight=False, soft_wrap=True)


def _sheet_target(out: Path | None, layout: Path, pdf: bool) -> Path:
    """The file ``--out`` names (default ``<layout>_markers.pdf/.png``), or exit 2 with one line: a
    directory, a suffix that is not .pdf / .png / .jpg / .jpeg, a parent that cannot be a directory."""
    from auvdock.camera.print_sheet import sheet_format

    default = f"{layout.stem}_markers.{'pdf' if pdf else 'png'}"
    target = out or Path(default)
    try:
        named, _ = sheet_format(target, pdf)
    except ValueError as e:
        if not target.is_dir():
            fail_input(f"--out {target}: {e}")
        named = target
    for path in dict.fromkeys((target, named)):
        if path.is_dir():
            fail_input(f"--out {path}: is a directory (give a file name, e.g. {path / default})")
    output_dir(named.parent, "--out")
    return named


@app.command()
def markers(
    layout: Path = typer.Argument(
        ...,
        help="Mission file or shipped mission name (its dock.markers, or the default layout), or a "
        "layout YAML file.",
    ),
    out: Path | None = typer.Option(
        None,
        "--out",
        "-o",
        help="Sheet file; the suffix names the format: .pdf (all pages in one file), .png, .jpg or .jpeg "
        "(one image per page, NAME-pageN.png when there are several). Default <name>_markers.pdf/.png.",
    ),
    paper: str = typer.Option(
        "a4",
        "--paper",
        help="Paper size, a4 or letter; the panel is tiled over as many pages as it needs, with crop marks "
        "and page labels.",
    ),
    pdf: bool = typer.Option(True, "--pdf/--png", help="Format when --out has no suffix: PDF or PNG."),
) -> None:
    """Print the dock's marker sheet at true scale on A4 or Letter (print at 100 %, check the 100 mm bar)."""
    from auvdock.camera.print_sheet import PAPER_MM, plan_pages, write_pages

    if paper.lower() not in PAPER_MM:
        fail_input(f"--paper {paper}: expected {' or '.join(PAPER_MM)}")
    lay = _load_layout(layout)
    target = _sheet_target(out, layout, pdf)
    plan = plan_pages(lay, paper.lower())
    try:
        written = write_pages(lay, target, plan=plan)
    except OSError as e:
        fail_input(f"--out {e.filename or target}: cannot write ({e.strerror or e})")
        raise AssertionError("unreachable") from None
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
    _say(
        f"sheet: {', '.join(str(p) for p in written)}: {plan.describe()}; print at 100 % (actual size, "
        "no fit to page) and check the 100 mm bar on each page"
    )
    if plan.split_ids:
        ids = ", ".join(str(i) for i in plan.split_ids)
        _say(
            f"note: a page join crosses the black square of marker {ids} (no join could avoid it): "
            "butt those pages together with care"
        )


def _parse_board(board: str) -> tuple[int, int]:
    try:
        cols, rows = (int(v) for v in board.lower().split("x"))
    except ValueError:
        fail_input(f"--board {board}: expected COLSxROWS inner corners, e.g. 9x6")
        raise AssertionError("unreachable") from None
    if cols < 2 or rows < 2:
        fail_input(f"--board {board}: need at least 2x2 inner corners")
    return cols, rows


def _live_names(src: object) -> tuple[str, str, str]:
    """(the source in messages, what its wait is for, a hint when no video came) of a live source."""
    from auvdock.camera.video_in import RtpSource, V4l2Source

    if isinstance(src, RtpSource):
        where = f"UDP port {src.port}" if src.host == "0.0.0.0" else f"UDP {src.host}:{src.port}"
        hint = f"; is the camera streaming RTP/H.264 to this computer's port {src.port}?"
        return where, f"the RTP/H.264 stream on {where}", hint
    if isinstance(src, V4l2Source):
        return src.path, f"frames from the camera {src.path}", ""
    what = str(getattr(src, "description", "the source"))
    return what, f"video from {what}", ""


@app.command()
def calibrate(
    ctx: typer.Context,
    source: str = typer.Argument(
        ..., help="Folder of images, a video file, or a live camera (udp:5600, /dev/video0, v4l2:0)."
    ),
    board: str = typer.Option(..., "--board", help="Checkerboard inner corners, COLSxROWS (e.g. 9x6)."),
    square: float = typer.Option(..., "--square", min=1e-4, help="Checkerboard square side, m."),
    out: Path = typer.Option(Path("camera.yaml"), "--out", "-o", help="Camera file to write."),
    frames: int = typer.Option(
        25,
        "--frames",
        min=5,
        help="Live camera: board views to collect (0.5 s apart; collection stops 60 s + 1 s per view after "
        "the first frame, and calibrates if it has at least 5).",
    ),
    wait: float = typer.Option(
        30.0,
        "--wait",
        min=0.1,
        help="Live camera: longest wait, s, for the first frame (a line every 5 s says what it waits for; "
        "then exit 2), and for the next one once the video runs.",
    ),
    every: int = typer.Option(1, "--every", min=1, help="Video file: use every Nth frame."),
) -> None:
    """OpenCV checkerboard calibration: writes the camera file missions point to (camera.calibration)."""
    clock = runtime(ctx).clock
    from auvdock.camera.calibration import NoVideoError, collect_views
    from auvdock.camera.calibration import calibrate as run_calibration
    from auvdock.camera.image_files import image_sources
    from auvdock.camera.model import save_camera

    cols, rows = _parse_board(board)
    images = []
    if Path(source).exists():
        try:
            images = list(image_sources(source, every=every))
        except ValueError as e:
            fail_input(str(e))
    else:
        from auvdock.camera.video_common import VideoSourceError
        from auvdock.camera.video_in import open_source

        try:
            src = open_source(source, clock=clock)
        except (OSError, ValueError, RuntimeError) as e:
            fail_input(f"{source}: {e}")
            raise AssertionError("unreachable") from None
        what, waiting_for, hint = _live_names(src)
        with src:
            try:
                images = collect_views(
                    src,
                    cols,
                    rows,
                    views=frames,
                    wait_s=wait,
                    clock=clock,
                    what=what,
                    waiting_for=waiting_for,
                    say=_say,
                )
            except NoVideoError as e:
                fail_input(f"{source}: {e} (--wait {wait:g}){hint}")
            except (ValueError, VideoSourceError) as e:
                fail_input(f"{source}: {e}")
            except KeyboardInterrupt:
                exit_interrupted("interrupted: no camera file written")
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
    console.print(
        f"camera file: {out} (set camera.calibration: {out} in the mission)", markup=False, highlight=False
    )
