"""``auvdock sitl-physics``: auvdock's truth model as the physics of ArduPilot SITL (``--model JSON``).

The real ArduSub firmware runs in SITL; this command moves its vehicle
(:class:`auvdock.standins.sitl_physics.SitlPhysics`) and, with ``--camera``, streams the
camera's view of the true pose as RTP/H.264
(:class:`auvdock.standins.truth_camera.TruthCameraStream`).  ``docs/commands/sitl-physics.md`` says how to run
the three programs together.

Output is plain lines (readable in a log file): one when it starts, one per event (SITL
connected or restarted, the vehicle released), a status line every
:data:`STATUS_PERIOD_S` s, a summary at the end.  Exit status 0 after ``--duration``, 2 on
bad input (one line: the mission, ``--listen`` or ``--camera`` and the problem), 130 on
Ctrl-C (one line: the summary), 1 if the server failed at run time.

The command waits on the command line's clock (:class:`auvdock.cli.app.Runtime`: the wall clock; tests
hand in a simulated one).
"""

from __future__ import annotations

import errno
import re
import socket
from pathlib import Path
from typing import TYPE_CHECKING

import typer

from auvdock.cli.app import (
    app,
    console,
    err_console,
    exit_interrupted,
    fail_input,
    load_or_exit,
    output_file,
    runtime,
)
from auvdock.config.mission import MissionError
from auvdock.runtime.interrupts import interrupt_name

if TYPE_CHECKING:
    from auvdock.standins.sitl_physics import PhysicsEvent, SitlPhysics
    from auvdock.standins.truth_camera import TruthCameraStream

#: Seconds (on the command's clock) between status lines.
STATUS_PERIOD_S = 5.0

_CAMERA = re.compile(r"udp:(?:(?P<host>[^:\s]+):)?(?P<port>\d+)")


def parse_camera_target(text: str) -> tuple[str, int]:
    """``udp:HOST:PORT`` or ``udp:PORT`` (to 127.0.0.1) as (host, port).

    Raises
    ------
    ValueError
        Naming the problem (another form, a port outside 1..65534: RTCP takes port + 1).
    """
    m = _CAMERA.fullmatch(text.strip())
    if m is None:
        raise ValueError("expected udp:HOST:PORT or udp:PORT (where fly's camera.source listens)")
    port = int(m.group("port"))
    if not 1 <= port <= 65534:
        raise ValueError(f"port {port} is outside 1..65534 (RTCP uses port + 1)")
    return m.group("host") or "127.0.0.1", port


def _bind_problem(e: OSError) -> str:
    if isinstance(e, socket.gaierror):
        return "host not found"
    if e.errno == errno.EADDRINUSE:
        return "port in use (another sitl-physics or physics backend?)"
    if e.errno == errno.EADDRNOTAVAIL:
        return "not an address of this computer"
    if e.errno == errno.EACCES:
        return "permission denied (ports below 1024 need root)"
    return e.strerror or str(e)


_HOLD_TEXT = {
    "surface": ", held at the surface",
    "lowering": ", being lowered to the start",
    "start": ", held at the start",
    "free": "",
}


def _line(text: str) -> None:
    console.print(text, markup=False, highlight=False, soft_wrap=True)


