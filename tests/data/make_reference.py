"""Write ``reference_runs.npz``: the results of a fixed batch of 3-D and planar launches,
against which ``tests/test_reference.py`` checks that a refactoring changed no result.

Run it only to accept a deliberate change of results (say why in the commit message):
``.venv/bin/python tests/data/make_reference.py``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

import rattlesweep as rs
from rattlesweep.planar import PlanarBody, run_planar_batch

HERE = Path(__file__).parent
PATH = HERE / "reference_runs.npz"

# (label, mu, mu_static): the rolling and frictionless cases must be bit-identical across
# refactorings; the Coulomb ones identical to rounding
FRICTION = (
    ("rolling", math.inf, None),
    ("frictionless", 0.0, None),
    ("coulomb", 0.3, None),
    ("coulomb_static", 0.2, 0.4),
)


def batch_3d(mu, mu_static, method):
    kl, toy, golden = (rs.Body.preset(n) for n in ("kane_levinson", "toy", "golden"))
    bodies = np.array(
        [kl, toy, golden, kl.with_point_masses([(0.05, (0.05, 0.01, -0.01))])], dtype=object
    )[:, None]
    spins = np.array([[-5.0, 5.0, 12.0]])
    return rs.run_batch(
        bodies,
        spin=spins,
        roll=math.radians(0.5),
        pitch=0.01,
        mu=mu,
        mu_static=mu_static,
        damping=[[0.0], [1e-6], [0.0], [1e-5]],
        t_end=0.6,
        dt=1e-3,
        method=method,
        record_every=37,
    )


def sliding_3d(method):
    kl = rs.Body.preset("kane_levinson")
    return rs.run_batch(
        kl,
        spin=[3.0, -3.0],
        velocity=[[0.05, -0.02], [0.0, 0.1]],
        roll=0.02,
        mu=0.25,
        mu_static=0.3,
        t_end=0.6,
        dt=1e-3,
        method=method,
        record_every=37,
    )


def batch_planar(mu, mu_static, method):
    bodies = np.array(
        [
            PlanarBody(0.10, 0.05, 1.0),
            PlanarBody(0.06, 0.08, 1.0, com_depth=0.05, inertia=1e-3),
        ],
        dtype=object,
    )[:, None]
    return run_planar_batch(
        bodies,
        theta=[[0.3, -0.7, 1.2]],
        rate=[[0.0, 2.0, -1.0]],
        mu=mu,
        mu_static=mu_static,
        t_end=0.6,
        dt=5e-4,
        method=method,
        record_every=23,
    )


def sliding_planar(method):
    return run_planar_batch(
        PlanarBody(0.10, 0.05, 1.0),
        theta=[0.2, -0.4],
        rate=1.0,
        velocity=[0.3, -0.2],
        mu=0.2,
        t_end=0.6,
        dt=5e-4,
        method=method,
        record_every=23,
    )


def statuses_3d():
    kl, toy = rs.Body.preset("kane_levinson"), rs.Body.preset("toy")
    omega = [[0.0, 0.0, 5.0], [15.0, 0.0, 0.0], [60.0, 0.0, 0.0], [np.nan, 0.0, 5.0]]
    return rs.run_batch(
        np.array([kl, toy, kl, kl], dtype=object),
        omega=omega,
        roll=np.radians([0.5, 80.0, 0.5, 0.5]),
        mu=0.5,
        t_end=0.3,
        dt=1e-3,
        record_every=11,
    )


def statuses_planar():
    return run_planar_batch(
        PlanarBody(0.10, 0.05, 1.0),
        theta=[0.3, 1.0, 1.0, np.nan],
        rate=[0.0, 10.0, 20.0, 0.0],
        mu=0.5,
        t_end=0.3,
        record_every=11,
    )


def runs():
    """label -> Dataset, for every case the reference holds."""
    out = {}
    for method in ("rk4", "euler"):
        for label, mu, mu_s in FRICTION:
            out[f"3d/{method}/{label}"] = batch_3d(mu, mu_s, method)
            out[f"planar/{method}/{label}"] = batch_planar(mu, mu_s, method)
        out[f"3d/{method}/sliding"] = sliding_3d(method)
        out[f"planar/{method}/sliding"] = sliding_planar(method)
    out["3d/rk4/statuses"] = statuses_3d()
    out["planar/rk4/statuses"] = statuses_planar()
    return out


def flatten(runs_by_label):
    """{'label:variable': values} for every data variable of every run."""
    return {
        f"{label}:{name}": np.asarray(ds[name].values)
        for label, ds in runs_by_label.items()
        for name in ds.data_vars
    }


if __name__ == "__main__":
    arrays = flatten(runs())
    np.savez_compressed(PATH, **arrays)
    print(f"wrote {len(arrays)} arrays to {PATH}")
