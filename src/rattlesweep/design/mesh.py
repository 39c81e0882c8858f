"""Triangle meshes of the printed part (trimesh, booleans by manifold3d): the STL file
and an independent check of the mass model.

The meshes are built in the body frame (m) from the same solids as :mod:`.mass`: the
part (the semi-ellipsoid less the pockets), the infill core (the inner semi-ellipsoid
less the solid surround of each pocket) and the coins. :func:`mesh_moments` weighs them
with the densities of the print model; it must agree with the closed forms of
:func:`.mass.moments_of` up to the tessellation.

The STL is in millimetres in the print's pose: the flat face on the bed (z = 0), the
curved side up. That pose is the body turned half a turn about its x axis
(:data:`PRINT_FROM_BODY`), a rotation, so the print is not a mirror image of the body.
"""

from __future__ import annotations

import importlib
import math
import signal
import sys
import threading
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING

import numpy as np

from .mass import Moments, Part

if TYPE_CHECKING:
    from trimesh import Trimesh


def trimesh_module() -> ModuleType:
    """trimesh, imported with a Ctrl-C held until the import returns: its import
    catches every exception in places, so a Ctrl-C landing there would be lost (the
    command then finishing and writing files) or leave a half-made module."""
    if "trimesh" in sys.modules:
        return sys.modules["trimesh"]
    if threading.current_thread() is not threading.main_thread():
        return _import("trimesh")
    caught: list[int] = []
    previous = signal.signal(signal.SIGINT, lambda number, frame: caught.append(number))
    try:
        module = _import("trimesh")
    finally:
        signal.signal(signal.SIGINT, previous or signal.default_int_handler)
    if caught:
        raise KeyboardInterrupt
    return module


def _import(name: str) -> ModuleType:
    try:
        return importlib.import_module(name)
    except ModuleNotFoundError as exc:
        if exc.name != name:
            raise
        raise ModuleNotFoundError(
            f"rattlesweep design writes its STL with {name}, which is not installed: "
            "pip install 'rattlesweep[design]'",
            name=name,
        ) from None


__all__ = [
    "PRINT_FROM_BODY",
    "coin_meshes",
    "core_mesh",
    "mesh_moments",
    "part_mesh",
    "moments_of_mesh",
    "segment_mesh",
    "write_stl",
]

PRINT_FROM_BODY = np.diag([1000.0, -1000.0, -1000.0, 1.0])
"""Homogeneous transform from the body frame (m) to the STL's print pose (mm): half a
turn about x, then metres to millimetres."""

SECTIONS = 256
"""Segments around each circle and ellipse of the meshes."""

RINGS = 64
"""Rings from the bottom pole of an ellipsoid to its flat face."""

_OVERCUT = 1e-3  # cutters reach this far (m) past the face they open, for clean booleans


def _ring_vertices(a: float, b: float, c: float, theta: np.ndarray) -> np.ndarray:
    phi = np.linspace(0.0, 2.0 * math.pi, SECTIONS, endpoint=False)
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    return np.stack(
        [a * st * np.cos(phi), b * st * np.sin(phi), -c * ct * np.ones_like(phi)], axis=-1
    ).reshape(-1, 3)


def segment_mesh(a: float, b: float, c: float, z_top: float) -> "Trimesh":
    """Closed mesh of the part z ≤ z_top (m, −c < z_top ≤ 0) of the ellipsoid with
    semi-axes a, b, c centred at the origin: rings of :data:`SECTIONS` vertices on the
    surface from the bottom pole up to the flat top, which is a fan about its centre."""
    trimesh = trimesh_module()

    theta = np.linspace(0.0, math.acos(-z_top / c), RINGS + 1)[1:]
    rings = _ring_vertices(a, b, c, theta)
    n = SECTIONS
    bottom, top = len(rings), len(rings) + 1
    vertices = np.vstack([rings, [[0.0, 0.0, -c], [0.0, 0.0, z_top]]])
    j = np.arange(n)
    k = (j + 1) % n
    faces = [np.stack([np.full(n, bottom), k, j], axis=1)]
    for r in range(RINGS - 1):
        lo, hi = r * n, (r + 1) * n
        faces.append(np.stack([lo + j, lo + k, hi + k], axis=1))
        faces.append(np.stack([lo + j, hi + k, hi + j], axis=1))
    last = (RINGS - 1) * n
    faces.append(np.stack([np.full(n, top), last + j, last + k], axis=1))
    mesh = trimesh.Trimesh(vertices, np.vstack(faces), process=True)
    trimesh.repair.fix_normals(mesh)
    return mesh


