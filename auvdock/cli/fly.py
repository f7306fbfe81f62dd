"""``auvdock fly`` and ``auvdock vehicle-sim``: the MAVLink vehicle and its rehearsal.

Both run on :data:`clock`, the wall clock.  Tests replace it with a
:class:`auvdock.clock.SimClock` shared with an in-process vehicle simulator
(``monkeypatch.setattr(auvdock.cli.fly, "clock", sim_clock)``) to run the commands in
simulated time.
"""

from __future__ import annotations

import time
from pathlib import Path

import typer

from ..clock import Clock, wall_clock
from ..mission import CONTROLLER_TYPES, MissionError
from .app import app, console, err_console, exit_interrupted, fail_input, load_or_exit

#: The clock ``fly`` and ``vehicle-sim`` wait and pace on.
clock: Clock = wall_clock


@app.command()
def fly(
    mission: Path = typer.Argument(..., help="Mission YAML file (e.g. missions/tank_0p6hz.yaml)."),
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
    timeout: float | None = typer.Option(None, "--timeout", min=0.0, help="Override the docking timeout, s."),
    sysid: int = typer.Option(
        255, "--sysid", min=1, max=255, help="Our MAVLink system id (ArduSub SYSID_MYGCS)."
    ),
    connect_timeout: float = typer.Option(
        10.0, "--connect-timeout", min=0.1, help="Wait for the vehicle, s."
    ),
) -> None:
    """Dock a real BlueROV2 (ArduSub) over MAVLink with the mission's controller."""
    from ..fly import FlySession
    from ..hardware.link import MavlinkLink, connection_string

    m = load_or_exit(mission)
    if controller is not None and controller not in CONTROLLER_TYPES:
        fail_input(f"--controller: unknown controller {controller!r} (known: {', '.join(CONTROLLER_TYPES)})")
    try:
        connection_string(port)
    except ValueError as e:
        fail_input(f"--port {port}: {e}")
    out_dir = out if out is not None else Path(m.output.dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    stamp = time.strftime("%Y%m%d-%H%M%S")
    name = controller or m.controller.type
    h5 = out_dir / f"{m.name}_{name}_fly_{stamp}.h5"
    tlog = h5.with_suffix(".tlog")
    mode = "[bold red]ARMED[/bold red]" if arm else "[yellow]dry run (no --arm): neutral thrust only[/yellow]"
    console.print(f"[bold]fly[/bold] {m.name} / {name} on {port}: {mode}")
    try:
        link = MavlinkLink(port, sysid=sysid, tlog=tlog, clock=clock)
    except (OSError, ValueError) as e:
        fail_input(f"--port {port}: {e}")
        raise AssertionError("unreachable") from None
    try:
        session = FlySession(m, link, arm=arm, out=h5, controller=controller, timeout_s=timeout,
                             connect_timeout_s=connect_timeout)  # fmt: skip
    except MissionError as e:
        link.close()
        fail_input(str(e))
        raise AssertionError("unreachable") from None
    except KeyboardInterrupt:
        link.close()
        exit_interrupted("interrupted: before connecting to the vehicle; nothing was sent")
    last = [-1e9]

    def on_step(t: float, dist: float, status: str) -> None:
        now = link.clock.now()
        if now - last[0] > 1.0:
            last[0] = now
            console.print(f"  t = {t:6.2f} s  distance {dist:6.3f} m  solver {status}")

    result = session.run(progress=on_step)
    for t_ev, text in result.events:
        console.print(f"  [dim]{t_ev:7.2f} s[/dim] {text}", markup=True, highlight=False)
    if result.results_path is not None:
        console.print(f"results: {result.results_path}")
    console.print(f"tlog: {tlog}")
    if result.reason == "docked":
        console.print(f"[green]{result.message}[/green]")
    elif result.reason == "timeout":
        err_console.print(f"not docked: {result.message}", markup=False, highlight=False)
    elif result.reason == "interrupted":
        where = f"; results in {result.results_path}" if result.results_path is not None else ""
        exit_interrupted(f"{result.message}{where}")  # "interrupted (Ctrl-C)...; results in ..."
    else:
        err_console.print(f"{result.reason}: {result.message}", markup=False, highlight=False)
    raise typer.Exit(code=result.exit_code)


@app.command("vehicle-sim")
def vehicle_sim(
    port: str = typer.Option(
        "udpout:127.0.0.1:14550",
        "--port",
        help="pymavlink connection string to serve the vehicle's MAVLink on.",
    ),
    mission: Path | None = typer.Option(
        None, "--mission", "-m", help="Mission for the start state, vehicle and flow (default: tank_0p6hz)."
    ),
    speed: float = typer.Option(1.0, "--speed", min=0.01, help="Simulated seconds per wall-clock second."),
    noise: bool = typer.Option(
        True,
        "--sensor-noise/--no-sensor-noise",
        help="Telemetry with the mission's sensor errors (IMU noise and biases, attitude, depth, position).",
    ),
) -> None:
    """Run auvdock's 6-DOF simulator as an ArduSub MAVLink vehicle (for rehearsing and testing fly)."""
    from ..catalog import missions_dir
    from ..hardware.vehicle_sim import VehicleSim

    path = mission if mission is not None else missions_dir() / "tank_0p6hz.yaml"
    m = load_or_exit(path)
    console.print(
        f"[bold]vehicle-sim[/bold]: ArduSub-like BlueROV2 (sysid 1) on {port}, mission {m.name}, "
        f"speed {speed:g}x, flow {m.build_flow().describe()}, sensor noise {'on' if noise else 'off'}; "
        "Ctrl-C to stop"
    )
    try:
        sim = VehicleSim(m, port=port, speed=speed, clock=clock, noise=noise)
        sim.run_forever()
    except OSError as e:
        fail_input(f"--port {port}: {e}")
    console.print(f"stopped at t = {sim.t:.1f} s; events: " + ", ".join(e.kind for e in sim.events))
