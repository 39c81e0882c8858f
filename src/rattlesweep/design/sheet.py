"""The placement sheet: the flat face at 1:1 scale with the pockets and coins, as PNG
and PDF (the figure's size in inches is the real size, so printing it at 100 % gives
millimetres on paper)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .mass import Part

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["MM_PER_INCH", "placement_sheet", "write_sheet"]

MM_PER_INCH = 25.4
_MARGIN = 12.0  # mm of paper around the face
_TEXT = 34.0  # mm of paper below the face for the legend
_HEADER = 12.0  # mm of paper above the face for the warning of a design not robust
_SCALE_BAR = 50.0  # mm


def placement_sheet(part: Part, prefer: str, not_robust: str | None = None) -> "Figure":
    """The sheet as a matplotlib figure whose size in inches is the drawing's real size:
    the flat face seen from above (the rattleback resting on its curved side), its
    pockets and coins, the coin centres in mm from the face's centre (each written
    outside the face, on the coin's side, with a leader line), a 50 mm scale bar to check
    the print's scale and the preferred sense of spin. ``not_robust``: a line saying why
    the design is not robust, printed in red above the face and framed in red."""
    from matplotlib.figure import Figure
    from matplotlib.patches import Circle, Ellipse, Rectangle

    a, b = part.a * 1e3, part.b * 1e3
    width = max(2 * a, _SCALE_BAR + 60.0) + 2 * _MARGIN
    height = 2 * b + 2 * _MARGIN + _TEXT + _HEADER
    fig = Figure(figsize=(width / MM_PER_INCH, height / MM_PER_INCH))
    ax = fig.add_axes((0.0, 0.0, 1.0, 1.0))
    y0 = (_TEXT - _HEADER) / 2  # centre of the face, mm above the middle of the sheet
    ax.set_xlim(-width / 2, width / 2)
    ax.set_ylim(-height / 2, height / 2)
    ax.set_aspect("equal")
    ax.axis("off")
    ax.add_patch(Ellipse((0, y0), 2 * a, 2 * b, fill=False, lw=0.8, color="k"))
    ax.plot([-a - 3, a + 3], [y0, y0], color="0.6", lw=0.4, ls="--")
    ax.plot([0, 0], [y0 - b - 3, y0 + b + 3], color="0.6", lw=0.4, ls="--")
    ax.text(a + 1, y0 + 1, "x", fontsize=7, color="0.4")
    ax.text(1, y0 + b + 1, "y", fontsize=7, color="0.4")
    r_pocket, r_coin = part.pocket_radius * 1e3, part.coin.diameter / 2 * 1e3
    for i, (x, y) in enumerate(part.pockets):
        x, y = x * 1e3, y * 1e3
        ax.add_patch(Circle((x, y0 + y), r_pocket, fill=False, lw=0.5, ls=":", color="k"))
        ax.add_patch(Circle((x, y0 + y), r_coin, color="#d4a017", alpha=0.45, lw=0.6))
        if part.coin.inner_diameter > 0:
            ax.add_patch(
                Circle(
                    (x, y0 + y), part.coin.inner_diameter / 2 * 1e3, color="white", lw=0.4
                )
            )
        ax.plot([x - 2, x + 2], [y0 + y, y0 + y], color="k", lw=0.5)
        ax.plot([x, x], [y0 + y - 2, y0 + y + 2], color="k", lw=0.5)
        # outside the face on the coin's side, so the text never crosses the outline
        side = 1.0 if y > 0 else -1.0
        y_text = y0 + side * (b + 3.0)
        ax.plot([x, x], [y0 + y + side * r_coin, y_text - side * 0.8], color="0.5", lw=0.4)
        ax.text(
            x,
            y_text,
            f"coin centre ({x:+.1f}, {y:+.1f}) mm",
            fontsize=6,
            ha="center",
            va="bottom" if side > 0 else "top",
        )
    # preferred sense: an arc arrow seen from above (angles grow counter-clockwise)
    sign = 1.0 if prefer == "ccw" else -1.0
    rr = min(6.0, 0.3 * b)
    ang = 0.5 * math.pi + sign * np.linspace(0.0, 1.5 * math.pi, 40)
    ax.plot(rr * np.cos(ang[:-1]), y0 + rr * np.sin(ang[:-1]), color="tab:blue", lw=0.8)
    ax.annotate(
        "",
        xy=(rr * math.cos(ang[-1]), y0 + rr * math.sin(ang[-1])),
        xytext=(rr * math.cos(ang[-4]), y0 + rr * math.sin(ang[-4])),
        arrowprops={"arrowstyle": "-|>", "color": "tab:blue", "lw": 0.8},
    )
    yt = -height / 2 + _TEXT - 6
    coin = part.coin
    lines = [
        f"rattlesweep placement sheet, 1:1: print at 100 % (the bar is {_SCALE_BAR:g} mm).",
        "Flat face seen from above, x along the long axis; blue arrow: the sense it "
        f"spins on ({'counter-' if sign > 0 else ''}clockwise).",
        f"2 x {coin.name}: {coin.mass * 1e3:.3g} g, {coin.diameter * 1e3:.4g} mm across, "
        f"{coin.thickness * 1e3:.3g} mm thick; pockets {2 * r_pocket:.4g} mm across, "
        f"{coin.thickness * 1e3:.3g} mm deep.",
    ]
    for i, line in enumerate(lines):
        ax.text(-width / 2 + _MARGIN, yt - 4 * i, line, fontsize=5.5, va="top")
    if not_robust:
        ax.text(
            0,
            height / 2 - 3,
            not_robust,
            fontsize=7,
            color="red",
            fontweight="bold",
            ha="center",
            va="top",
        )
        ax.add_patch(
            Rectangle(
                (-width / 2 + 1, -height / 2 + 1),
                width - 2,
                height - 2,
                fill=False,
                color="red",
                lw=2.0,
            )
        )
    xb, yb = -width / 2 + _MARGIN, -height / 2 + 6
    ax.plot([xb, xb + _SCALE_BAR], [yb, yb], color="k", lw=1.0)
    for xt in (xb, xb + _SCALE_BAR):
        ax.plot([xt, xt], [yb - 1.5, yb + 1.5], color="k", lw=1.0)
    ax.text(xb + _SCALE_BAR + 3, yb, f"{_SCALE_BAR:g} mm", fontsize=6, va="center")
    return fig


def write_sheet(
    part: Part, prefer: str, directory: Path, dpi: int = 300, not_robust: str | None = None
) -> tuple[Path, Path]:
    """Write ``placement_sheet.png`` (``dpi`` recorded in the file) and
    ``placement_sheet.pdf`` into ``directory``; returns their paths."""
    fig = placement_sheet(part, prefer, not_robust)
    png, pdf = directory / "placement_sheet.png", directory / "placement_sheet.pdf"
    fig.savefig(png, dpi=dpi)
    fig.savefig(pdf)
    return png, pdf
