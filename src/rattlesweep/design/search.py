"""The choice of the coin placement: candidates × launches in one batch, refined.

Every candidate placement (x, y) of the first pocket (the second at (−x, −y)) is
launched as a person would launch it (:class:`Launches`: spins of both senses, small
tilts, friction over the range), all candidates and launches of a level in one
:func:`rattlesweep.run_batch` call, each launch ended at its first reversal. A candidate
is robust when every launch in the bad sense reverses and none in the preferred sense
does, within ``t_end``; the best is the robust candidate whose slowest bad-sense reversal
is quickest (when none is robust: the one with the most launches right). The first
level is a grid over the flat face; each refinement level tries the eight neighbours of
the best so far at half the previous spacing.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import xarray as xr

from ..rattleback.batch import run_batch
from ..rattleback.body import Body
from .constraints import placement_problem
from .mass import Part, body_of
from .printing import require

__all__ = ["Launches", "SearchResult", "bad_sign", "evaluate", "search"]

SENSES = ("ccw", "cw")
"""Spin senses seen from above: counter-clockwise (n > 0) and clockwise (n < 0)."""


def bad_sign(prefer: str) -> float:
    """The sign of the spin n that must reverse when ``prefer`` is the preferred sense."""
    if prefer not in SENSES:
        raise ValueError(
            f"prefer = {prefer!r} is invalid: it must be one of {SENSES} "
            "(the sense, seen from above, in which the rattleback spins on)"
        )
    return 1.0 if prefer == "cw" else -1.0


@dataclass(frozen=True)
class Launches:
    """How a person launches the rattleback, for the search and the checks.

    Parameters
    ----------
    spins : tuple of float
        Spin magnitudes (rad/s); each is launched in both senses.
    tilts : tuple of (roll, pitch)
        Launch tilts (rad), each below 1 degree.
    mu : (float, float)
        Friction range (Coulomb coefficient, static = kinetic); launches use ``n_mu``
        values from low to high.
    n_mu : int
        Number of friction values (2: the ends of the range).
    t_end : float
        Time (s) within which a bad-sense launch must reverse and a preferred-sense
        launch must not.
    """

    spins: tuple[float, ...] = (3.0, 5.0, 7.0, 10.0)
    tilts: tuple[tuple[float, float], ...] = (
        (math.radians(0.8), 0.0),
        (0.0, math.radians(0.8)),
        (math.radians(0.2), math.radians(0.2)),
    )
    mu: tuple[float, float] = (0.2, 0.5)
    n_mu: int = 3
    t_end: float = 15.0

    def __post_init__(self) -> None:
        if not self.spins:
            raise ValueError("spins = () is invalid: give at least one spin (rad/s)")
        spins = tuple(
            require("spins", s, "finite and > 0 (rad/s)", lambda v: v > 0)
            for s in self.spins
        )
        object.__setattr__(self, "spins", spins)
        if not self.tilts:
            raise ValueError("tilts = () is invalid: give at least one (roll, pitch) (rad)")
        for roll, pitch in self.tilts:
            require(
                "tilt",
                math.hypot(roll, pitch),
                "below 1 degree (0.01745 rad)",
                lambda v: v < math.radians(1.0),
            )
        if len(self.mu) != 2:
            raise ValueError(f"mu = {self.mu!r} is invalid: it must be (low, high)")
        low = require("mu low", self.mu[0], "finite and > 0", lambda v: v > 0)
        high = require(
            "mu high", self.mu[1], f"finite and >= mu low ({low!r})", lambda v: v >= low
        )
        object.__setattr__(self, "mu", (low, high))
        n = self.n_mu
        if not (isinstance(n, int) and n >= 1 and (n >= 2 or low == high)):
            raise ValueError(
                f"n_mu = {n!r} is invalid: it must be an integer >= 2 (1 when "
                "mu low equals mu high)"
            )
        require("t_end", self.t_end, "finite and > 0 (s)", lambda v: v > 0)

    @property
    def mus(self) -> np.ndarray:
        """The friction values launched."""
        return (
            np.linspace(self.mu[0], self.mu[1], self.n_mu)
            if self.n_mu > 1
            else np.array([self.mu[0]])
        )

    @property
    def size(self) -> int:
        """Launches per candidate."""
        return 2 * len(self.spins) * len(self.tilts) * self.n_mu

    def describe(self) -> dict[str, object]:
        """Plain-number description (rad/s, degrees, s)."""
        return {
            "spins": list(self.spins),
            "tilts_deg": [[math.degrees(r), math.degrees(p)] for r, p in self.tilts],
            "mu": list(self.mu),
            "n_mu": self.n_mu,
            "t_end": self.t_end,
        }


def evaluate(bodies: list[Body], launches: Launches, prefer: str) -> xr.Dataset:
    """Launch every body in ``bodies`` with every launch, in one batch.

    Returns first reversal times over (candidate, sense, spin, mu, tilt), ``sense``
    "bad" and "good" (the preferred sense), NaN where a launch did not reverse or did not
    end ``ok`` (capsized, lifted off), and per-candidate summaries: ``worst_bad_time``
    (s; inf unless every bad launch reversed), ``bad_reversed`` and ``good_reversed``
    (fractions) and ``robust``.
    """
    sign = bad_sign(prefer)
    spins = np.asarray(launches.spins)
    spin = np.stack([sign * spins, -sign * spins])  # (sense, spin)
    mus = launches.mus
    roll = np.array([t[0] for t in launches.tilts])
    pitch = np.array([t[1] for t in launches.tilts])
    b = np.empty(len(bodies), dtype=object)
    b[:] = bodies
    ds = run_batch(
        b[:, None, None, None, None],
        spin=spin[None, :, :, None, None],
        mu=mus[None, None, None, :, None],
        roll=roll[None, None, None, None, :],
        pitch=pitch[None, None, None, None, :],
        t_end=launches.t_end,
        stop="first_reversal",
    )
    shape = (len(bodies), 2, len(spins), len(mus), len(roll))
    t = ds.first_reversal_time.values.reshape(shape)
    ok = ds.status.values.reshape(shape) == 0
    t = np.where(ok, t, np.nan)
    reversed_ = np.isfinite(t)
    bad, good = (
        reversed_[:, 0].reshape(len(bodies), -1),
        reversed_[:, 1].reshape(len(bodies), -1),
    )
    times = t[:, 0].reshape(len(bodies), -1)
    worst = np.max(np.where(np.isfinite(times), times, np.inf), axis=1)
    out = xr.Dataset(
        {
            "first_reversal_time": (
                ("candidate", "sense", "spin", "mu", "tilt"),
                t,
                {
                    "units": "s",
                    "long_name": "first reversal time (NaN: none within t_end, or not ok)",
                },
            ),
            "worst_bad_time": (
                "candidate",
                worst,
                {
                    "units": "s",
                    "long_name": (
                        "slowest first reversal in the bad sense (inf: some did not)"
                    ),
                },
            ),
            "bad_reversed": (
                "candidate",
                bad.mean(axis=1),
                {"units": "1", "long_name": "fraction of bad-sense launches that reversed"},
            ),
            "good_reversed": (
                "candidate",
                good.mean(axis=1),
                {
                    "units": "1",
                    "long_name": "fraction of preferred-sense launches that reversed",
                },
            ),
        },
        coords={
            "sense": (
                "sense",
                ["bad", "good"],
                {
                    "long_name": "sense of the launch "
                    "spin: bad (must reverse) or good (the preferred sense)"
                },
            ),
            "spin": ("spin", spins, {"units": "rad s-1", "long_name": "spin magnitude"}),
            "mu": ("mu", mus, {"units": "1", "long_name": "friction coefficient"}),
            "tilt": [
                f"roll {math.degrees(r):.2g} deg, pitch {math.degrees(p):.2g} deg"
                for r, p in launches.tilts
            ],
        },
    )
    out["robust"] = (out.bad_reversed == 1.0) & (out.good_reversed == 0.0)
    out["robust"].attrs = {
        "long_name": "every bad-sense launch reversed and no preferred-sense launch did"
    }
    out.attrs["launches"] = int(ds.sizes["trajectory"])
    return out


@dataclass
class SearchResult:
    """What the search found: the best part, every candidate tried with every launch
    (``data``: x, y (m), level and the variables of :func:`evaluate`), the per-candidate
    summaries alone (``table``), the best candidate's launches (``best``) and the
    number of launches simulated."""

    part: Part
    data: xr.Dataset
    table: xr.Dataset
    best: xr.Dataset
    launches: int
    levels: int
    notes: list[str] = field(default_factory=list)

    @property
    def robust(self) -> bool:
        """Whether the chosen placement reverses every bad launch and no good one."""
        return bool(self.best.robust)


def _rank(ds: xr.Dataset) -> np.ndarray:
    """Candidates best first: robust ones by their slowest bad reversal, then the rest
    by the fraction of launches right."""
    right = 0.5 * (ds.bad_reversed.values + 1.0 - ds.good_reversed.values)
    worst = ds.worst_bad_time.values
    return np.lexsort((worst, -right, ~ds.robust.values))


def _feasible(
    part: Part, points: list[tuple[float, float]], seen: set[tuple[float, float]]
) -> list[tuple[float, float]]:
    out = []
    for x, y in points:
        key = (round(x, 9), round(y, 9))
        if key in seen or placement_problem(part.at(x, y)) is not None:
            continue
        seen.add(key)
        out.append((x, y))
    return out


def _span(part: Part, x: float, y_sign: float, n: int = 400) -> tuple[float, float] | None:
    """The least and greatest feasible |y| (m) of a pocket at ``x``, or None."""
    ys = np.linspace(0.0, part.b, n + 1)[1:]
    ok = [y for y in ys if placement_problem(part.at(x, y_sign * y)) is None]
    return (float(min(ok)), float(max(ok))) if ok else None


def search(
    part: Part,
    launches: Launches,
    prefer: str,
    *,
    grid: tuple[int, int] = (10, 6),
    refine: int = 2,
    progress: Callable[[str], None] | None = None,
) -> SearchResult:
    """Search coin placements for ``part`` (its own x, y are ignored): a grid of
    ``grid`` = (nx, ny) points over the quarter of the flat face where the preferred
    sense comes out (x > 0, y of the sign that makes it): nx columns across x, each
    with ny points spread over the |y| that fit there, then ``refine`` levels of
    local refinement around the best; ``progress`` is told each level's size. ValueError
    when no placement fits."""
    nx, ny = grid
    if not (nx >= 1 and ny >= 1):
        raise ValueError(f"grid = {grid!r} is invalid: it must be two integers >= 1")
    if not (isinstance(refine, int) and refine >= 0):
        raise ValueError(f"refine = {refine!r} is invalid: it must be an integer >= 0")
    y_sign = -bad_sign(prefer)  # I_xy = -2 m x y must have the bad sense's sign
    hx = part.a / (nx + 1)
    grid_points, hy = [], 0.0
    for i in range(nx):
        span = _span(part, hx * (i + 1), y_sign)
        if span is None:
            continue
        low, high = span
        ys = np.linspace(low, high, ny) if ny > 1 else np.array([0.5 * (low + high)])
        hy = max(hy, (high - low) / max(ny - 1, 1))
        grid_points += [(hx * (i + 1), y_sign * float(y)) for y in ys]
    hy = hy or part.b / (ny + 1)
    seen: set[tuple[float, float]] = set()
    points = _feasible(part, grid_points, seen)
    if not points:
        raise ValueError(
            f"no coin placement fits: a {part.coin.name} pocket "
            f"({2 * part.pocket_radius * 1e3:.3g} mm) cannot sit off the long axis of this "
            f"flat face ({2 * part.a * 1e3:.4g} x {2 * part.b * 1e3:.4g} mm) with the rim "
            f"({part.settings.rim * 1e3:g} mm) and the walls around it; use a smaller coin "
            "or a wider shell (b)"
        )
    tables, total, level = [], 0, 0
    while True:
        if progress is not None:
            what = "searching" if level == 0 else f"refining (level {level} of {refine}):"
            progress(f"{what} {len(points)} placements x {launches.size} launches...")
        bodies = [
            body_of(part.at(x, y), name=f"x={x * 1e3:.2f}mm,y={y * 1e3:.2f}mm")
            for x, y in points
        ]
        ev = evaluate(bodies, launches, prefer)
        total += ev.attrs["launches"]
        tables.append(
            ev.assign_coords(
                x=(
                    "candidate",
                    [p[0] for p in points],
                    {"units": "m", "long_name": "x of the first pocket's centre"},
                ),
                y=(
                    "candidate",
                    [p[1] for p in points],
                    {"units": "m", "long_name": "y of the first pocket's centre"},
                ),
                level=(
                    "candidate",
                    np.full(len(points), level),
                    {"long_name": "refinement level"},
                ),
            )
        )
        data = xr.concat(tables, dim="candidate", data_vars="all")
        best = data.isel(candidate=int(_rank(data)[0]))
        if level == refine:
            break
        level += 1
        bx, by = float(best.x), float(best.y)
        sx, sy = hx / 2**level, hy / 2**level
        points = _feasible(
            part,
            [(bx + i * sx, by + j * sy) for i in (-1, 0, 1) for j in (-1, 0, 1) if i or j],
            seen,
        )
        if not points:
            break
    data.attrs = {
        "launches": total,
        "prefer": prefer,
        "best_candidate": int(_rank(data)[0]),
    }
    table = data.drop_dims(["sense", "spin", "mu", "tilt"])
    chosen = part.at(float(best.x), float(best.y))
    notes = (
        []
        if bool(best.robust)
        else [
            "no placement tried is robust: the best reverses "
            f"{float(best.bad_reversed):.0%} "
            f"of the bad-sense launches and {float(best.good_reversed):.0%} of the "
            f"preferred-sense ones within {launches.t_end:g} s"
        ]
    )
    return SearchResult(chosen, data, table, best, total, level, notes)
