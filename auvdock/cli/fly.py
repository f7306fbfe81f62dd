"""``auvdock fly`` and ``auvdock vehicle-sim``: the MAVLink vehicle and its rehearsal.

Both run on the command line's clock (:class:`auvdock.cli.app.Runtime`: the wall clock; a test
invokes them with a :class:`auvdock.runtime.clock.SimClock` shared with an in-process vehicle
simulator, to run them in simulated time).
"""

from __future__ import annotations

import contextlib
import time
from pathlib import Path
from typing import TYPE_CHECKING

import typer
from rich.markup import escape

from auvdock.cli.app import (
    app,
    check_controller,
    check_estimation,
    console,
    err_console,
    exit_interrupted,
    fail_input,
    load_or_exit,
    output_dir,
    output_file,
    positive_timeout,
    runtime,
    water_line,
)
from auvdock.config.mission import Mission, MissionError
from auvdock.runtime.interrupts import interrupt_name

#: vehicle-sim's log of received messages (``VehicleSim.received``, a test hook): the last this many, so
#: that a stand-in left running does not grow (about 1 kB an entry; 20 a second while fly flies).
RECEIVED_LOG = 2_000

if TYPE_CHECKING:
    from auvdock.runtime.clock import Clock
    from auvdock.standins.truth_camera import TruthCameraStream
    from auvdock.standins.vehicle_sim import VehicleSim


def _camera_line(path: Path) -> str:
    """``camera: 12.4 fixes/s over 15.9 s, capture-to-fix latency median 98 ms (p95 441 ms)`` from a
    camera flight's results (wall-clock figures: they depend on the machine); "" without a camera."""
    import h5py
    import numpy as np

    try:
        with h5py.File(path, "r") as f:
            if "camera_fixes" not in f:
                return ""
            fixes, t, lat = f["camera_fixes"][()], f["time_s"][()], f["camera_latency_s"][()]
    except (OSError, KeyError):
        return ""
    span = float(t[-1] - t[0]) if len(t) > 1 else 0.0
    lat = lat[np.isfinite(lat)]
    if span <= 0 or not lat.size:
        return ""
    return (
        f"camera: {np.nansum(fixes) / span:.1f} fixes/s over {span:.1f} s, capture-to-fix latency median "
        f"{1e3 * np.median(lat):.0f} ms (p95 {1e3 * np.percentile(lat, 95):.0f} ms)"
    )


def _pace_line(path: Path) -> str:
    """``pace: steps late median 0 ms, p95 3 ms, at most 41 ms (1 of 380 steps later than a period)`` from
    a flight's results (``loop_late_s``: how late each step started on the session's clock; wall-clock
    figures, which depend on the machine); "" without them."""
    import h5py
    import numpy as np

    try:
        with h5py.File(path, "r") as f:
            if "loop_late_s" not in f:
                return ""
            late, dt = f["loop_late_s"][()], float(f.attrs.get("dt_s", np.nan))
    except (OSError, KeyError):
        return ""
    late = late[np.isfinite(late)]
    if not late.size:
        return ""
    over = int(np.sum(late > dt)) if np.isfinite(dt) else 0
    p50, p95 = 1e3 * np.median(late), 1e3 * np.percentile(late, 95)
    return (
        f"pace: steps late median {p50:.0f} ms, p95 {p95:.0f} ms, "
        f"at most {1e3 * np.max(late):.0f} ms ({over} of {late.size} steps later than a period)"
    )