def _cylinder(
    radius: float,
    z_low: float,
    z_high: float,
    x: float,
    y: float,
    inner_radius: float = 0.0,
) -> "Trimesh":
    trimesh = trimesh_module()

    transform = trimesh.transformations.translation_matrix([x, y, 0.5 * (z_low + z_high)])
    if inner_radius > 0.0:
        return trimesh.creation.annulus(
            inner_radius, radius, z_high - z_low, sections=SECTIONS, transform=transform
        )
    return trimesh.creation.cylinder(
        radius, z_high - z_low, sections=SECTIONS, transform=transform
    )


def _difference(base: "Trimesh", cutters: list["Trimesh"]) -> "Trimesh":
    trimesh = trimesh_module()

    out = trimesh.boolean.difference([base, *cutters], engine="manifold")
    if not out.is_watertight:  # pragma: no cover - manifold returns closed meshes
        raise RuntimeError("the boolean difference did not give a closed mesh")
    return out


def part_mesh(part: Part) -> "Trimesh":
    """The printed part in the body frame (m): the semi-ellipsoid less its pockets."""
    t = part.coin.thickness
    outer = segment_mesh(part.a, part.b, part.c, 0.0)
    return _difference(
        outer, [_cylinder(part.pocket_radius, -t, _OVERCUT, x, y) for x, y in part.pockets]
    )


def core_mesh(part: Part) -> "Trimesh":
    """The infill core in the body frame (m): the inner semi-ellipsoid below the face's
    wall less the solid surround of each pocket."""
    w, t = part.settings.wall, part.coin.thickness
    inner = segment_mesh(part.a - w, part.b - w, part.c - w, -w)
    return _difference(
        inner,
        [
            _cylinder(part.pocket_radius + w, -(t + w), -w + _OVERCUT, x, y)
            for x, y in part.pockets
        ],
    )


def coin_meshes(part: Part) -> list["Trimesh"]:
    """The coins in their pockets, body frame (m)."""
    coin = part.coin
    return [
        _cylinder(coin.diameter / 2, -coin.thickness, 0.0, x, y, coin.inner_diameter / 2)
        for x, y in part.pockets
    ]


def moments_of_mesh(mesh: "Trimesh", density: float) -> Moments:
    """Moments about the frame's origin of a closed mesh of uniform ``density``."""
    volume = float(mesh.volume)
    centre = np.asarray(mesh.center_mass, dtype=float)
    inertia = np.asarray(mesh.moment_inertia, dtype=float) * volume / float(mesh.mass)
    # inertia about the centroid per unit density -> second moment tensor about it
    second = 0.5 * np.trace(inertia) * np.eye(3) - inertia
    m = Moments(volume, volume * centre, second + volume * np.outer(centre, centre))
    return m.scaled(density)


def mesh_moments(part: Part) -> Moments:
    """The part's moments from its meshes and the print model's densities: the part at
    the material's density, the core less (1 − infill) of it, the coins at theirs."""
    rho = part.settings.material.density
    total = moments_of_mesh(part_mesh(part), rho)
    if part.settings.infill < 1.0:
        total = total + moments_of_mesh(
            core_mesh(part), -(1.0 - part.settings.infill) * rho
        )
    for coin in coin_meshes(part):
        total = total + moments_of_mesh(coin, part.coin.density)
    return total


def write_stl(part: Part, path: str | Path) -> Path:
    """Write the printed part as a binary STL in millimetres, flat face on the bed
    (:data:`PRINT_FROM_BODY`); the file is written to a temporary name and renamed."""
    mesh = part_mesh(part).copy()
    mesh.apply_transform(PRINT_FROM_BODY)
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    data = mesh.export(file_type="stl")
    if not isinstance(data, bytes):  # pragma: no cover - a binary STL is bytes
        raise TypeError(f"trimesh wrote {type(data).__name__}, not bytes, for an STL")
    tmp.write_bytes(data)
    tmp.replace(path)
    return path
