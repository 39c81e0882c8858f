"""Hypothesis strategies for the property-based tests (tests/test_properties*.py).

Two kinds of value: *valid* ones, from ranges the documentation allows and where a run
is cheap (a few hundred steps at most), and *arbitrary* ones, which mix valid values
with every kind of bad one a caller might pass: NaN, infinities, zeros and negatives,
extreme magnitudes, wrong shapes, strings, None, ragged lists, booleans.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import strategies as st

import rattlesweep as rs

SPECIAL_FLOATS = (
    0.0,
    -0.0,
    -1.0,
    math.nan,
    math.inf,
    -math.inf,
    1e300,
    -1e300,
    1e-300,
    5e-324,
)
NON_NUMBERS = ("abc", "", None, [1.0, "x"], [[1.0, 2.0], [3.0]], {"a": 1}, 1j, object())


def finite(lo: float, hi: float) -> st.SearchStrategy[float]:
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False)


def any_float() -> st.SearchStrategy[float]:
    """Any float, NaN and infinities included, with the special values often."""
    return st.one_of(st.sampled_from(SPECIAL_FLOATS), st.floats(allow_subnormal=True))


def any_scalar(valid: st.SearchStrategy) -> st.SearchStrategy:
    """A valid value, an arbitrary float, a non-number, an array of either, or a bool."""
    return st.one_of(
        valid,
        any_float(),
        st.sampled_from(NON_NUMBERS),
        st.booleans(),
        st.lists(st.one_of(valid, any_float()), min_size=0, max_size=3),
        st.integers(-(2**70), 2**70),
    )


def any_vector(width: int, valid: st.SearchStrategy) -> st.SearchStrategy:
    """A (width,) vector, a vector of another length, a stack of vectors, or junk."""
    return st.one_of(
        st.lists(valid, min_size=width, max_size=width).map(tuple),
        st.lists(any_float(), min_size=width, max_size=width).map(tuple),
        st.lists(finite(-1, 1), min_size=0, max_size=5).map(tuple),
        st.lists(st.lists(valid, min_size=width, max_size=width), min_size=0, max_size=3),
        st.sampled_from(NON_NUMBERS),
        any_float(),
    )


# --- bodies ---------------------------------------------------------------------------
@st.composite
def semi_ellipsoid_args(draw) -> dict:
    """Arguments of a homogeneous semi-ellipsoid that is stable upright (a**2/c and
    b**2/c above the height 5c/8 of G over the contact point)."""
    a = draw(finite(0.01, 0.3))
    b = draw(finite(0.2, 1.0)) * a
    c = draw(finite(0.1, 1.2)) * b
    mass = draw(finite(0.005, 3.0))
    delta = draw(finite(-0.6, 0.6))
    return {"a": a, "b": b, "c": c, "mass": mass, "delta": delta}


@st.composite
def valid_bodies(draw) -> rs.Body:
    """A valid body: a preset, a homogeneous semi-ellipsoid, a full ellipsoid, or one of
    these with point masses on its flat face or inside it."""
    kind = draw(st.sampled_from(["preset", "semi", "ellipsoid", "masses"]))
    if kind == "preset":
        return rs.Body.preset(draw(st.sampled_from(sorted(rs.PRESETS))))
    if kind == "ellipsoid":
        a = draw(finite(0.02, 0.3))
        b = draw(finite(0.3, 1.0)) * a
        c = draw(finite(0.2, 1.0)) * b  # c <= min(a, b) keeps it stable upright
        return rs.Body.ellipsoid(a, b, c, draw(finite(0.01, 3.0)))
    args = draw(semi_ellipsoid_args())
    body = rs.Body.semi_ellipsoid(**args)
    if kind == "masses":
        # small masses below the flat face, well inside: G stays low, so it stays stable
        n = draw(st.integers(1, 3))
        masses = []
        for _ in range(n):
            x = draw(finite(-0.5, 0.5)) * body.a
            y = draw(finite(-0.5, 0.5)) * body.b
            z = -draw(finite(0.3, 0.6)) * body.c
            masses.append((draw(finite(0.01, 0.3)) * body.mass, (x, y, z)))
        body = body.with_point_masses(masses)
    return body


def arbitrary_inertia() -> st.SearchStrategy:
    """Inertia tensors: physical ones (principal moments obeying the triangle rule,
    turned about z), near-misses, and junk."""

    @st.composite
    def physical(draw):
        i1, i2 = draw(finite(1e-7, 1e-2)), draw(finite(1e-7, 1e-2))
        i3 = draw(finite(0.0, 1.2)) * (i1 + i2)
        d = draw(finite(-1.0, 1.0))
        return rs.rattleback.body.rotated_inertia(i1, i2, i3, d).tolist()

    return st.one_of(
        physical(),
        st.lists(st.lists(any_float(), min_size=3, max_size=3), min_size=3, max_size=3),
        any_vector(3, finite(0, 1)),
    )


# --- launches -------------------------------------------------------------------------
LAUNCH_ARGS = (
    "spin",
    "omega",
    "roll",
    "pitch",
    "yaw",
    "orientation",
    "velocity",
    "mu",
    "mu_static",
    "mu_spin",
    "mu_roll",
    "damping",
    "g",
    "dt",
    "t_end",
    "method",
    "record_every",
    "reversal_band",
    "parallel",
    "threads",
)


@st.composite
def valid_launch(draw, body: rs.Body, max_steps: int = 300) -> dict:
    """Scalar keyword arguments of one valid launch of ``body`` that takes at most
    ``max_steps`` steps: spin or body-frame omega, small tilts (or a unit quaternion),
    optionally sliding, any friction, damping, g and a step up to the body's default.

    The launch is one the default step resolves: spin up to the body's fastest
    small-oscillation frequency w0 (at most 40 rad/s), rocking rates up to 0.15 w0 (a
    rocking amplitude of about 0.15 rad). Faster launches are valid input too, but the
    default step does not resolve them (a kane_levinson pitching at 19.5 rad/s at
    g = 1 gains 127 % energy in two default steps, 2e-5 % at 1/64 of it), so their
    accuracy is not a property of the engine's defaults."""
    g = draw(st.one_of(st.just(9.81), finite(0.5, 30.0)))
    dt0 = body.default_dt(g)
    w0 = max(
        *body.small_oscillation_frequencies(g, rolling=True),
        *body.small_oscillation_frequencies(g, rolling=False),
    )
    dt = draw(st.one_of(st.none(), finite(0.05, 1.0).map(lambda f: f * dt0)))
    steps = draw(st.integers(1, max_steps))
    t_end = steps * (dt0 if dt is None else dt) * draw(finite(0.5, 1.0))
    # at least one step (a given dt longer than t_end is refused, and the checks rerun
    # launches at given fractions of their default step)
    t_end = max(t_end, dt0 if dt is None else dt)
    mu = draw(st.sampled_from([math.inf, 0.0, 0.1, 0.3, 1.0]) | finite(0.0, 2.0))
    kw: dict = {"mu": mu, "t_end": t_end, "g": g}
    if draw(st.booleans()):
        kw["mu_static"] = mu + draw(st.sampled_from([0.0, math.inf]) | finite(0.0, 1.0))
    if dt is not None:
        kw["dt"] = dt
    spin = min(40.0, w0)
    if draw(st.booleans()):
        kw["spin"] = draw(finite(-spin, spin))
    else:
        rock = 0.15 * w0
        kw["omega"] = (
            draw(finite(-rock, rock)),
            draw(finite(-rock, rock)),
            draw(finite(-spin, spin)),
        )
    if draw(st.integers(0, 3)) == 0:
        q = np.array([1.0] + [draw(finite(-0.07, 0.07)) for _ in range(3)])
        kw["orientation"] = tuple(q / np.linalg.norm(q))
    else:
        for name in ("roll", "pitch"):
            kw[name] = draw(finite(-0.15, 0.15))
        kw["yaw"] = draw(finite(-math.pi, math.pi))
    if draw(st.integers(0, 3)) == 0:
        kw["damping"] = draw(finite(0.0, 1e-3))
    if draw(st.integers(0, 3)) == 0:
        kw["mu_spin"] = draw(finite(0.0, 0.1)) * body.b
    if draw(st.integers(0, 3)) == 0:
        kw["mu_roll"] = draw(finite(0.0, 0.1)) * body.c
    if math.isfinite(kw.get("mu_static", mu)) and draw(st.integers(0, 3)) == 0:
        kw["velocity"] = (draw(finite(-0.3, 0.3)), draw(finite(-0.3, 0.3)))
    return kw


