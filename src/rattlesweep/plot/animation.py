"""3-D animation of a run: the body on the floor, the contact point and the spin arrow,
saved as GIF (Pillow, always there with matplotlib) or MP4 (needs ffmpeg)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

__all__ = ["WRITERS", "animate"]

WRITERS = {".gif": "pillow", ".mp4": "ffmpeg"}


def _surface(a: float, b: float, c: float, full: bool, n_u: int = 28, n_v: int = 10
             ) -> np.ndarray:
    """Body-frame mesh (3, n_v, n_u) of the curved surface (the lower half unless full)."""
    u = np.linspace(0.0, 2.0 * np.pi, n_u)
    v = np.linspace(0.0 if full else 0.5 * np.pi, np.pi, n_v)
    return np.stack([a * np.outer(np.sin(v), np.cos(u)), b * np.outer(np.sin(v), np.sin(u)),
                     c * np.outer(np.cos(v), np.ones_like(u))])


def animate(run: xr.Dataset, path: str | os.PathLike, *, frames: int = 100,
            fps: float = 20.0, dpi: int = 80, elev: float = 25.0,
            azim: float = -60.0, z_stretch: float | None = None) -> Path:
    """Write a 3-D animation of a :func:`rattlesweep.simulate` run to ``path``.

    The file has exactly ``frames`` frames, evenly spaced over the recorded samples, and
    plays at ``fps`` frames per second. The suffix picks the format: ``.gif`` (Pillow) or
    ``.mp4`` (ffmpeg, when installed). Drawn: the body (its curved surface, and the flat
    face's rim with a mark at the +x end), the floor with the contact point's trace, the
    contact point (red) and, above the body on the vertical through G, an arrow whose
    length and direction follow the spin.
    Axes are world X, Y, Z in metres. ``z_stretch`` draws Z that many times larger than
    X and Y, which makes small tilts visible (the tick labels stay true); by default 1,
    or enough to make the height at least a third of the width for flat bodies, and the
    heading says so. The file is written under a temporary name and renamed when
    complete. Returns the path.
    """
    from matplotlib import animation

    from ..contact import body_geometry, check_run, contact_dataset
    from ..launch import rotation_matrices

    check_run(run)
    path = Path(path)
    writer = WRITERS.get(path.suffix.lower())
    if writer is None:
        raise ValueError(f"path {str(path)!r}: the suffix must be one of {sorted(WRITERS)}")
    if not animation.writers.is_available(writer):
        raise ValueError(f"path {str(path)!r}: writing {path.suffix} needs {writer!r}, which "
                         "is not available here; use a .gif path")
    n_samples = run.sizes["time"]
    if not isinstance(frames, (int, np.integer)) or not 1 <= frames <= n_samples:
        raise ValueError(f"frames must be an integer from 1 to the run's {n_samples} "
                         f"recorded samples, got {frames!r} (record more with "
                         "simulate(..., record_every=...))")
    if not fps > 0:
        raise ValueError(f"fps must be > 0, got {fps!r}")
    if z_stretch is not None and not (np.isfinite(z_stretch) and z_stretch >= 1.0):
        raise ValueError(f"z_stretch must be a finite number >= 1, got {z_stretch!r}")
    if not path.parent.is_dir():
        raise ValueError(f"path {str(path)!r}: directory {str(path.parent)!r} does not exist")

    (a, b, c), com, _ = body_geometry(run)
    full = bool(run.attrs.get("full_ellipsoid", False))
    idx = np.round(np.linspace(0, n_samples - 1, frames)).astype(int)
    sub = run.isel(time=idx)
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
    # the spin arrow stands above the body's highest point, up for + and down for -
    arrow = 1.5 * max(c, 0.5 * b)
    world = np.einsum("kij,jab->kiab", rot, mesh) + pos[:, :, None, None]  # every frame
    top = world[:, 2].max(axis=(1, 2))
    z_hi = float(top.max()) + 1.25 * arrow
    width = max(x_hi - x_lo, y_hi - y_lo)
    if z_stretch is None:
        z_stretch = max(1.0, width / (3.0 * z_hi))
    spin_scale = arrow / max(float(np.abs(spin).max()), 1e-300)

    fig = Figure(figsize=(6.0, 4.5), dpi=dpi)
    ax = fig.add_subplot(projection="3d")
    fig.subplots_adjust(0.0, 0.0, 1.0, 0.93)
    ax.view_init(elev=elev, azim=azim)
    ax.set_xlim(x_lo, x_hi)
    ax.set_ylim(y_lo, y_hi)
    ax.set_zlim(0.0, z_hi)
    ax.set_box_aspect((x_hi - x_lo, y_hi - y_lo, z_stretch * z_hi), zoom=1.1)
    ax.set_xlabel("X [m]")
    ax.set_ylabel("Y [m]")
    ax.set_zlabel("Z [m]")
    fx, fy = np.meshgrid([x_lo, x_hi], [y_lo, y_hi])
    ax.plot_surface(fx, fy, np.zeros_like(fx), color="0.85", alpha=0.5, shade=False)
    floor_track = contact.contact_floor.values
    ax.plot(floor_track[:, 0], floor_track[:, 1], 0.0, color="0.5", lw=0.6)
    name = run.attrs.get("body_name", "body")
    stretch = f", Z drawn x{z_stretch:.3g}" if z_stretch != 1.0 else ""
    fig.text(0.02, 0.915, f"red: contact point; arrow: spin (blue +, red -){stretch}",
             fontsize="x-small")
    heading = fig.text(0.02, 0.955, "", fontsize="small", family="monospace")
    drawn: list[Any] = []

    def draw(k: int) -> list[Any]:
        for artist in drawn:
            artist.remove()
        drawn.clear()
        drawn.append(ax.plot_surface(*world[k], color="#c8a165", edgecolor="#8a6a3a",
                                     lw=0.15, alpha=0.85))
        r = rot[k] @ rim + pos[k][:, None]
        drawn.extend(ax.plot(*r, color="#5a3d1a", lw=1.2))
        tip = rot[k] @ nose + pos[k]
        drawn.extend(ax.plot(*tip[:, None], "o", color="#5a3d1a", ms=3))
        p = floor_track[k]
        drawn.extend(ax.plot([p[0]], [p[1]], [0.0], "o", color="red", ms=4))
        length = spin[k] * spin_scale
        base = top[k] + 0.1 * arrow + max(0.0, -length)
        colour = "#1f77b4" if spin[k] >= 0 else "#d62728"
        drawn.append(ax.quiver(pos[k, 0], pos[k, 1], base, 0.0, 0.0, length,
                               color=colour, lw=2, arrow_length_ratio=0.25))
        # the frame number keeps every frame distinct (GIF writers merge equal frames)
        heading.set_text(f"{name}  t = {t[k]:8.4f} s  spin = {spin[k]:+7.3f} rad/s  "
                         f"[{k + 1}/{frames}]")
        return drawn

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
