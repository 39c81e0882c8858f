"""Regenerate the README gallery (docs/gallery/*.png, *.gif) from the engine.

.venv/bin/python docs/make_gallery.py        # about a minute on 2 cores
"""

from __future__ import annotations

import math
import tempfile
import time
from pathlib import Path

import rattlesweep as rs
from rattlesweep import Sweep, run_sweep, stability
from rattlesweep.planar import PlanarBody, simulate_planar
from rattlesweep.plot import animate, contact_path, reversal_map, stability_map, time_series
from rattlesweep.sweep import DEMO_TOML

OUT = Path(__file__).parent / "gallery"
DPI = 80


def main() -> None:
    OUT.mkdir(exist_ok=True)
    start = time.perf_counter()
    kl = rs.Body.preset("kane_levinson")
    fast = rs.simulate(kl, spin=5.0, roll_deg=0.5, mu=0.3, t_end=10.0)
    time_series(fast, title="kane_levinson, +5 rad/s, μ = 0.3 (orange: slipping)").savefig(
        OUT / "time_series.png", dpi=DPI
    )
    contact_path(
        [rs.simulate(kl, spin=s, roll_deg=0.5, t_end=8.0) for s in (5.0, -5.0)],
        ["spin +5 rad/s (reverses)", "spin -5 rad/s"],
        title="contact point over the body, rolling",
    ).savefig(OUT / "contact_path.png", dpi=DPI)
    animate(
        rs.simulate(kl, spin=5.0, roll_deg=0.5, mu=0.3, t_end=8.0),
        OUT / "reversal.gif",
        frames=80,
        fps=10,
        dpi=60,
    )
    planar = simulate_planar(PlanarBody(0.10, 0.05, 1.0), theta=0.6, mu=0.2, t_end=3.0)
    time_series(planar, title="rocking semi-ellipse, μ = 0.2").savefig(
        OUT / "planar.png", dpi=DPI
    )
    with tempfile.TemporaryDirectory() as tmp:
        demo = Sweep.from_toml(DEMO_TOML)
        sim = run_sweep(demo, Path(tmp) / "demo", progress=False)
        reversal_map(sim, x="launch_spin", y="delta_deg", facet="mu").savefig(
            OUT / "reversal_map.png", dpi=DPI
        )
        reversal_map(
            sim,
            x="launch_spin",
            y="delta_deg",
            var="computed",
            facet="mu",
            title=f"{sim.attrs['points_simulated']} of {sim.computed.size} points "
            "simulated",
        ).savefig(OUT / "refinement.png", dpi=DPI)
        reversal_map(
            sim, x="launch_spin", y="delta_deg", var="first_reversal_time", facet="mu"
        ).savefig(OUT / "reversal_time.png", dpi=DPI)
        stability_map(
            stability.stability_dataset(demo),
            x="launch_spin",
            y="delta_deg",
            select={"mu": math.inf},
            overlay=sim.sel(mu=[math.inf]),
            title="linear growth rate, simulated reversals (rolling)",
        ).savefig(OUT / "stability_map.png", dpi=DPI)
    for path in sorted(OUT.iterdir()):
        print(f"{path.name}: {path.stat().st_size / 1e3:.0f} kB")
    print(f"{time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
