"""The camera pipeline's detection and fix errors on rendered underwater views, and the fast model
derived from them.

Everything is rendered with the synthetic camera (:func:`auvdock.camera.render.render_view`: the ideal
640 x 480, 80 deg camera, image noise ``--noise`` 2 grey levels, blur ``--blur`` 0.5 px) and the water
(:class:`auvdock.camera.render.Water`: a marker of range ``d`` keeps the fraction ``exp(-c d)`` of its
black/white contrast, ``c = 4.8 / V``), then detected and solved by the real pipeline
(:class:`auvdock.camera.pose.MarkerDetector`, :func:`auvdock.camera.pose.estimate_dock_pose`).

1. **The sweep** (the derivation).  One 0.15 m marker, seen over a grid of apparent sides (12-85 px),
   contrasts (12-255 grey levels, set through the water: at range ``d`` the visibility
   ``V = 4.8 d / ln(C0 / C)`` gives the contrast ``C``) and obliquities (0, 30, 50 deg), each view
   ``--frames`` times at random sub-pixel offsets and in-plane rotations (+-5 deg); and an angle sweep
   (0-80 deg) at 60 px.  It prints the decoding rate and the corner error (RMS about the true
   projections, bias included: a bias moves with the pose along a trajectory) per side and contrast,
   and fits the constants of :class:`auvdock.sensing.camera_fix.CameraFixModel` (the "side" is the
   square root of the marker's image area, the "short side" that times sqrt(cos(obliquity))):

   * ``min_contrast_grey``, ``min_side_px``, ``size_power`` (and ``detect_steepness``): the decoding
     rate ``1 / (1 + u^k)``, ``u = min_contrast_grey / C + (min_side_px / side)^size_power``, fitted by
     maximum likelihood over every view of the grid; the model decodes where ``u <= 1``;
   * ``max_view_angle_deg``: the obliquity at which half the 60 px markers are decoded;
   * ``corner_px``: the corner error of well-resolved (short side >= 40 px, <= 30 deg), edge-refined
     markers at full contrast, from ``corner error = corner_px C0 / C`` (image noise over contrast: the
     edge refinement's area method integrates the noise across the edge, so the error is the noise over
     the step height; the printed ``error x C / C0`` is constant if the law holds);
   * ``small_px``, ``small_power``: the extra error of small refined markers (cells of 2-3 px),
     ``small_px (16 px / short side)^small_power`` added in quadrature (least squares in log, <= 30 deg);
   * ``unrefined_corner_px``: the error of the detector's own corners, where the edge refinement gave up;
   * ``refine_contrast_grey``, ``refine_side_px``, ``refine_steepness``: the rate at which the edge
     refinement gives up, ``u^k / (1 + u^k)``, ``u = refine_contrast_grey / C + refine_side_px / short
     side`` (maximum likelihood over the decoded views);
   * ``refine_max_angle_deg``, ``refine_angle_width_deg``: the share of unrefined-like corner error
     against the obliquity in the angle sweep, fitted by a logistic;
   * ``unrefined_radial_share``, ``small_radial_share``: the share of the corner error variance that is
     a displacement common to the four corners along their directions from the marker's centre (a scale
     error: it moves the range, not the tilt), for unrefined and for small refined markers.

2. **The tables** (one per ``--visibility``).  The dock's five-marker layout seen from the default
   mount at several ranges and obliquities: the pipeline's fix rate, its fix errors (RMS about the
   truth of the docking point in the camera frame: x, y across the view, z along it, mm) and the
   markers it used, beside the fast model's (with its defaults, which are the fitted constants of
   2026-12-02) markers and standard deviations; then along the approaches of
   ``tests/test_camera_rendered.py`` (25 poses each): the fix rates of both, and the RMS of the
   pipeline's errors over the model's standard deviation at each pose (1 if the model is right), with
   the share of outliers beyond 5 standard deviations (wrong IPPE solutions, not modelled).

    python benchmarks/camera_fix_errors.py [--frames 10] [--visibility 2 5 8] [--noise 2] [--blur 0.5]
                                           [--no-sweep] [--no-tables]

``--blur 1.0`` shows how much a larger blur (as forward scatter would add) changes the fitted constants.
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import dataclass

import numpy as np

from auvdock.camera.layout import Marker, MarkerLayout, default_layout
from auvdock.camera.model import CameraModel, CameraMount, camera_from_dock, project
from auvdock.camera.pose import MarkerDetector, estimate_dock_pose, refine_corners
from auvdock.camera.render import VISIBILITY_ATTENUATION, Water, render_view
from auvdock.sensing.camera_fix import CameraFixModel
from auvdock.vehicle.geometry import rotation_zyx

C0 = 255.0  # the synthetic markers' black (0) to white (255) step, grey levels
SIDES = (12, 14, 16, 18, 20, 23, 26, 30, 35, 40, 50, 65, 85)  # fronto-parallel sides, px
CONTRASTS = (12, 14, 16, 18, 20, 22, 25, 28, 32, 40, 55, 75, 110, 160, 255)  # grey levels
ANGLES = (0.0, 30.0, 50.0)  # obliquities of the grid, deg
SWEEP_ANGLES = (0.0, 20.0, 40.0, 50.0, 55.0, 60.0, 65.0, 70.0, 75.0, 80.0)  # the angle sweep, deg
SWEEP_SIDE = 60  # px (fronto-parallel) of the angle sweep

VIEWS = [  # (vehicle north offset from the dock m, east m, yaw deg)
    (-0.5, 0.0, 0.0), (-1.0, 0.0, 0.0), (-1.5, 0.0, 0.0), (-2.0, 0.0, 0.0), (-2.5, 0.0, 0.0),
    (-3.0, 0.0, 0.0), (-3.5, 0.0, 0.0), (-1.5, 0.8, -15.0), (-1.0, 0.3, 20.0), (-1.6, 1.2, -37.0),
]  # fmt: skip


@dataclass
class Sample:
    """One rendered view of the sweep's marker: its obliquity (deg), apparent side (px: the square root of
    its image area, as :class:`CameraFixModel` measures it), contrast (grey levels), whether it was
    decoded, whether the edge refinement gave up, its corner errors (4, 2), px (edge-refined, or the
    detector's own when the refinement gave up), and their part common to the four corners along their
    directions from the marker's centre (the mean radial error, px: a scale error)."""

    angle_deg: float
    side_px: float
    contrast: float
    decoded: bool
    unrefined: bool
    errors_px: np.ndarray
    radial_px: float = math.nan

    @property
    def short_side_px(self) -> float:
        """The side foreshortened by the obliquity, px: ``side sqrt(cos(obliquity))``."""
        return self.side_px * math.sqrt(math.cos(math.radians(self.angle_deg)))


def sweep_view(
    camera: CameraModel,
    side_nominal: float,
    contrast: float,
    angle_deg: float,
    frames: int,
    rng: np.random.Generator,
    noise: float,
    blur: float,
) -> list[Sample]:
    """``frames`` renderings of the 0.15 m marker with a fronto-parallel side ``side_nominal`` (px),
    turned by ``angle_deg`` about the camera's y axis, with the water that leaves it ``contrast``."""
    layout = MarkerLayout(markers=(Marker(0, 0.15, (0.0, 0.0, 0.0)),))
    marker = layout.markers[0]
    detector = MarkerDetector(layout, camera, refine_edges=False)
    f = float(camera.K[0, 0])
    d = f * marker.size_m / side_nominal
    water = None if contrast >= C0 else Water(VISIBILITY_ATTENUATION * d / math.log(C0 / contrast))
    out = []
    for _ in range(frames):
        offset = rng.uniform(-0.05, 0.05, 2) * d
        roll = math.radians(rng.uniform(-5.0, 5.0))
        # marker frame -> camera: facing the camera (marker z towards it), turned, rolled in its plane
        R_cm = rotation_zyx(0.0, math.radians(angle_deg), 0.0) @ np.diag([1.0, -1.0, -1.0])
        R_cm = R_cm @ rotation_zyx(0.0, 0.0, roll)
        R_cd = R_cm @ marker.R_dm().T
        t_cd = np.array([offset[0], offset[1], d]) - R_cd @ marker.t_dm()
        image = render_view(camera, layout, R_cd, t_cd, noise_std=noise, blur_px=blur, rng=rng, water=water)
        uv = project(camera, marker.corners_dock() @ R_cd.T + t_cd)
        x, y = uv[:, 0], uv[:, 1]
        side = math.sqrt(0.5 * abs(float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))))
        found = detector.detect(image)
        if not found:
            out.append(Sample(angle_deg, side, contrast, False, False, np.full((4, 2), np.nan)))
            continue
        raw = found[0].corners
        refined = refine_corners(image, raw, layout.cells, camera)
        unrefined = bool(np.array_equal(raw, refined))
        radial = uv - uv.mean(axis=0)
        radial /= np.linalg.norm(radial, axis=1, keepdims=True)
        err = refined - uv
        out.append(
            Sample(angle_deg, side, contrast, True, unrefined, err, float(np.mean(np.sum(err * radial, 1))))
        )
    return out


