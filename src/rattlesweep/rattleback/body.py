"""Rigid semi-ellipsoidal bodies (docs/model.md).

A :class:`Body` holds the geometry (semi-axes a, b, c in m), the mass (kg), the centre of
mass G (m, body frame from the centre C of the flat face) and the inertia tensor about G
(kg m², body axes, I = ∫(|r|²𝟙 − r rᵀ) dm so that I_xy = −∫xy dm). Bodies are immutable
and validated when made: a bad body is a ``ValueError`` naming the parameter, never a NaN
later in a simulation.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Iterable, Sequence, TypeAlias, Union

import numpy as np
import numpy.typing as npt

from .._validation import as_float_array, check_boolean, finite_vector, positive

__all__ = ["Bodies", "Body", "PRESETS", "rotated_inertia"]

_REL_TOL = 1e-9


def rotated_inertia(i1: float, i2: float, i3: float, delta: float) -> np.ndarray:
    """Inertia tensor with principal moments (i1, i2, i3) (kg m²) whose horizontal principal
    axes are rotated by ``delta`` (rad) about +z: I = R_z(δ) diag(i1, i2, i3) R_z(δ)ᵀ,
    so I_xy = (i1 − i2) sin δ cos δ."""
    c, s = math.cos(delta), math.sin(delta)
    rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return rz @ np.diag([i1, i2, i3]) @ rz.T


MOMENT_RATIO_MIN = 1e-12
"""Smallest principal moment of inertia a homogeneous body may have, relative to its
largest: rounding in float64 (about 2e-16 of the largest) then leaves the smallest
accurate to 2e-4. Semi-axes within a factor of about 1e6 of each other meet it."""


def _check_axes_scale(a: float, b: float, c: float, moments: np.ndarray) -> None:
    """Refuse semi-axes (m) whose homogeneous body's principal moments of inertia
    ``moments`` (kg m²) are too far apart for float64, naming the semi-axes: its smallest
    moment would be lost in the rounding of the largest (and the turned inertia of a
    misaligned body would no longer be positive definite)."""
    with np.errstate(all="ignore"):
        small, large = float(np.min(moments)), float(np.max(moments))
    if not (math.isfinite(large) and small > MOMENT_RATIO_MIN * large):
        raise ValueError(
            f"semi-axes a = {a!r}, b = {b!r}, c = {c!r} m are too far apart in scale for "
            f"float64: the body's smallest principal moment of inertia ({small:.3g} kg m2) "
            f"must exceed {MOMENT_RATIO_MIN:g} of its largest ({large:.3g} kg m2); keep "
            "the semi-axes within a factor of about 1e6 of each other"
        )


# eq=False: the generated __eq__ would compare the ndarray fields with ==, whose
# elementwise result has no truth value, and the generated __hash__ would fail on them
@dataclass(frozen=True, eq=False)
class Body:
    """A rigid body with an ellipsoidal bottom resting on a flat floor.

    Parameters
    ----------
    a, b, c : float
        Semi-axes along body x, y, z (m). The curved surface is x²/a² + y²/b² + z²/c² = 1
        with z ≤ 0; a is normally the largest.
    mass : float
        Mass (kg).
    com : (3,) array_like
        Centre of mass G from the centre C of the flat face, body components (m).
    inertia : (3, 3) array_like
        Inertia tensor about G in body axes (kg m²), ``I = ∫(|r|²𝟙 − r rᵀ) dm``.
    full_ellipsoid : bool
        A full ellipsoid has no rim, so it never capsizes (Kane and Levinson's body).
    name : str
        Label stored with results.

    Bodies are values: two bodies are equal, and hash alike, when all their parameters
    above except ``name`` are equal (exactly, float by float), so they can be dict keys
    and set members.
    """

    a: float
    b: float
    c: float
    mass: float
    com: np.ndarray
    inertia: np.ndarray
    full_ellipsoid: bool = False
    name: str = field(default="custom", compare=False)

    if TYPE_CHECKING:
        # The constructor takes com and inertia array_like; __post_init__ stores them as
        # read-only float arrays. A field has one type, so the signature is spelled out
        # for type checkers (at run time the dataclass makes the same __init__).
        def __init__(
            self,
            a: float,
            b: float,
            c: float,
            mass: float,
            com: npt.ArrayLike,
            inertia: npt.ArrayLike,
            full_ellipsoid: bool = False,
            name: str = "custom",
        ) -> None: ...

    def __post_init__(self) -> None:
        # checked first: the rim check below depends on it
        check_boolean("full_ellipsoid", self.full_ellipsoid)
        for key in ("a", "b", "c", "mass"):
            object.__setattr__(self, key, positive(key, getattr(self, key)))
        com = finite_vector("com", self.com, 3)
        inertia = as_float_array("inertia", self.inertia)
        if inertia.shape != (3, 3):
            raise ValueError(f"inertia must have shape (3, 3), got {inertia.shape}")
        if not np.all(np.isfinite(inertia)):
            raise ValueError("inertia must be finite")
        scale = float(np.max(np.abs(inertia)))
        if not np.allclose(inertia, inertia.T, rtol=0.0, atol=_REL_TOL * scale):
            raise ValueError(f"inertia must be symmetric, got {inertia.tolist()}")
        inertia = 0.5 * (inertia + inertia.T)
        moments = np.linalg.eigvalsh(inertia)
        if moments[0] <= 0.0:
            raise ValueError(
                "inertia must be positive definite; its principal moments are "
                f"{moments.tolist()}"
            )
        if moments[0] + moments[1] < moments[2] * (1.0 - _REL_TOL):
            raise ValueError(
                "inertia violates the triangle inequality of principal moments "
                f"(I1 + I2 >= I3): moments {moments.tolist()}"
            )
        gx, gy, gz = com
        inside = (gx / self.a) ** 2 + (gy / self.b) ** 2 + (gz / self.c) ** 2 < 1.0
        if not inside or (not self.full_ellipsoid and gz >= 0.0):
            where = "full ellipsoid" if self.full_ellipsoid else "semi-ellipsoid (z < 0)"
            raise ValueError(f"com {com.tolist()} must lie strictly inside the {where}")
        ell = self.c + gz
        for label, radius in (
            ("a**2/c", self.a**2 / self.c),
            ("b**2/c", self.b**2 / self.c),
        ):
            if not math.isfinite(radius):
                raise ValueError(
                    f"radius of curvature {label} overflows float64 (a = {self.a!r}, "
                    f"b = {self.b!r}, c = {self.c!r} m): c is too small for a and b"
                )
            if radius < ell * (1.0 - _REL_TOL):
                raise ValueError(
                    f"upright pose is unstable: radius of curvature {label} = "
                    f"{radius:.6g} m is smaller than the height of the centre of mass "
                    f"above the contact "
                    f"point c + com_z = {ell:.6g} m (need {label} >= c + com_z)"
                )
        com.setflags(write=False)
        inertia.setflags(write=False)
        object.__setattr__(self, "com", com)
        object.__setattr__(self, "inertia", inertia)
        object.__setattr__(
            self, "full_ellipsoid", check_boolean("full_ellipsoid", self.full_ellipsoid)
        )
        # Scales so far apart (c = 1e-300 m under a = 486 m, a mass of 1e165 kg) that the
        # rocking frequencies overflow leave no time step to integrate with.
        freqs: tuple[float, ...]
        with np.errstate(all="ignore"):
            try:
                freqs = (
                    *self.small_oscillation_frequencies(1.0, rolling=True),
                    *self.small_oscillation_frequencies(1.0, rolling=False),
                )
            except np.linalg.LinAlgError:
                freqs = (math.nan,)
        if not all(math.isfinite(f) for f in freqs):
            raise ValueError(
                f"a = {self.a!r}, b = {self.b!r}, c = {self.c!r} m, "
                f"mass = {self.mass!r} kg and inertia are too far apart in scale for "
                f"float64: the body's "
                f"small-oscillation frequencies overflow"
            )

    # --- constructors -------------------------------------------------------------
    @classmethod
    def semi_ellipsoid(
        cls,
        a: float,
        b: float,
        c: float,
        mass: float,
        delta: float = 0.0,
        *,
        delta_deg: float | None = None,
        name: str = "semi_ellipsoid",
    ) -> "Body":
        """Homogeneous solid semi-ellipsoid (m, kg) with its horizontal principal inertia
        axes rotated by the misalignment ``delta`` (rad) about +z, or ``delta_deg``
        (degrees; give one of the two). Default 0.

        G = (0, 0, −3c/8); inertia about C is diag(b²+c², a²+c², a²+b²)·m/5, moved to G
        by the parallel-axis rule, then rotated.
        """
        a, b, c, mass = (
            positive("a", a),
            positive("b", b),
            positive("c", c),
            positive("mass", mass),
        )
        if delta_deg is not None and not (isinstance(delta, (int, float)) and delta == 0.0):
            raise ValueError(
                f"give either delta (rad) or delta_deg (degrees), not both; "
                f"got delta={delta!r} and delta_deg={delta_deg!r}"
            )
        key, given, units = (
            ("delta_deg", delta_deg, "degrees")
            if delta_deg is not None
            else ("delta", delta, "rad")
        )
        try:
            angle = float(given)
        except (TypeError, ValueError):  # not a number: refused as below
            angle = math.nan
        if not math.isfinite(angle):
            raise ValueError(f"{key} must be a finite number ({units}), got {given!r}")
        if delta_deg is not None:
            angle = math.radians(angle)
        delta = angle
        zg = -3.0 * c / 8.0
        i_c = np.array([b * b + c * c, a * a + c * c, a * a + b * b]) * mass / 5.0
        i_g = i_c - mass * zg * zg * np.array([1.0, 1.0, 0.0])
        _check_axes_scale(a, b, c, i_g)
        ix, iy, iz = i_g
        return cls(
            a, b, c, mass, (0.0, 0.0, zg), rotated_inertia(ix, iy, iz, delta), name=name
        )

    @classmethod
    def ellipsoid(
        cls, a: float, b: float, c: float, mass: float, *, name: str = "ellipsoid"
    ) -> "Body":
        """Homogeneous solid full ellipsoid (m, kg), G at its centre. With a = b = c this is
        a uniform sphere."""
        a, b, c, mass = (
            positive("a", a),
            positive("b", b),
            positive("c", c),
            positive("mass", mass),
        )
        moments = np.array([b * b + c * c, a * a + c * c, a * a + b * b]) * mass / 5.0
        _check_axes_scale(a, b, c, moments)
        return cls(
            a, b, c, mass, (0.0, 0.0, 0.0), np.diag(moments), full_ellipsoid=True, name=name
        )

    def with_point_masses(self, masses: Iterable[tuple[float, npt.ArrayLike]]) -> "Body":
        """This body plus point masses ``[(mass_kg, (x, y, z)_m), ...]`` (body frame from
        C), combined by the parallel-axis rule. Returns a new, validated body."""
        total = self.mass
        first = self.mass * self.com
        items = []
        for i, (mi, pos) in enumerate(masses):
            mi = positive(f"masses[{i}] mass", mi)
            pos = finite_vector(f"masses[{i}] position", pos, 3)
            items.append((mi, pos))
            total += mi
            first = first + mi * pos
        com = first / total

        def shift(m: float, d: np.ndarray) -> np.ndarray:
            return m * (np.dot(d, d) * np.eye(3) - np.outer(d, d))

        inertia = self.inertia + shift(self.mass, self.com - com)
        for mi, pos in items:
            inertia = inertia + shift(mi, pos - com)
        return Body(
            self.a,
            self.b,
            self.c,
            total,
            com,
            inertia,
            self.full_ellipsoid,
            name=f"{self.name}+{len(items)} point masses",
        )

    @classmethod
    def preset(cls, name: str) -> "Body":
        """A named body; see :data:`PRESETS` for the list and the sources."""
        try:
            factory = PRESETS[name][0]
        except KeyError:
            raise ValueError(
                f"preset name {name!r} is unknown; choose one of {sorted(PRESETS)}"
            ) from None
        return factory()

    # --- value semantics ----------------------------------------------------------
    # Both cached: a batch hashes the same body once per trajectory, and hashing the key
    # costs more than the rest of a dictionary lookup.
    @functools.cached_property
    def _key(self) -> tuple[Any, ...]:
        """Every parameter but the name, as plain Python scalars."""
        return (
            self.a,
            self.b,
            self.c,
            self.mass,
            *self.com.tolist(),
            *self.inertia.ravel().tolist(),
            self.full_ellipsoid,
        )

    @functools.cached_property
    def _hash(self) -> int:
        return hash(self._key)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Body) or other.__class__ is not self.__class__:
            return NotImplemented
        return self is other or self._key == other._key

    def __hash__(self) -> int:
        return self._hash

    # Pickling and deepcopy rebuild the arrays writable; freeze them again, or the copy
    # could be changed after its key was cached. The cached key and hash are left out: a
    # hash need not survive a change of Python version.
    def __getstate__(self) -> dict[str, Any]:
        return {k: v for k, v in self.__dict__.items() if k not in ("_key", "_hash")}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self.com.setflags(write=False)
        self.inertia.setflags(write=False)

    # --- derived properties -------------------------------------------------------
    @property
    def com_height(self) -> float:
        """ℓ = c + com_z: height of G above the contact point in the upright pose (m)."""
        return self.c + float(self.com[2])

    @property
    def radii_of_curvature(self) -> tuple[float, float]:
        """Radii of curvature at the bottom point (m): (a²/c in the x–z plane, b²/c in
        the y–z plane)."""
        return self.a**2 / self.c, self.b**2 / self.c

    @property
    def misalignment(self) -> float:
        """Angle δ (rad, in (−π/4, π/4]) of the horizontal principal inertia axis nearest
        to body x, measured about +z: tan 2δ = 2 I_xy / (I_xx − I_yy)."""
        ixx, iyy, ixy = self.inertia[0, 0], self.inertia[1, 1], self.inertia[0, 1]
        if ixx == iyy:
            return 0.0 if ixy == 0.0 else math.copysign(math.pi / 4.0, ixy)
        return 0.5 * math.atan(2.0 * ixy / (ixx - iyy))

    def small_oscillation_frequencies(
        self, g: float = 9.81, *, rolling: bool = True
    ) -> tuple[float, float]:
        """Angular frequencies (rad/s) of small rocking about the upright pose at zero spin.

        Returns (pitch-like, roll-like): the modes mostly about body y and body x. For
        rolling contact the tilt inertia is taken about the contact point (I + mℓ²); for
        frictionless contact about G. With I_xy ≠ 0 the two modes couple: the frequencies
        solve det(K − ω² M) = 0 with K = m g diag(b²/c − ℓ, a²/c − ℓ) and M the x–y block
        of the inertia (docs/model.md). A neutral mode has frequency 0.
        """
        g = positive("g", g)
        ell = self.com_height
        extra = self.mass * ell * ell if rolling else 0.0
        m_mat = self.inertia[:2, :2] + extra * np.eye(2)
        rx, ry = self.radii_of_curvature
        # a margin within round-off of zero is neutral (a sphere with G at its centre)
        margins = [0.0 if abs(r - ell) <= _REL_TOL * ell else r - ell for r in (ry, rx)]
        k_mat = self.mass * g * np.diag(margins)
        # symmetric generalised eigenproblem via Cholesky of M
        lower = np.linalg.cholesky(m_mat)
        inv_l = np.linalg.inv(lower)
        vals, vecs = np.linalg.eigh(inv_l @ k_mat @ inv_l.T)
        modes = inv_l.T @ vecs
        freqs = np.sqrt(np.clip(vals, 0.0, None))
        # the pitch-like mode is the one with the larger share of motion about body y
        share_y = np.abs(modes[1, :]) / np.linalg.norm(modes, axis=0)
        pitch, roll = (0, 1) if share_y[0] > share_y[1] else (1, 0)
        return float(freqs[pitch]), float(freqs[roll])

    def default_dt(self, g: float = 9.81) -> float:
        """Default time step (s): 1/64 of the shortest small-oscillation period over the
        rolling and frictionless limits (docs/model.md). A body with no restoring
        stiffness (a sphere with G at its centre) uses the period 2π√(c/g) instead."""
        return _default_dt(self, positive("g", g))

    def describe(self) -> dict[str, Any]:
        """Plain-number description for result attributes."""
        return {
            "body_name": self.name,
            "a": self.a,
            "b": self.b,
            "c": self.c,
            "mass": self.mass,
            "com": self.com.tolist(),
            "inertia": self.inertia.tolist(),
            "full_ellipsoid": self.full_ellipsoid,
        }

    def __repr__(self) -> str:
        return (
            f"Body(name={self.name!r}, a={self.a:g}, b={self.b:g}, c={self.c:g}, "
            f"mass={self.mass:g}, com={self.com.tolist()}, "
            f"inertia={self.inertia.tolist()}, full_ellipsoid={self.full_ellipsoid})"
        )


# Sweeps ask for the default step of the same few bodies once per tile, and each answer
# costs two small eigenproblems. Bounded, as a sweep over random bodies meets thousands.
@functools.lru_cache(maxsize=4096)
def _default_dt(body: Body, g: float) -> float:
    with np.errstate(all="ignore"):
        w = max(
            *body.small_oscillation_frequencies(g, rolling=True),
            *body.small_oscillation_frequencies(g, rolling=False),
        )
        if w == 0.0:
            w = math.sqrt(g / body.c)
        dt = 2.0 * math.pi / w / 64.0
    if not (math.isfinite(dt) and dt > 0.0):
        raise ValueError(
            f"g = {g!r} m s-2 is too large for body {body.name!r}: its "
            f"small-oscillation frequencies overflow float64"
        )
    return dt


Bodies: TypeAlias = Union[Body, "npt.NDArray[np.object_]", Sequence["Bodies"]]
"""A body, or an array of bodies: an object array, or sequences nested to any depth."""


def _kane_levinson() -> Body:
    inertia = np.array([[2.0, 0.2, 0.0], [0.2, 16.0, 0.0], [0.0, 0.0, 17.0]]) * 1e-4
    return Body(
        0.20,
        0.03,
        0.02,
        1.0,
        (0.0, 0.0, -0.01),
        inertia,
        full_ellipsoid=True,
        name="kane_levinson",
    )


def _golden() -> Body:
    phi = (1.0 + math.sqrt(5.0)) / 2.0
    inertia = np.array(
        [
            [0.05796875, -0.025, 0.0],
            [-0.025, 0.09032943, 0.0],
            [0.0, 0.0, 0.12236068],
        ]
    )
    return Body(phi, 1.0, 1.0, 0.2, (0.0, 0.0, -0.1875), inertia, name="golden")


def _toy() -> Body:
    # 95 x 19 x 11 mm solid plastic (1050 kg/m^3) half-ellipsoid, 5 degree misalignment
    a, b, c = 0.0475, 0.0095, 0.011
    mass = 1050.0 * (2.0 / 3.0) * math.pi * a * b * c
    return Body.semi_ellipsoid(a, b, c, mass, math.radians(5.0), name="toy")


PRESETS = {
    "kane_levinson": (
        _kane_levinson,
        "a=0.20, b=0.03, c=0.02 m, m=1 kg, G=(0,0,-0.01) m, I=[[2,0.2,0],[0.2,16,0],"
        "[0,0,17]]e-4 kg m^2, full ellipsoid; Kane & Levinson, Int. J. Non-Linear Mech. "
        "17, "
        "175 (1982). Their air-resistance torque coefficient is sigma = 1e-4 N m s "
        "(pass damping=1e-4).",
    ),
    "golden": (
        _golden,
        "a=phi, b=c=1 m, m=0.2 kg, G=(0,0,-0.1875) m, half-ellipsoid plus two point "
        "masses; Kuypers; Schoemer.",
    ),
    "toy": (
        _toy,
        "typical plastic rattleback, 95 x 19 x 11 mm: homogeneous solid half-ellipsoid "
        "a=47.5, b=9.5, c=11 mm of density 1050 kg/m^3 (m = 10.9 g), inertia axes "
        "misaligned by delta = +5 degrees; chosen for this project.",
    ),
}
"""name → (factory, description with source)."""