def arbitrary_value(name: str) -> st.SearchStrategy:
    """Anything a caller might pass as the launch argument ``name``."""
    angle = finite(-0.2, 0.2)
    return {
        "spin": any_scalar(finite(-40, 40)),
        "omega": any_vector(3, finite(-20, 20)),
        "roll": any_scalar(angle),
        "pitch": any_scalar(angle),
        "yaw": any_scalar(angle),
        "orientation": any_vector(4, finite(-1, 1)),
        "velocity": any_vector(2, finite(-0.3, 0.3)),
        "mu": any_scalar(finite(0, 2)),
        "mu_static": any_scalar(finite(0, 2)),
        "mu_spin": any_scalar(finite(0, 1e-3)),
        "mu_roll": any_scalar(finite(0, 1e-3)),
        "damping": any_scalar(finite(0, 1e-3)),
        "g": any_scalar(finite(0.5, 30)),
        "dt": any_scalar(finite(1e-5, 1e-3)),
        "t_end": any_scalar(finite(1e-4, 0.05)),
        "method": st.one_of(
            st.sampled_from(["rk4", "euler", "RK4", "", "rk45"]),
            st.sampled_from(NON_NUMBERS),
            st.integers(-1, 3),
        ),
        "record_every": st.one_of(
            st.integers(-3, 5), st.sampled_from(NON_NUMBERS), st.booleans(), any_float()
        ),
        "reversal_band": any_scalar(finite(0, 0.99)),
        "parallel": st.one_of(st.booleans(), st.sampled_from(NON_NUMBERS)),
        "threads": st.one_of(st.integers(-2, 4), st.sampled_from(NON_NUMBERS), any_float()),
    }[name]