@app.command()
def fly(
    ctx: typer.Context,
    mission: Path = typer.Argument(..., help="Mission YAML file or shipped mission name (tank_positioned)."),
    port: str = typer.Option(
        "udp:14550",
        "--port",
        help="pymavlink connection string; udp:PORT listens on 0.0.0.0:PORT (where BlueOS sends MAVLink).",
    ),
    arm: bool = typer.Option(
        False,
        "--arm",
        help="Arm the vehicle and command thrust. Without it: a dry run, neutral overrides only.",
    ),
    controller: str | None = typer.Option(
        None, "--controller", "-c", help="Override the mission's controller."
    ),
    out: Path | None = typer.Option(None, "--out", "-o", help="Output directory (default: the mission's)."),
    timeout: float | None = typer.Option(
        None, "--timeout", callback=positive_timeout, help="Override the docking timeout, s."
    ),
    sysid: int = typer.Option(
        255, "--sysid", min=1, max=255, help="Our MAVLink system id (ArduSub SYSID_MYGCS)."
    ),
    connect_timeout: float = typer.Option(
        10.0, "--connect-timeout", min=0.1, help="Wait for the vehicle, s."
    ),
    estimation: str | None = typer.Option(
        None,
        "--estimation",
        help="Override the mission's estimation: filter (the navigation filter on the vehicle's "
        "sensors; needed by the FSE controllers) or truth (the autopilot's estimate as the state).",
    ),
) -> None:
    """Dock a real BlueROV2 (ArduSub) over MAVLink with the mission's controller.

    Checks the vehicle's parameters and the measured limits before arming; stops at once when
    someone else takes the vehicle.  Exit status: 0 docked, 1 not docked in time, 2 bad input,
    3 aborted (a check, a limit, lost telemetry, arming refused), 4 takeover, 130 Ctrl-C.
    """
    clock = runtime(ctx).clock
    from auvdock.fly import FlySession
    from auvdock.fly.link import MavlinkLink, connection_string
    from auvdock.fly.session import check_flyable

    m = load_or_exit(mission)
    if check_estimation(estimation) is not None:
        m = m.with_updates(estimation=estimation)
    if controller is not None:
        check_controller(controller)
    try:
        connection_string(port)
    except ValueError as e:
        fail_input(f"--port {port}: {e}")
    try:  # a mission fly cannot fly is refused before anything is said, opened or written
        check_flyable(m, controller)
    except MissionError as e:
        fail_input(str(e))
    out_dir = output_dir(out if out is not None else Path(m.output.dir))
    stamp = time.strftime("%Y%m%d-%H%M%S")
    name = controller or m.controller.type
    h5 = out_dir / f"{m.name}_{name}_fly_{stamp}.h5"
    tlog = h5.with_suffix(".tlog")
    # nothing is armed yet: --arm arms after the vehicle's parameters and the pre-flight checks pass
    mode = (
        "[bold red]--arm: arming when the pre-flight checks pass[/bold red]"
        if arm
        else "[yellow]dry run (no --arm): neutral thrust only[/yellow]"
    )
    console.print(f"[bold]fly[/bold] {escape(f'{m.name} / {name} on {port}')}: {mode}", soft_wrap=True)
    try:
        link = MavlinkLink(port, sysid=sysid, tlog=tlog, clock=clock)
    except (OSError, ValueError) as e:
        fail_input(f"--port {port}: {e}")
        raise AssertionError("unreachable") from None

    def close_unused() -> None:
        """Close the link of a session that never ran, and its tlog with it when nothing was recorded."""
        link.close()
        with contextlib.suppress(OSError):
            if tlog.stat().st_size == 0:
                tlog.unlink()

    try:
        session = FlySession(m, link, arm=arm, out=h5, controller=controller, timeout_s=timeout,
                             connect_timeout_s=connect_timeout)  # fmt: skip
    except MissionError as e:
        close_unused()
        fail_input(str(e))
        raise AssertionError("unreachable") from None
    except KeyboardInterrupt:
        close_unused()
        exit_interrupted("interrupted: before connecting to the vehicle; nothing was sent")
    last = [-1e9]

    def on_step(t: float, dist: float, status: str) -> None:
        now = link.clock.now()
        if now - last[0] > 1.0:
            last[0] = now
            console.print(f"  t = {t:6.2f} s  distance {dist:6.3f} m  solver {status}", markup=False)

    def on_event(
        t_ev: float, text: str
    ) -> None:  # as they happen: waits, pre-arm reasons, the vehicle's words
        console.print(f"  [dim]{t_ev:7.2f} s[/dim] {escape(text)}", highlight=False, soft_wrap=True)

    result = session.run(progress=on_step, on_event=on_event)
    if result.results_path is not None:
        console.print(f"results: {result.results_path}", markup=False, highlight=False, soft_wrap=True)
        for line in (_camera_line(result.results_path), _pace_line(result.results_path)):
            if line:
                console.print(line, markup=False, highlight=False, soft_wrap=True)
    console.print(f"tlog: {tlog}", markup=False, highlight=False, soft_wrap=True)
    if result.reason == "docked":
        console.print(f"[green]{escape(result.message)}[/green]", soft_wrap=True)
    elif result.reason == "timeout":
        err_console.print(f"not docked: {result.message}", markup=False, highlight=False, soft_wrap=True)
    elif result.reason == "interrupted":
        where = f"; results in {result.results_path}" if result.results_path is not None else ""
        exit_interrupted(f"{result.message}{where}")  # "interrupted (Ctrl-C)...; results in ..."
    elif result.reason == "takeover":
        err_console.print(
            f"takeover: {result.message}; fly released the channels and stopped",
            markup=False,
            highlight=False,
            soft_wrap=True,
        )
    else:
        err_console.print(f"{result.reason}: {result.message}", markup=False, highlight=False, soft_wrap=True)
    raise typer.Exit(code=result.exit_code)