def _crossing(x: np.ndarray, y: np.ndarray, level: float = 0.5) -> float:
    """Where the piecewise-linear y(x) first crosses ``level`` (x sorted), or nan."""
    for i in range(len(x) - 1):
        y0, y1 = y[i], y[i + 1]
        if (y0 - level) * (y1 - level) <= 0 and y0 != y1:
            return float(x[i] + (level - y0) * (x[i + 1] - x[i]) / (y1 - y0))
    return math.nan


def _rms(samples: list[Sample]) -> float:
    e = np.array([s.errors_px for s in samples])
    return float(np.sqrt(np.mean(e**2))) if len(e) else math.nan


def fit_boundary(
    contrast: np.ndarray, side: np.ndarray, success: np.ndarray, powers: tuple[float, ...] | None = None
) -> tuple[float, float, float, float]:
    """Maximum-likelihood fit of ``P(success) = 1 / (1 + u^k)``, ``u = A / contrast + (B / side)^p``
    (grid search): the boundary ``u = 1`` is where half succeed; ``A`` (grey levels) is the limit for
    large sides, ``B`` (px) for high contrasts, ``p`` how the two combine (from ``powers``, default
    1-20), ``k`` the steepness.  Returns (A, B, p, k)."""
    cells: dict[tuple[float, float], list[int]] = {}
    for c, s, ok in zip(contrast, side, success, strict=True):
        key = (float(c), round(float(s), 1))
        cells.setdefault(key, [0, 0])
        cells[key][0] += int(ok)
        cells[key][1] += 1
    cs = np.array([k[0] for k in cells])
    ss = np.array([k[1] for k in cells])
    n_ok = np.array([v[0] for v in cells.values()], dtype=float)
    n = np.array([v[1] for v in cells.values()], dtype=float)
    best = (math.inf, 0.0, 0.0, 0.0, 0.0)
    A_grid, B_grid = np.arange(10.0, 45.01, 0.5), np.arange(6.0, 40.01, 0.5)
    p_grid = np.array(
        powers or (1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 10.0, 12.0, 14.0, 16.0, 20.0)
    )
    k_grid = np.array([2.0, 3.0, 4.0, 6.0, 8.0, 10.0, 13.0, 16.0, 20.0, 25.0, 32.0, 40.0])
    for p in p_grid:
        side_term = (B_grid[:, None] / ss[None, :]) ** p  # (nB, cells)
        u = A_grid[:, None, None] / cs[None, None, :] + side_term[None, :, :]  # (nA, nB, cells)
        log_u = np.log(u)
        for k in k_grid:
            # P = 1 / (1 + u^k): log P = -log1p(u^k), log(1 - P) = k log u - log1p(u^k)
            lp = -np.logaddexp(0.0, k * log_u)
            lq = k * log_u + lp
            nll = -(n_ok * lp + (n - n_ok) * lq).sum(axis=2)
            i = np.unravel_index(int(np.argmin(nll)), nll.shape)
            if nll[i] < best[0]:
                best = (float(nll[i]), float(A_grid[i[0]]), float(B_grid[i[1]]), float(p), float(k))
    return best[1], best[2], best[3], best[4]