# --- sweep configurations -------------------------------------------------------------
SWEEP_BODY = ("a", "b", "c", "mass", "delta")
VALID_RANGES = {
    "spin": (-30.0, 30.0),
    "roll": (-0.1, 0.1),
    "pitch": (-0.1, 0.1),
    "yaw": (-3.0, 3.0),
    "roll_deg": (-5.0, 5.0),
    "pitch_deg": (-5.0, 5.0),
    "delta_deg": (-8.0, 8.0),
    "mu": (0.05, 1.0),
    "mu_static": (1.0, 2.0),
    "mu_spin": (0.0, 1e-3),
    "mu_roll": (0.0, 1e-3),
    "damping": (0.0, 1e-4),
    "g": (5.0, 15.0),
    "a": (0.04, 0.05),
    "b": (0.009, 0.01),
    "c": (0.008, 0.011),
    "mass": (0.005, 0.02),
    "delta": (-0.15, 0.15),
}


@st.composite
def sweep_value(draw, key: str, bad: bool):
    lo, hi = VALID_RANGES[key]
    if bad:
        return draw(st.one_of(any_float(), st.sampled_from(["x", True, [1, 2], {}])))
    return draw(finite(lo, hi))


@st.composite
def sweep_axis(draw, key: str, bad: bool):
    lo, hi = VALID_RANGES[key]
    if draw(st.booleans()):
        values = draw(st.lists(finite(lo, hi), min_size=1, max_size=3, unique=True))
        if bad:
            values[draw(st.integers(0, len(values) - 1))] = draw(sweep_value(key, True))
        return values
    num = draw(st.integers(1, 3))
    start = draw(finite(lo, hi))
    stop = (
        draw(finite(start, hi))
        if num == 1
        else start + draw(finite(1e-6, 1.0)) * (hi - start) + 1e-9 * max(1.0, abs(start))
    )
    spec = {"start": start, "stop": stop, "num": num}
    if bad:
        spec[draw(st.sampled_from(["start", "stop", "num"]))] = draw(sweep_value(key, True))
    if lo > 0 and draw(st.booleans()):
        spec["scale"] = "log"
    return spec