@app.command("vehicle-sim")
def vehicle_sim(
    ctx: typer.Context,
    mission: Path | None = typer.Argument(
        None, help="Mission YAML file or name: start state, vehicle and flow (default: tank_positioned)."
    ),
    port: str = typer.Option(
        "udpout:127.0.0.1:14550",
        "--port",
        help="pymavlink connection string to serve the vehicle's MAVLink on.",
    ),
    mission_option: Path | None = typer.Option(
        None, "--mission", "-m", hidden=True, help="The mission, as an option (older spelling)."
    ),
    speed: float = typer.Option(1.0, "--speed", min=0.01, help="Simulated seconds per wall-clock second."),
    hold: bool = typer.Option(
        True,
        "--hold-start/--no-hold-start",
        help="Hold the vehicle at the mission's start while disarmed (as a pilot who dives it there "
        "before each flight), else it floats up from the start (the BlueROV2 Heavy is 2 N buoyant).",
    ),
    noise: bool = typer.Option(
        True,
        "--sensor-noise/--no-sensor-noise",
        help="Telemetry with the mission's sensor errors (IMU noise and biases, attitude, depth, position).",
    ),
    truth_out: Path | None = typer.Option(
        None,
        "--truth-out",
        help="Write the truth (the vehicle's and the dock's trajectories, the arming) to this results "
        "file, complete when stopped; score a flight on it with auvdock truth-check.",
    ),
    camera: str | None = typer.Option(
        None,
        "--camera",
        help="udp:HOST:PORT (or udp:PORT, to 127.0.0.1): stream the camera's view of the true pose as "
        "RTP/H.264, as BlueOS would, for fly with camera.source: udp:PORT. Default: no camera.",
    ),
) -> None:
    """Run auvdock's 6-DOF simulator as an ArduSub MAVLink vehicle (for rehearsing and testing fly)."""
    clock = runtime(ctx).clock
    from auvdock.cli.sitl import parse_camera_target
    from auvdock.config.catalog import missions_dir
    from auvdock.fly.link import check_host, connection_string
    from auvdock.standins.vehicle_sim import VehicleSim

    try:
        port = connection_string(port)
    except ValueError as e:
        fail_input(f"--port {port}: {e}")
    target: tuple[str, int] | None = None
    if camera is not None:
        try:
            target = parse_camera_target(camera)
            check_host(target[0])
        except ValueError as e:
            fail_input(f"--camera {camera}: {e}")
    if mission is not None and mission_option is not None:
        fail_input(f"--mission {mission_option}: the mission is also given as {mission}; give it once")
    mission = mission if mission is not None else mission_option
    path = mission if mission is not None else missions_dir() / "tank_positioned.yaml"
    m = load_or_exit(path)
    if truth_out is not None:
        truth_out = output_file(truth_out, "--truth-out")
    stream = None
    try:
        try:  # (from the banner on: a Ctrl-C right after it is said as one before the simulator started)
            console.print(
                "[bold]vehicle-sim[/bold]: "
                + escape(
                    f"ArduSub-like BlueROV2 (sysid 1) on {port}, mission {m.name}, speed {speed:g}x, "
                    f"{water_line(m)}, "
                    f"sensor noise {'on' if noise else 'off'}, "
                    f"{'held at the start while disarmed' if hold else 'free from the start'}; Ctrl-C to stop"
                ),
                soft_wrap=True,
            )
            sim = VehicleSim(
                m,
                port=port,
                speed=speed,
                clock=clock,
                noise=noise,
                hold_start=hold,
                truth_out=truth_out,
                received_maxlen=RECEIVED_LOG,
            )
            if target is not None:
                stream = _truth_camera(m, sim, target, camera, clock)
                said = f"camera: {stream.description}"
                console.print(said, markup=False, highlight=False, soft_wrap=True)
        except KeyboardInterrupt:  # before the simulator started: its truth file is not yet created
            said = "before the simulator started; nothing written"
            exit_interrupted(f"interrupted ({interrupt_name()}): {said}")
            raise AssertionError("unreachable") from None
        interrupted = sim.run_forever(then=None if stream is None else stream.start)
    except (OSError, ValueError) as e:
        fail_input(f"--port {port}: {e}")
    finally:
        if stream is not None:
            stream.stop()
    truth = f"; truth in {truth_out}" if truth_out is not None and truth_out.is_file() else ""
    events = "events: " + ", ".join(e.kind for e in sim.events) if sim.events else "no events"
    said = f"stopped at t = {sim.t:.1f} s; {events}{truth}"
    if interrupted:  # Ctrl-C or SIGTERM: how a stand-in is stopped, said as every command says it
        exit_interrupted(f"interrupted ({interrupt_name()}): {said}")
    console.print(said, markup=False, highlight=False, soft_wrap=True)