@app.command("sitl-physics")
def sitl_physics(
    ctx: typer.Context,
    mission: Path = typer.Argument(..., help="Mission YAML file or name (vehicle, flow, start, dock)."),
    listen: str = typer.Option(
        "127.0.0.1:9002",
        "--listen",
        help="HOST:PORT to receive SITL's servo frames on (SITL's JSON backend sends to 9002).",
    ),
    camera: str | None = typer.Option(
        None,
        "--camera",
        help="udp:HOST:PORT (or udp:PORT, to 127.0.0.1): stream the camera's view of the true pose as "
        "RTP/H.264, as BlueOS would, for fly with camera.source: udp:PORT. Default: no camera.",
    ),
    seed: int | None = typer.Option(
        None, "--seed", min=0, help="Image-noise seed of the --camera stream (default: the mission's)."
    ),
    hold: bool = typer.Option(
        True,
        "--hold/--no-hold",
        "--hold-until-thrust/--no-hold-until-thrust",
        help="Until ArduSub's motors first push, hold the vehicle: at the surface while ArduSub boots "
        "(it zeroes its depth sensor there), then lowered to the mission's start and held there (it "
        "would otherwise float up while SITL's EKF settles and ArduSub cannot yet arm).",
    ),
    duration: float | None = typer.Option(
        None, "--duration", help="Stop after this much physics time, s (default: until Ctrl-C)."
    ),
    truth_out: Path | None = typer.Option(
        None,
        "--truth-out",
        help="Write the truth (the vehicle's and the dock's trajectories, whether the motors push) to this "
        "results file, complete when stopped; score a flight on it with auvdock truth-check.",
    ),
) -> None:
    """Be the physics of ArduPilot SITL (ardusub --model JSON): the real ArduSub flies in auvdock's ocean."""
    clock = runtime(ctx).clock
    from auvdock.fly.link import check_host
    from auvdock.standins.sitl_physics import SitlPhysics, parse_listen

    m = load_or_exit(mission)
    if truth_out is not None:
        truth_out = output_file(truth_out, "--truth-out")
    if duration is not None and not duration > 0:  # also NaN
        fail_input(f"--duration {duration:g}: must be a positive time, s")
    try:
        address = parse_listen(listen)
        check_host(address[0])
    except ValueError as e:
        fail_input(f"--listen {listen}: {e}")
        raise AssertionError("unreachable") from None
    target: tuple[str, int] | None = None
    if camera is not None:
        try:
            target = parse_camera_target(camera)
            check_host(target[0])
        except ValueError as e:
            fail_input(f"--camera {camera}: {e}")
    where = m.source or mission

    def on_event(ev: PhysicsEvent) -> None:  # from the server's thread
        _line(f"  t = {ev.t:9.3f} s  {ev.kind}: {ev.detail}")

    try:
        physics = SitlPhysics(
            m,
            listen=address,
            hold_until_thrust=hold,
            duration_s=duration,
            # the older camera tracker's rehearsal renders the dock moved by camera.synthetic.dock_offset_m;
            # the dock camera as a sensor renders the true dock of the seed (build_dock(truth=True))
            dock_offset_ned_m=m.camera.synthetic.dock_offset_m
            if target is not None and not (m.estimation == "filter" and m.sensors.dock_camera.enabled)
            else (0.0, 0.0, 0.0),
            on_event=on_event,
            clock=clock,
            truth_out=truth_out,
        )
    except ValueError as e:
        fail_input(f"{where}: vehicle: {e}")
        raise AssertionError("unreachable") from None
    except KeyboardInterrupt:
        exit_interrupted("interrupted: before listening; nothing was started")
        raise AssertionError("unreachable") from None
    try:
        host, port = physics.bind()
    except OSError as e:
        fail_input(f"--listen {listen}: {_bind_problem(e)}")
        raise AssertionError("unreachable") from None

    stream: TruthCameraStream | None = None
    if target is not None:
        from auvdock.camera.video_common import VideoSourceError
        from auvdock.camera.video_out import h264_encoder
        from auvdock.standins.truth_camera import TruthCameraStream

        try:
            h264_encoder()
            stream = TruthCameraStream.from_mission(m, physics.pose, *target, seed=seed, clock=clock)
        except MissionError as e:
            physics.stop()
            fail_input(str(e))
        except (VideoSourceError, ImportError, OSError, ValueError) as e:
            physics.stop()
            fail_input(f"--camera {camera}: {e}")

    v = physics.vehicle
    x0 = m.start_state()
    if not hold:
        hold_text = "free from the first frame (--no-hold)"
    elif physics.at_start_s > 0:
        hold_text = (
            f"held until the motors push: at the surface (ArduSub zeroes its depth sensor at boot), "
            f"then lowered to the start by t = {physics.at_start_s:.1f} s"
        )
    else:
        hold_text = "held at the start until the motors push"
    cam_text = f"; camera {stream.description}" if stream is not None else ""
    _line(
        f"sitl-physics: listening on udp {host}:{port} for ArduPilot SITL (--model JSON); mission {m.name}, "
        f"vehicle {v.name} ({v.n_thrusters} thrusters), start ({x0[0]:g}, {x0[1]:g}, {x0[2]:g}) m NED, "
        f"flow {physics.flow.describe()}; {hold_text}{cam_text}; Ctrl-C to stop"
    )
    try:
        physics.start()
        if stream is not None:
            stream.start()
        last = (clock.now(), physics.t, physics.frames)
        quiet_since = clock.now()
        while not physics.wait(STATUS_PERIOD_S):
            now, t, frames = clock.now(), physics.t, physics.frames
            if frames == last[2] and frames > 0:  # SITL stopped, paused or restarting
                quiet = now - quiet_since
                _line(f"  t = {t:9.3f} s  no new frame in the last {quiet:.0f} s (SITL stopped or paused?)")
            else:
                quiet_since = now
                _line(_status_line(physics, stream, host, port, (t - last[1]) / max(now - last[0], 1e-9)))
            last = (now, t, frames)
    except KeyboardInterrupt:
        _stop(physics, stream)
        exit_interrupted(f"interrupted ({interrupt_name()}): {_summary(physics, stream)}")
    _stop(physics, stream)
    if physics.error is not None:
        err_console.print(
            f"sitl-physics failed: {physics.error!r}; {_summary(physics, stream)}",
            markup=False,
            highlight=False,
            soft_wrap=True,
        )
        raise typer.Exit(code=1)
    _line(f"done: {_summary(physics, stream)}")


def _stop(physics: SitlPhysics, stream: TruthCameraStream | None) -> None:
    if stream is not None:
        stream.stop()
    physics.stop()


def _status_line(
    physics: SitlPhysics, stream: TruthCameraStream | None, host: str, port: int, speed: float
) -> str:
    s = physics.status()
    if s.frames == 0:
        return f"  waiting for SITL's first servo frame on udp {host}:{port} ..."
    motors = "motors active" if s.motors_active else "motors neutral"
    motors += _HOLD_TEXT[s.hold]
    cam = ""
    if stream is not None:
        cam = f"  camera {stream.frames_sent} frames"
        if stream.error is not None:
            cam += f" (stopped: {stream.error})"
    return (
        f"  t = {s.t:9.3f} s  frames {s.frames} at {s.frame_rate_hz} Hz (x{speed:.2f} real time)  "
        f"depth {s.depth_m:.2f} m  dock {s.dock_distance_m:.2f} m  {motors}{cam}"
    )


def _summary(physics: SitlPhysics, stream: TruthCameraStream | None) -> str:
    s = physics.status()
    text = (
        f"physics time {s.t:.3f} s, {s.frames} frames, {s.repeats} repeated, {s.ignored} ignored, "
        f"{s.resets} SITL restarts; vehicle at ({s.state[0]:.2f}, {s.state[1]:.2f}, {s.state[2]:.2f}) m NED, "
        f"{s.dock_distance_m:.3f} m from the dock"
    )
    if s.frames:
        text += f", closest {s.closest_m:.3f} m at t = {s.closest_t:.2f} s"
    if stream is not None:
        text += f"; camera {stream.frames_sent} frames"
    if physics.truth_out is not None and physics.truth_out.is_file():
        text += f"; truth in {physics.truth_out}"
    return text
