"""Pictures that pass a look: rendered at the default and a high dpi, no text overlaps
another or a legend and none leaves the figure (text bounding boxes from the renderer);
log-spaced axes on log scales; labels in human units; panels that are compared share
their scales; an animation whose contact point and spin arrow read at a glance, for
planar runs too, and that plays inline."""

import math

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.text import Text

import rattlesweep as rs
from rattlesweep.planar import PlanarBody, simulate_planar
from rattlesweep.plot import (
    animate,
    animate_inline,
    contact_path,
    reversal_map,
    reversal_vs_growth,
    spin_history,
    stability_map,
    time_series,
)
from rattlesweep.plot.animation import _scene
from rattlesweep.sweep import Sweep, run_sweep

from figure_checks import layout_problems

DPIS = (80.0, 100.0, 300.0)  # the gallery's, matplotlib's default, a print's
CF_STRINGS = ("rad s-1", "m s-1", "mu = inf", "degree]")


@pytest.fixture(scope="module")
def sweeps(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("layout")
    grid = Sweep(
        axes={
            "spin": {"start": -20, "stop": 20, "num": 5},
            "delta_deg": {"start": -6, "stop": 6, "num": 3},
            "mu": [0.3, math.inf],
        },
        fixed={"t_end": 1.5, "roll_deg": 0.5},
    )
    logs = Sweep(
        axes={
            "spin": {"start": -20, "stop": 20, "num": 5},
            "damping": {"start": 1e-7, "stop": 1e-4, "num": 4, "scale": "log"},
        },
        fixed={"t_end": 1.5, "roll_deg": 0.5},
    )
    return (
        run_sweep(grid, tmp / "grid", progress=False),
        run_sweep(logs, tmp / "logs", progress=False),
        rs.stability.stability_dataset(grid),
    )


def _texts(fig):
    FigureCanvasAgg(fig).draw()
    return [t.get_text() for t in fig.findobj(Text) if t.get_text()]


def _clean(fig):
    for dpi in DPIS:
        problems = layout_problems(fig, dpi)
        assert not problems, "\n".join(problems)
    shown = " | ".join(_texts(fig))
    for cf in CF_STRINGS:
        assert cf not in shown, cf


def test_maps_are_clean_with_human_units(sweeps):
    grid, logs, stab = sweeps
    fig = reversal_map(grid, "launch_spin", "delta_deg", facet="mu")
    _clean(fig)
    panels = [ax for ax in fig.axes if ax.get_visible()]
    assert panels[0].get_xlabel() == "initial spin about the vertical [rad/s]"
    assert [ax.get_title() for ax in panels] == ["μ = 0.3", "μ = ∞ (rolling)"]
    assert "roll = 0.5°" in fig.get_suptitle()
    # a legend beside the panels, clear of the title, with a title of many values
    fig = reversal_map(logs, "launch_spin", "damping")
    _clean(fig)
    fig = reversal_map(grid, "launch_spin", "delta_deg", "first_reversal_time", facet="mu")
    _clean(fig)
    assert fig.axes[-1].get_ylabel().endswith("[s]")  # the colour bar, whole
    _clean(
        stability_map(stab, "launch_spin", "delta_deg", overlay=grid, select={"mu": 0.3})
    )


def test_log_spaced_axes_are_drawn_on_log_scales(sweeps):
    grid, logs, _ = sweeps
    ax = reversal_map(logs, "launch_spin", "damping").axes[0]
    assert ax.get_yscale() == "log" and ax.get_xscale() == "linear"
    lo, hi = ax.get_ylim()
    # each of the 4 cells spans the same factor, 10 (edges at the geometric midpoints)
    assert hi / lo == pytest.approx(10.0**4, rel=1e-6)
    ax = reversal_map(logs, "damping", "launch_spin", "max_tilt").axes[0]
    assert ax.get_xscale() == "log" and ax.get_yscale() == "linear"
    assert (
        reversal_map(grid, "launch_spin", "delta_deg", facet="mu").axes[0].get_yscale()
        == "linear"
    )


def test_predicted_against_simulated_has_readable_log_ticks(sweeps):
    grid, _, stab = sweeps
    for color_by in ("launch_spin", "delta_deg", None):
        fig = reversal_vs_growth(stab, grid, color_by=color_by)
        _clean(fig)
        ax = fig.axes[0]
        assert ax.get_xscale() == ax.get_yscale() == "log"
        FigureCanvasAgg(fig).draw()
        shown = [t.get_text() for t in ax.get_xticklabels() if t.get_text()]
        assert shown and all("times" not in t for t in shown)  # plain numbers


def test_run_pictures_are_clean_and_contact_paths_share_scales(kl):
    run = rs.simulate(kl, spin=5.0, roll_deg=0.5, mu=0.3, t_end=3.0)
    other = rs.simulate(kl, spin=-5.0, roll_deg=0.5, t_end=3.0)
    # a title as long as the figure is wide, next to the slipping/sticking legend
    _clean(time_series(run, title="kane_levinson, +5 rad/s, μ = 0.3 (orange: slipping)"))
    _clean(spin_history([run, other], ["+5", "-5"], title="two senses"))
    for frame in ("body", "floor"):
        fig = contact_path([run, other], ["+5 rad/s", "-5 rad/s"], frame=frame)
        _clean(fig)
        panels = [ax for ax in fig.axes if ax.get_label() != "<colorbar>"]
        assert panels[0].get_xlim() == panels[1].get_xlim()
        assert panels[0].get_ylim() == panels[1].get_ylim()
    # the -5 rad/s path is a short stroke on the +5 one's scale, not blown up to fill it
    xy = [
        np.ptp(p.get_paths()[0].vertices[:, 0]) if p.get_paths() else 0
        for p in fig.axes[1].collections
    ]
    assert max(xy, default=0) < np.diff(fig.axes[1].get_xlim())[0]


@pytest.mark.parametrize("dpi", [80.0, 200.0])
def test_animation_frame_reads_at_a_glance(kl, dpi):
    toy = rs.Body.preset("toy")
    run = rs.simulate(toy, spin=-3.0, roll_deg=0.5, mu=0.3, t_end=2.0)
    fig, draw = _scene(run, 20, dpi, 25.0, -60.0, None)
    artists = draw(12)
    assert not layout_problems(fig, dpi)
    ax = fig.axes[0]
    assert ax.computed_zorder is False  # drawn in zorder, not by depth
    body = artists[0]
    dot = [
        a
        for a in artists
        if getattr(a, "get_marker", lambda: None)() == "o" and a.get_color() == "#e8000b"
    ][0]
    arrow = artists[-1]
    assert dot.get_zorder() > body.get_zorder() and arrow.get_zorder() > body.get_zorder()
    # the arrow is tens of pixels long (was 5 px), in proportion to the dpi
    pixels = ax.transData.transform(np.concatenate(arrow.get_segments()))  # as projected
    height = np.ptp(pixels[:, 1])
    assert height > 0.5 * dpi, height
    assert dot.get_markersize() >= 7


def test_planar_runs_animate_and_animations_play_inline(tmp_path):
    from PIL import Image

    run = simulate_planar(PlanarBody(0.05, 0.02, 0.1), theta=0.3, mu=0.3, t_end=0.5)
    for dpi in (80.0, 200.0):
        fig, draw = _scene(run, 10, dpi, 25.0, -60.0, None)
        draw(5)
        assert not layout_problems(fig, dpi)
    out = animate(run, tmp_path / "planar.gif", frames=6, fps=5)
    with Image.open(out) as gif:
        assert gif.n_frames == 6
    inline = animate_inline(run, frames=4, fps=4)
    html = inline._repr_html_()
    assert "<script" in html and html.count("data:image/png;base64") == 4
    with pytest.raises(ValueError, match="frames must be an integer"):
        animate_inline(run, frames=0)
    with pytest.raises(ValueError, match="a planar animation needs"):
        animate(run.drop_vars("x_G"), tmp_path / "x.gif")