@st.composite
def sweep_configs(draw):
    """A sweep configuration table (what a TOML file holds) and the set of keys made
    bad on purpose (empty for a configuration that must be accepted). Sizes stay small
    (at most 3 values per axis, 3 axes, 2 repeats) and ``t_end`` a few steps, so a
    valid sweep runs in milliseconds."""
    keys = list(VALID_RANGES)
    chosen = draw(
        st.lists(
            st.sampled_from(keys),
            min_size=1,
            max_size=5,
            unique_by=lambda k: k.removesuffix("_deg"),
        )
    )
    n_axes = draw(st.integers(1, min(3, len(chosen))))
    n_random = draw(st.integers(0, len(chosen) - n_axes))
    bad_keys: set[str] = set()
    make_bad = draw(st.booleans())

    def bad_here(key):
        if make_bad and not bad_keys and draw(st.booleans()):
            bad_keys.add(key)
            return True
        return False

    config: dict = {"name": draw(st.text(max_size=10)), "axes": {}, "fixed": {}}
    for key in chosen[:n_axes]:
        config["axes"][key] = draw(sweep_axis(key, bad_here(f"axes.{key}")))
    randoms = chosen[n_axes : n_axes + n_random]
    for key in chosen[n_axes + n_random :]:
        config["fixed"][key] = draw(sweep_value(key, bad_here(f"fixed.{key}")))
    if randoms:
        config["random"] = {}
        for key in randoms:
            lo, hi = VALID_RANGES[key]
            x, y = sorted(
                draw(st.lists(finite(lo, hi), min_size=2, max_size=2, unique=True))
            )
            spec = {"uniform": [x, y]}
            if bad_here(f"random.{key}"):
                spec = draw(
                    st.sampled_from(
                        [
                            {"uniform": [y, x]},
                            {"normal": [x, -1.0]},
                            {"uniform": [x]},
                            {"beta": [x, y]},
                        ]
                    )
                )
            config["random"][key] = spec
        config["repeats"] = draw(st.integers(1, 2))
        config["seed"] = draw(st.integers(0, 2**32))
    if "mu_static" in chosen and "mu" not in chosen:
        config["fixed"]["mu"] = 0.5  # the default mu, inf, is above any finite mu_static
    uses_body = any(k.removesuffix("_deg") in SWEEP_BODY for k in chosen)
    if not uses_body and draw(st.booleans()):
        config["fixed"]["body"] = draw(st.sampled_from(["toy", "kane_levinson"]))
    config["fixed"]["t_end"] = draw(finite(0.002, 0.02))
    if bad_here("method"):
        config["method"] = draw(st.sampled_from(["rk5", "", "RK4"]))
    else:
        config["method"] = draw(st.sampled_from(["rk4", "euler"]))
    if bad_here("tile_size"):
        config["tile_size"] = draw(st.sampled_from([0, -3, 2.5, "big"]))
    elif draw(st.booleans()):
        config["tile_size"] = draw(st.integers(1, 40))
    if bad_here("reversal_band"):
        config["reversal_band"] = draw(st.sampled_from([1.0, -0.1, math.nan, "x"]))
    return config, bad_keys


@st.composite
def corruptions(draw, text: str) -> str:
    """``text`` damaged the ways files get damaged or hand-edited: cut short, a span
    deleted or repeated, a character replaced, junk inserted, a line duplicated."""
    kind = draw(
        st.sampled_from(
            ["truncate", "delete", "repeat", "replace", "insert", "duplicate_line"]
        )
    )
    n = len(text)
    i = draw(st.integers(0, n))
    j = draw(st.integers(i, min(n, i + 20)))
    if kind == "truncate":
        return text[:i]
    if kind == "delete":
        return text[:i] + text[j:]
    if kind == "repeat":
        return text[:j] + text[i:j] + text[j:]
    if kind == "replace" and i < n:
        return text[:i] + draw(st.characters(codec="utf-8")) + text[i + 1 :]
    if kind == "duplicate_line":
        lines = text.splitlines(keepends=True)
        k = draw(st.integers(0, len(lines) - 1))
        return "".join(lines[: k + 1] + lines[k:])
    junk = draw(
        st.sampled_from(
            [
                "=",
                "[",
                "]",
                "{",
                '"',
                "'",
                "nan",
                "inf",
                "-",
                "\n[axes]\n",
                "\nspin = 1\n",
                "\x00",
                "#",
                ",",
                "\\",
            ]
        )
    )
    return text[:i] + junk + text[i:]
