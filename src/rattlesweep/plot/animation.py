"""Animation of a run: for a rattleback the body on the floor in 3-D, the contact point
and the spin arrow; for a planar run the rocking lamina on its line. Saved as GIF
(Pillow, always there with matplotlib) or MP4 (needs ffmpeg), or played inline in a
notebook (:func:`animate_inline`, HTML and JavaScript, no file)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Callable

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

__all__ = ["InlineAnimation", "WRITERS", "animate", "animate_inline"]

WRITERS = {".gif": "pillow", ".mp4": "ffmpeg"}


def _surface(
    a: float, b: float, c: float, full: bool, n_u: int = 28, n_v: int = 10
) -> np.ndarray:
    """Body-frame mesh (3, n_v, n_u) of the curved surface (the lower half unless full)."""
    u = np.linspace(0.0, 2.0 * np.pi, n_u)
    v = np.linspace(0.0 if full else 0.5 * np.pi, np.pi, n_v)
    return np.stack(
        [
            a * np.outer(np.sin(v), np.cos(u)),
            b * np.outer(np.sin(v), np.sin(u)),
            c * np.outer(np.cos(v), np.ones_like(u)),
        ]
    )


Draw = Callable[[int], list[Any]]

CONTACT_COLOUR = "#e8000b"


def _check_frames(run: xr.Dataset, frames: object, fps: float) -> None:
    n_samples = run.sizes["time"]
    if not isinstance(frames, (int, np.integer)) or not 1 <= frames <= n_samples:
        raise ValueError(
            f"frames must be an integer from 1 to the run's {n_samples} "
            f"recorded samples, got {frames!r} (record more with "
            "simulate(..., record_every=...))"
        )
    if not fps > 0:
        raise ValueError(f"fps must be > 0, got {fps!r}")


def _check_planar(run: object) -> None:
    if not isinstance(run, xr.Dataset) or "time" not in run.dims:
        raise ValueError(
            "run must be an xarray.Dataset over 'time' (a simulate or "
            f"simulate_planar result, or its file), got {type(run).__name__}"
        )
    for name in ("angle", "rate", "x_G", "y_G"):
        if name not in run:
            raise ValueError(
                f"run has no variable {name!r}; a planar animation needs a "
                "rattlesweep.simulate_planar result (or its netCDF file)"
            )
    for name in ("a", "b", "com_depth"):
        if name not in run.attrs:
            raise ValueError(
                f"run has no attribute {name!r}; a planar animation needs a "
                "rattlesweep.simulate_planar result (or its netCDF file)"
            )


def _scene(
    run: xr.Dataset,
    frames: int,
    dpi: float,
    elev: float,
    azim: float,
    z_stretch: float | None,
) -> tuple[Figure, Draw]:
    """The figure and the function that draws frame k of ``frames`` of a run: the 3-D
    rattleback scene, or the planar one for a :func:`simulate_planar` result."""
    if isinstance(run, xr.Dataset) and "angle" in run and "quaternion" not in run:
        _check_planar(run)
        _check_frames(run, frames, 1.0)
        return _planar_scene(run, frames, dpi)
    from ..rattleback.contact import check_run

    check_run(run)
    _check_frames(run, frames, 1.0)
    return _rattleback_scene(run, frames, dpi, elev, azim, z_stretch)


def _frames(run: xr.Dataset, frames: int) -> np.ndarray:
    n_samples = run.sizes["time"]
    return np.round(np.linspace(0, n_samples - 1, frames)).astype(int)


def _rattleback_scene(
    run: xr.Dataset,
    frames: int,
    dpi: float,
    elev: float,
    azim: float,
    z_stretch: float | None,
) -> tuple[Figure, Draw]:
    from ..rattleback.contact import body_geometry, contact_dataset
    from ..rattleback.launch import rotation_matrices

    (a, b, c), com, _ = body_geometry(run)
    full = bool(run.attrs.get("full_ellipsoid", False))
    sub = run.isel(time=_frames(run, frames))
    contact = contact_dataset(sub)
    rot = rotation_matrices(sub.quaternion.transpose("time", "quaternion_component").values)
    pos = sub.position.transpose("time", "axis").values
    spin = sub.spin.values
    t = sub.time.values
    mesh = _surface(a, b, c, full) - com[:, None, None]
    phi = np.linspace(0.0, 2.0 * np.pi, 73)
    rim = np.stack([a * np.cos(phi), b * np.sin(phi), np.zeros_like(phi)]) - com[:, None]
    nose = np.array([a, 0.0, 0.0]) - com

    reach = 1.15 * max(a, b, c)
    x_lo, x_hi = pos[:, 0].min() - reach, pos[:, 0].max() + reach
    y_lo, y_hi = pos[:, 1].min() - reach, pos[:, 1].max() + reach
    width = max(x_hi - x_lo, y_hi - y_lo)
    # the spin arrow stands above the body's highest point, up for + and down for -; a
    # fifth of the scene long at the largest spin, so that it reads on any body
    arrow = max(1.5 * max(c, 0.5 * b), 0.2 * width)
    world = np.einsum("kij,jab->kiab", rot, mesh) + pos[:, :, None, None]  # every frame
    top = world[:, 2].max(axis=(1, 2))
    z_hi = float(top.max()) + 1.25 * arrow
    if z_stretch is None:
        z_stretch = max(1.0, width / (3.0 * z_hi))
    spin_scale = arrow / max(float(np.abs(spin).max()), 1e-300)

    fig = Figure(figsize=(6.0, 4.8), dpi=dpi)
    ax = fig.add_subplot(projection="3d")
    # the contact point and the arrow are drawn after the body whatever the view, so
    # that they are never hidden behind it (matplotlib's depth sort would)
    ax.computed_zorder = False
    # a margin all round for the axis labels, which grow with the dpi like the rest
    fig.subplots_adjust(0.02, 0.02, 0.9, 0.86)
    ax.view_init(elev=elev, azim=azim)
    ax.set_xlim(x_lo, x_hi)
    ax.set_ylim(y_lo, y_hi)
    ax.set_zlim(0.0, z_hi)
    ax.set_box_aspect((x_hi - x_lo, y_hi - y_lo, z_stretch * z_hi), zoom=1.0)
    ax.set_xlabel("X [m]", fontsize="small", labelpad=6)
    ax.set_ylabel("Y [m]", fontsize="small", labelpad=8)
    ax.set_zlabel("Z [m]", fontsize="small")
    ax.tick_params(labelsize="x-small")
    fx, fy = np.meshgrid([x_lo, x_hi], [y_lo, y_hi])
    ax.plot_surface(
        fx, fy, np.zeros_like(fx), color="0.85", alpha=0.5, shade=False, zorder=0
    )
    floor_track = contact.contact_floor.values
    ax.plot(floor_track[:, 0], floor_track[:, 1], 0.0, color="0.5", lw=0.6, zorder=1)
    name = run.attrs.get("body_name", "body")
    stretch = f", Z drawn x{z_stretch:.3g}" if z_stretch != 1.0 else ""
    fig.text(
        0.02,
        0.905,
        f"red dot: contact point; arrow: spin (blue +, red -){stretch}",
        fontsize="x-small",
    )
    heading = fig.text(0.02, 0.95, "", fontsize="small", family="monospace")
    drawn: list[Any] = []

    def draw(k: int) -> list[Any]:
        for artist in drawn:
            artist.remove()
        drawn.clear()
        drawn.append(
            ax.plot_surface(
                *world[k],
                color="#c8a165",
                edgecolor="#8a6a3a",
                lw=0.15,
                alpha=0.85,
                zorder=2,
            )
        )
        r = rot[k] @ rim + pos[k][:, None]
        drawn.extend(ax.plot(*r, color="#5a3d1a", lw=1.2, zorder=3))
        tip = rot[k] @ nose + pos[k]
        drawn.extend(ax.plot(*tip[:, None], "o", color="#5a3d1a", ms=3, zorder=3))
        p = floor_track[k]
        drawn.extend(
            ax.plot(
                [p[0]],
                [p[1]],
                [0.0],
                "o",
                color=CONTACT_COLOUR,
                ms=7,
                markeredgecolor="white",
                markeredgewidth=1.0,
                zorder=10,
            )
        )
        length = spin[k] * spin_scale
        base = top[k] + 0.1 * arrow + max(0.0, -length)
        colour = "#1f77b4" if spin[k] >= 0 else "#d62728"
        drawn.append(
            ax.quiver(
                pos[k, 0],
                pos[k, 1],
                base,
                0.0,
                0.0,
                length,
                color=colour,
                lw=3,
                arrow_length_ratio=0.3,
                zorder=11,
            )
        )
        # the frame number keeps every frame distinct (GIF writers merge equal frames)
        heading.set_text(
            f"{name}  t = {t[k]:8.4f} s  spin = {spin[k]:+7.3f} rad/s  [{k + 1}/{frames}]"
        )
        return drawn

    return fig, draw


def _planar_scene(run: xr.Dataset, frames: int, dpi: float) -> tuple[Figure, Draw]:
    a, b, d = (float(run.attrs[k]) for k in ("a", "b", "com_depth"))
    sub = run.isel(time=_frames(run, frames))
    theta, rate, t = sub.angle.values, sub.rate.values, sub.time.values
    g = np.stack([sub.x_G.values, sub.y_G.values], axis=1)
    # the outline from G in the body frame (x along the flat edge, y up): the curved
    # edge (y <= 0), then the flat edge back along y = 0
    phi = np.linspace(np.pi, 2.0 * np.pi, 181)
    outline = np.stack([a * np.cos(phi), b * np.sin(phi) + d])
    outline = np.concatenate([outline, outline[:, :1]], axis=1)
    c, s = np.cos(theta), np.sin(theta)
    rot = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)  # (k, 2, 2)
    world = np.einsum("kij,jn->kin", rot, outline) + g[:, :, None]
    contact = world[np.arange(frames), :, np.argmin(world[:, 1], axis=1)]
    reach = 1.15 * max(a, b)
    x_lo, x_hi = float(g[:, 0].min()) - reach, float(g[:, 0].max()) + reach

    fig = Figure(figsize=(6.0, 3.6), dpi=dpi)
    # fixed margins (the heading changes every frame; a layout engine would move the
    # axes with it): room for the tick and axis labels below and left, the heading above
    ax = fig.add_axes((0.13, 0.16, 0.84, 0.64))
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlim(x_lo, x_hi)
    ax.set_ylim(-0.15 * reach, float(world[:, 1].max()) + 0.25 * reach)
    ax.axhline(0.0, color="0.4", lw=1.0)
    ax.set_xlabel("X [m]")
    ax.set_ylabel("height [m]")
    ax.plot(contact[:, 0], contact[:, 1], color="0.5", lw=0.6)
    name = run.attrs.get("body_name", "body")
    heading = fig.text(0.02, 0.93, "", fontsize="small", family="monospace")
    fig.text(0.02, 0.86, "red dot: contact point; +: centre of mass", fontsize="x-small")
    drawn: list[Any] = []

    def draw(k: int) -> list[Any]:
        for artist in drawn:
            artist.remove()
        drawn.clear()
        drawn.extend(
            ax.fill(
                world[k, 0],
                world[k, 1],
                facecolor="#c8a165",
                edgecolor="#5a3d1a",
                lw=1.2,
                zorder=2,
            )
        )
        drawn.extend(ax.plot([g[k, 0]], [g[k, 1]], "+", color="#5a3d1a", ms=8, zorder=3))
        drawn.extend(
            ax.plot(
                [contact[k, 0]],
                [contact[k, 1]],
                "o",
                color=CONTACT_COLOUR,
                ms=7,
                markeredgecolor="white",
                zorder=10,
            )
        )
        heading.set_text(
            f"{name}  t = {t[k]:6.3f} s  angle = {theta[k]:+6.3f} rad  "
            f"rate = {rate[k]:+7.3f} rad/s  [{k + 1}/{frames}]"
        )
        return drawn

    return fig, draw


def animate(
    run: xr.Dataset,
    path: str | os.PathLike,
    *,
    frames: int = 100,
    fps: float = 20.0,
    dpi: int = 80,
    elev: float = 25.0,
    azim: float = -60.0,
    z_stretch: float | None = None,
) -> Path:
    """Write an animation of a :func:`rattlesweep.simulate` run (3-D) or of a
    :func:`rattlesweep.simulate_planar` run (the lamina rocking on its line) to ``path``.

    The file has exactly ``frames`` frames, evenly spaced over the recorded samples, and
    plays at ``fps`` frames per second. The suffix picks the format: ``.gif`` (Pillow) or
    ``.mp4`` (ffmpeg, when installed). Drawn for a rattleback: the body (its curved
    surface, and the flat face's rim with a mark at the +x end), the floor with the
    contact point's trace, the contact point (a red dot, always drawn in front) and,
    above the body on the vertical through G, an arrow whose length (a fifth of the
    scene at the largest spin) and direction follow the spin. Axes are world X, Y, Z
    in metres. ``z_stretch`` draws Z that many times larger than X and Y, which makes
    small tilts visible (the tick labels stay true); by default 1, or enough to make
    the height at least a third of the width for flat bodies, and the heading says so.
    ``elev``, ``azim`` and ``z_stretch`` apply to the 3-D scene only. The file is
    written under a temporary name and renamed when complete. Returns the path.
    """
    from matplotlib import animation

    path = Path(path)
    writer = WRITERS.get(path.suffix.lower())
    if writer is None:
        raise ValueError(f"path {str(path)!r}: the suffix must be one of {sorted(WRITERS)}")
    if not animation.writers.is_available(writer):
        raise ValueError(
            f"path {str(path)!r}: writing {path.suffix} needs {writer!r}, which "
            "is not available here; use a .gif path"
        )
    _check_options(run, frames, fps, z_stretch)
    if not path.parent.is_dir():
        raise ValueError(
            f"path {str(path)!r}: directory {str(path.parent)!r} does not exist"
        )
    fig, draw = _scene(run, frames, dpi, elev, azim, z_stretch)
    anim = animation.FuncAnimation(fig, draw, frames=frames, blit=False)
    tmp = path.with_name(f".{path.name}.tmp{path.suffix}")
    try:
        # matplotlib's stubs say an int, but the writers take any rate (save itself
        # makes a float one from the interval when fps is not given)
        anim.save(tmp, writer=writer, fps=fps, dpi=dpi)  # type: ignore[arg-type]
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path


def _check_options(
    run: xr.Dataset, frames: int, fps: float, z_stretch: float | None
) -> None:
    if isinstance(run, xr.Dataset) and "time" in run.dims:
        _check_frames(run, frames, fps)
    if z_stretch is not None and not (np.isfinite(z_stretch) and z_stretch >= 1.0):
        raise ValueError(f"z_stretch must be a finite number >= 1, got {z_stretch!r}")


class InlineAnimation:
    """An animation that plays in a notebook (Jupyter shows :meth:`_repr_html_`): the
    frames as PNG images in HTML with JavaScript playback controls, made by
    matplotlib's ``to_jshtml``; no file and no ffmpeg. ``html`` holds the markup."""

    def __init__(self, html: str) -> None:
        self.html = html

    def _repr_html_(self) -> str:
        return self.html


def animate_inline(
    run: xr.Dataset,
    *,
    frames: int = 60,
    fps: float = 15.0,
    dpi: int = 72,
    elev: float = 25.0,
    azim: float = -60.0,
    z_stretch: float | None = None,
) -> InlineAnimation:
    """The animation of :func:`animate` for playing inline in a notebook: put
    ``animate_inline(run)`` last in a cell. Fewer frames and a lower dpi by default,
    since every frame is embedded in the notebook (about 30 kB each at dpi 72)."""
    from matplotlib import animation

    _check_options(run, frames, fps, z_stretch)
    fig, draw = _scene(run, frames, dpi, elev, azim, z_stretch)
    anim = animation.FuncAnimation(
        fig, draw, frames=frames, interval=1000.0 / fps, blit=False
    )
    # to_jshtml's stubs say an int rate; it only writes the rate into the page's script
    page = anim.to_jshtml(fps=fps, default_mode="loop")  # type: ignore[arg-type]
    return InlineAnimation(page)