def _truth_camera(
    m: Mission, sim: VehicleSim, target: tuple[str, int], option: str | None, clock: Clock
) -> TruthCameraStream:
    """vehicle-sim's --camera: the view of its true pose as RTP/H.264 (exit 2 on a bad camera or encoder)."""
    from auvdock.camera.video_common import VideoSourceError
    from auvdock.camera.video_out import h264_encoder
    from auvdock.standins.truth_camera import TruthCameraStream

    try:
        h264_encoder()
        return TruthCameraStream.from_mission(m, sim.pose, *target, clock=clock)
    except MissionError as e:
        fail_input(str(e))
    except (VideoSourceError, ImportError, OSError, ValueError) as e:
        fail_input(f"--camera {option}: {e}")
    raise AssertionError("unreachable")


@app.command("truth-check")
def truth_check(
    flight: Path = typer.Argument(..., help="A flight's results file (fly's .h5)."),
    truth: Path = typer.Argument(..., help="The truth of the same session (vehicle-sim --truth-out)."),
) -> None:
    """Score a rehearsed flight on what really happened: its verdict, the truth's closest approach."""
    from auvdock.standins.truth_check import check_flight

    for p in (flight, truth):
        if not p.is_file():
            fail_input(f"{p}: file not found")
    try:
        result = check_flight(flight, truth)
    except (ValueError, OSError, KeyError) as e:
        fail_input(str(e))
        return
    for line in result.lines():
        console.print(line, markup=False, highlight=False)
    if not result.verdict_right:
        raise typer.Exit(code=1)


@app.command()
def replay(
    tlog: Path = typer.Argument(..., help="A flight's tlog, as fly writes it beside its results."),
    mission: Path = typer.Argument(..., help="The mission it flew (or a variant to try on the same data)."),
    controller: str | None = typer.Option(
        None, "--controller", "-c", help="Controller (default: the flight's, from its tlog)."
    ),
    out: Path | None = typer.Option(
        None, "--out", "-o", help="Results file (default: the tlog's name with _replay.h5)."
    ),
    force: bool = typer.Option(False, "--force", help="Overwrite an existing results file."),
) -> None:
    """Rerun a flight's estimator and controller offline on its tlog; results like fly's.

    The same session code runs on the recorded messages, step by step (nothing is sent); with
    the flight's mission and controller the outputs equal the flight's.  If the flight's
    results file lies beside the tlog, the largest thrust difference is printed.
    """
    from auvdock.fly.replay import ReplayError
    from auvdock.fly.replay import replay as run_replay
    from auvdock.results.store import read_run

    if not tlog.is_file():
        fail_input(f"{tlog}: no such file")
    m = load_or_exit(mission)
    if controller is not None:
        check_controller(controller)
    h5 = out if out is not None else tlog.with_name(f"{tlog.stem}_replay.h5")
    if h5.is_dir():
        fail_input(f"--out {h5}: is a directory")
    if h5.exists() and not force:
        fail_input(f"--out {h5}: exists (--force to overwrite)")
    if not h5.parent.is_dir():
        fail_input(f"--out {h5}: no such directory {h5.parent}")
    if h5.exists():
        h5.unlink()
    try:
        result, tag = run_replay(tlog, m, h5, controller=controller)
    except (ReplayError, MissionError) as e:
        fail_input(str(e))
        raise AssertionError("unreachable") from None
    except KeyboardInterrupt:
        exit_interrupted(f"interrupted ({interrupt_name()}); results so far in {h5}")
    name = controller or (tag.controller if tag is not None else m.controller.type)
    console.print(
        "[bold]replay[/bold] "
        + escape(f"{tlog.name} with {m.name} / {name}: {result.reason}: {result.message}"),
        highlight=False,
        soft_wrap=True,
    )
    if result.results_path is None:
        err_console.print(
            f"replay: no control step reached ({result.message})", markup=False, highlight=False
        )
        raise typer.Exit(code=1)
    r = read_run(h5)
    console.print(
        f"results: {h5} ({int(r.control_rows().sum())} control steps)", markup=False, highlight=False
    )
    flight = tlog.with_suffix(".h5")
    if flight.is_file():
        f = read_run(flight)
        n = min(len(f.thrust_N), len(r.thrust_N))
        diff = float(abs(f.thrust_N[:n] - r.thrust_N[:n]).max()) if n else float("nan")
        console.print(
            f"the flight's results {flight.name}: {n} rows compared, largest thrust difference {diff:.3g} N",
            markup=False,
        )
    if result.message.startswith("replay diverged"):
        raise typer.Exit(code=1)