def run_sweep(frames: int, noise: float, blur: float, seed: int = 0) -> dict[str, float]:
    """The sweep and the fit (see the module docstring); prints its tables and returns the constants."""
    camera = CameraModel.ideal()
    rng = np.random.default_rng(seed)
    t0 = time.perf_counter()
    grid: dict[tuple[float, int, int], list[Sample]] = {}
    for a in ANGLES:
        for s in SIDES:
            for c in CONTRASTS:
                grid[(a, s, c)] = sweep_view(camera, s, c, a, frames, rng, noise, blur)
    angle_sweep = {
        (a, c): sweep_view(camera, SWEEP_SIDE, c, a, 2 * frames, rng, noise, blur)
        for a in SWEEP_ANGLES
        for c in (255, 55)
    }
    print(
        f"sweep: {len(grid) * frames + len(angle_sweep) * 2 * frames} rendered views of one 0.15 m marker "
        f"(noise {noise:g} grey levels, blur {blur:g} px) in {time.perf_counter() - t0:.0f} s"
    )
    for a in ANGLES:
        print(f"\nobliquity {a:g} deg: decoded fraction / corner RMS error px ('u': mostly unrefined)")
        print("side px \\ contrast " + "".join(f"{c:>11d}" for c in CONTRASTS))
        for s in SIDES:
            cells = []
            for c in CONTRASTS:
                got = [x for x in grid[(a, s, c)] if x.decoded]
                rate = len(got) / frames
                if not got:
                    cells.append(f"{rate:>5.1f}/    -")
                    continue
                unref = np.mean([x.unrefined for x in got]) > 0.5
                cells.append(f"{rate:>5.1f}/{_rms(got):.3f}{'u' if unref else ' '}")
            side = np.mean([x.side_px for x in grid[(a, s, CONTRASTS[-1])]])
            print(f"{side:>7.1f}            " + "".join(f"{c:>11s}" for c in cells))

    every = [x for xs in grid.values() for x in xs]
    # -- detection: contrast and size together (obliquity through the apparent side)
    A, B, p, k = fit_boundary(
        np.array([x.contrast for x in every]),
        np.array([x.side_px for x in every]),
        np.array([x.decoded for x in every]),
    )
    print(
        f"\ndecoded: P = 1 / (1 + u^{k:g}), u = {A:g} / contrast + ({B:g} px / side)^{p:g} "
        "(maximum likelihood over the grid)"
    )
    angles = np.array(SWEEP_ANGLES)
    rate_a = np.array([np.mean([x.decoded for x in angle_sweep[(a, 255)]]) for a in SWEEP_ANGLES])
    max_angle = _crossing(angles, rate_a)

    # -- corners: noise over contrast, small markers, the refinement's limits
    decoded = [x for x in every if x.decoded]
    refined = [x for x in decoded if not x.unrefined]
    well = [x for x in refined if x.short_side_px >= 40.0 and x.angle_deg <= 30.0]
    by_c: dict[float, list[Sample]] = {}
    for x in well:
        by_c.setdefault(x.contrast, []).append(x)
    per_c = [(c, _rms(xs)) for c, xs in sorted(by_c.items()) if len(xs) >= frames]
    corner_px = float(np.median([r * c / C0 for c, r in per_c]))
    print("well-resolved (short side >= 40 px, <= 30 deg), edge-refined corners: RMS error x C / C0, px:")
    print("  " + "  ".join(f"{c:g}:{r * c / C0:.4f}" for c, r in per_c))

    fit_rows = []
    for (a, _, _), xs in grid.items():
        got = [x for x in xs if x.decoded and not x.unrefined]
        if a > 30.0:  # obliquity has its own error (the angle sweep)
            continue
        if len(got) < max(3, frames // 2):
            continue
        s_short = float(np.mean([x.short_side_px for x in got]))
        extra2 = _rms(got) ** 2 - (corner_px * C0 / got[0].contrast) ** 2
        if 10.0 <= s_short <= 35.0 and extra2 > 0:
            fit_rows.append((math.log(16.0 / s_short), 0.5 * math.log(extra2)))
    X = np.array([[1.0, r[0]] for r in fit_rows])
    y = np.array([r[1] for r in fit_rows])
    (log_small, small_power), *_ = np.linalg.lstsq(X, y, rcond=None)
    small_px = math.exp(log_small)

    # the power fixed at 1 (the simplest form): a free power went to the grid's smallest (0.5, with
    # 12.5 grey levels and 7.5 px) and put the boundary within 2 grey levels of this one at 16-60 px
    Ar, Br, pr, kr = fit_boundary(
        np.array([x.contrast for x in decoded]),
        np.array([x.short_side_px for x in decoded]),
        np.array([not x.unrefined for x in decoded]),
        powers=(1.0,),
    )
    print(
        f"edge-refined (of the decoded): P = 1 / (1 + u^{kr:g}), u = {Ar:g} / contrast + "
        f"({Br:g} px / short side)^{pr:g}"
    )
    unrefined_px = _rms([x for x in decoded if x.unrefined])

    def radial_share(xs: list[Sample]) -> float:
        """The share of the corner error variance that is a radial displacement common to the four
        corners: errors ``e_k = delta r_k + n_k`` (``r_k`` the unit radial directions, ``n`` independent
        of std ``s`` per coordinate) have ``mean(e^2) = delta^2 / 2 + s^2`` and a mean radial error of
        mean square ``delta^2 + s^2 / 4``, whence ``(delta^2 / 2) / mean(e^2)``."""
        tot = float(np.mean([np.mean(x.errors_px**2) for x in xs]))
        rad2 = float(np.mean([x.radial_px**2 for x in xs]))
        return (4.0 / 7.0) * (rad2 / tot - 0.25)

    unrefined_share = radial_share([x for x in decoded if x.unrefined])
    small_share = radial_share(
        [x for x in refined if x.angle_deg <= 30.0 and x.short_side_px <= 23.0 and x.contrast >= 110]
    )
    well_share = radial_share([x for x in well])
    print(
        "radial share of the corner error (the part common to the 4 corners along their directions from "
        f"the centre; 0 for independent noise): unrefined {unrefined_share:.2f}, small refined "
        f"(short side <= 23 px, contrast >= 110) {small_share:.2f}, well-resolved {well_share:.2f}"
    )

    rms_a = np.array([_rms([x for x in angle_sweep[(a, 255)] if x.decoded]) for a in SWEEP_ANGLES])
    share = (rms_a**2 - corner_px**2) / (unrefined_px**2 - corner_px**2)  # the share of unrefined-like
    # the rise, up to the first angle past one half (beyond, fewer markers are decoded, and those a
    # little better than unrefined corners on average)
    last = int(np.argmax(share > 0.5)) if np.any(share > 0.5) else len(share) - 1
    keep = (share > 0.001) & (np.arange(len(share)) <= last)
    slope, icpt = np.polyfit(angles[keep], np.log(share[keep] / (1 - share[keep])), 1)
    print(f"\nangle sweep (fronto-parallel side {SWEEP_SIDE} px): decoded fraction / corner RMS px")
    for c in (255, 55):
        print(
            f"  {c:>3d}: "
            + "  ".join(
                f"{a:g}:{np.mean([x.decoded for x in angle_sweep[(a, c)]]):.2f}/"
                f"{_rms([x for x in angle_sweep[(a, c)] if x.decoded]):.3f}"
                for a in SWEEP_ANGLES
            )
        )
    fitted = {
        "min_contrast_grey": A,
        "min_side_px": B,
        "size_power": p,
        "detect_steepness": k,
        "max_view_angle_deg": max_angle,
        "corner_px": corner_px,
        "small_px": small_px,
        "small_power": float(small_power),
        "unrefined_corner_px": unrefined_px,
        "unrefined_radial_share": unrefined_share,
        "small_radial_share": small_share,
        "refine_contrast_grey": Ar,
        "refine_side_px": Br,
        "refine_size_power": pr,
        "refine_steepness": kr,
        "refine_max_angle_deg": float(-icpt / slope),
        "refine_angle_width_deg": float(1.0 / slope),
    }
    print(
        f"\nfitted constants (CameraFixModel; python benchmarks/camera_fix_errors.py --frames {frames} "
        f"--noise {noise:g} --blur {blur:g}, seed {seed}):"
    )
    for key, v in fitted.items():
        print(f"  {key:<24} {v:8.4f}")
    return fitted


def _look(n: float, e: float) -> float:
    """Yaw (rad) that points the vehicle at (n, e) to the dock's big marker (0.35 m ahead of the dock)."""
    return math.atan2(-e, 0.35 - n)


def approaches(poses: int) -> dict[str, list[np.ndarray]]:
    """The trajectories of ``tests/test_camera_rendered.py``: vehicle poses eta (6,) around the dock at
    the origin, heading north: straight approaches on the axis, offset (0.3 m east, 0.1 m deep, looking
    ahead), and aimed from 0.6 m west (looking at the dock), and a pass across the dock 1.6 m in front
    of it, looking at it (obliquities up to ~45 deg)."""
    out: dict[str, list[np.ndarray]] = {"axis": [], "offset": [], "aimed": [], "pass": []}
    for n in np.linspace(-4.0, -0.3, poses):
        out["axis"].append(np.array([n, 0.0, 0.0, 0.0, 0.0, 0.0]))
    for n in np.linspace(-4.0, -0.4, poses):
        out["offset"].append(np.array([n, 0.3, 0.1, 0.0, 0.0, 0.0]))
    for n in np.linspace(-3.5, -0.8, poses):
        out["aimed"].append(np.array([n, -0.6, 0.0, 0.0, 0.0, _look(n, -0.6)]))
    for e in np.linspace(-1.8, 1.8, poses):
        out["pass"].append(np.array([-1.6, e, 0.0, 0.0, 0.0, _look(-1.6, e)]))
    return out


def _fmt(v: np.ndarray) -> str:
    return "/".join("-" if not np.isfinite(x) else f"{x:.1f}" if x < 100 else f"{x:.0f}" for x in v)


def run_tables(visibilities: list[float], frames: int, noise: float, blur: float, seed: int = 1) -> None:
    """Per visibility: the pipeline on the dock's layout at several views and along the approaches,
    beside the fast model (its defaults)."""
    camera, mount, layout = CameraModel.ideal(), CameraMount(), default_layout()
    detector = MarkerDetector(layout, camera)
    rng = np.random.default_rng(seed)
    dock = np.zeros(3)
    for V in visibilities:
        water = Water(V)
        model = CameraFixModel(camera, mount, layout, visibility_m=V, dropout=0.0)
        print(
            f"\n=== visibility {V:g} m (c = {water.attenuation_per_m:.2f} /m; the model decodes large "
            f"markers out to {model.max_range_m:.2f} m)"
        )
        print(
            f"{'view (n, e, yaw)':<20} {'range':>5} {'C':>5} {'fixes':>6} {'pipeline RMS x/y/z mm':>22} "
            f"{'model sd x/y/z mm':>20} {'pipe ids':>10} {'model ids':>10}  model why-not (marker 0)"
        )
        for n, e, yaw in VIEWS:
            eta = np.array([n, e, 0.0, 0.0, 0.0, math.radians(yaw)])
            R_cd, t_cd = camera_from_dock(eta, dock, 0.0, mount)
            errors, ids = [], set()
            for _ in range(frames):
                image = render_view(
                    camera, layout, R_cd, t_cd, noise_std=noise, blur_px=blur, rng=rng, water=water
                )
                pose = estimate_dock_pose(detector.detect(image), layout, camera)
                if pose is not None:
                    errors.append(pose.t_cd - t_cd)
                    ids.update(pose.markers_used)
            views = model.views(eta, dock, 0.0)
            cov = model.covariance_camera(views)
            sd_model = np.sqrt(np.diag(cov)) * 1e3 if cov is not None else np.full(3, np.nan)
            rms = np.sqrt(np.mean(np.square(errors), axis=0)) * 1e3 if errors else np.full(3, np.nan)
            v0 = views[0]
            print(
                f"{f'({n:g}, {e:g}, {yaw:g})':<20} {v0.range_m:>5.2f} {v0.contrast_grey:>5.0f} "
                f"{len(errors):>3}/{frames:<2} {_fmt(rms):>22} {_fmt(sd_model):>20} "
                f"{str(sorted(ids)):>10} {str([v.marker_id for v in model.fused(views)]):>10}  {v0.why}"
            )
        # along the approaches: the fix rate, and the pipeline's errors over the model's std per pose
        print(
            f"approaches ({frames} frames at each of 25 poses): fix rate pipeline/model; "
            "RMS of error / model sd"
        )
        print(
            f"{'':<8} {'fixes':>12} {'lateral':>8} {'range':>8} {'outliers':>9}   (outliers: |error| > 5 sd)"
        )
        for name, etas in approaches(25).items():
            z, n_pipe, n_model = [], 0, 0
            for eta in etas:
                R_cd, t_cd = camera_from_dock(eta, dock, 0.0, mount)
                cov = model.covariance_camera(model.views(eta, dock, 0.0))
                for _ in range(frames):
                    image = render_view(
                        camera, layout, R_cd, t_cd, noise_std=noise, blur_px=blur, rng=rng, water=water
                    )
                    pose = estimate_dock_pose(detector.detect(image), layout, camera)
                    n_pipe += pose is not None
                    n_model += cov is not None
                    if pose is not None and cov is not None:
                        z.append((pose.t_cd - t_cd) / np.sqrt(np.diag(cov)))
            total = len(etas) * frames
            za = np.array(z).reshape(-1, 3)
            bad = np.any(np.abs(za) > 5.0, axis=1)
            good = za[~bad]
            lat = math.sqrt(float(np.mean(good[:, :2] ** 2))) if len(good) else math.nan
            rng_ = math.sqrt(float(np.mean(good[:, 2] ** 2))) if len(good) else math.nan
            print(
                f"{name:<8} {n_pipe / total:>5.2f}/{n_model / total:<5.2f} {lat:>8.2f} {rng_:>8.2f} "
                f"{bad.mean() if len(bad) else 0.0:>9.3f}"
            )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=10, help="renderings per view")
    ap.add_argument("--visibility", type=float, nargs="*", default=[2.0, 5.0, 8.0], help="m; one table each")
    ap.add_argument("--noise", type=float, default=2.0, help="image noise std, grey levels")
    ap.add_argument("--blur", type=float, default=0.5, help="Gaussian blur sigma, px")
    ap.add_argument("--no-sweep", action="store_true", help="skip the sweep and the fit")
    ap.add_argument("--no-tables", action="store_true", help="skip the tables per visibility")
    args = ap.parse_args()
    if not args.no_sweep:
        run_sweep(args.frames, args.noise, args.blur)
    if not args.no_tables:
        run_tables(args.visibility, args.frames, args.noise, args.blur)


if __name__ == "__main__":
    main()
