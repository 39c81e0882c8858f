"""The rocking semi-ellipse lamina (docs/model.md).

Body frame: origin C at the centre of the flat edge, x along the edge (semi-axis a), y up
(semi-axis b); the curved edge is x²/a² + y²/b² = 1 with y ≤ 0. The centre of mass G is on
the axis, ``com_depth`` = d below C. The body rocks on the floor Y = 0 by the angle θ
(rad, counter-clockwise: positive θ lowers the −x end).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, NamedTuple, Sequence, TypeAlias, Union

import numpy as np
import numpy.typing as npt

from .._validation import positive

__all__ = ["ContactPoint", "PlanarBodies", "PlanarBody"]

_REL_TOL = 1e-9


class ContactPoint(NamedTuple):
    """Where the body touches the floor at angle θ (all in m).

    from_com : world-horizontal offset of the contact point from G, −h′(θ) (positive: the
        contact point is on the +X side of G).
    from_centre : world-horizontal offset from C, the centre of the flat edge.
    body_x, body_y : the contact point in the body frame, from C: (−a² sin θ, −b² cos θ)/σ
        with σ = √(a² sin²θ + b² cos²θ). From G it is (body_x, body_y + d).
    """

    from_com: np.ndarray
    from_centre: np.ndarray
    body_x: np.ndarray
    body_y: np.ndarray


@dataclass(frozen=True)
class PlanarBody:
    """A rigid half-ellipse lamina rocking on a line.

    Parameters
    ----------
    a : float
        Semi-axis along the flat edge (m).
    b : float
        Semi-axis normal to the flat edge, the depth of the body (m).
    mass : float
        Mass (kg).
    com_depth : float, optional
        Depth d of the centre of mass below the flat edge (m), 0 < d < b. Default: the
        homogeneous lamina's 4b/(3π). Giving it requires ``inertia`` too.
    inertia : float, optional
        Moment of inertia about G (kg m²). Default: the homogeneous lamina's
        m[(a² + b²)/4 − d²] (polar moment about C, moved to G by the parallel-axis rule).
    name : str
        Label stored with results.

    The upright pose must not be unstable: the radius of curvature at the bottom, a²/b,
    must be at least the height of G above the contact point at rest, b − d (equality is
    neutral and allowed). A bad body is a ValueError naming the parameter and the rule.
    """

    a: float
    b: float
    mass: float
    if TYPE_CHECKING:
        # None in the constructor stands for the homogeneous lamina's value, which
        # __post_init__ stores: a body made holds numbers. A field has one type, so the
        # constructor's signature is spelled out for type checkers (at run time the
        # dataclass makes the same __init__ from the fields of the else branch).
        com_depth: float
        inertia: float

        def __init__(
            self,
            a: float,
            b: float,
            mass: float,
            com_depth: float | None = None,
            inertia: float | None = None,
            name: str = "semi_ellipse",
        ) -> None: ...
    else:
        com_depth: float | None = None
        inertia: float | None = None
    name: str = field(default="semi_ellipse", compare=False)

    def __post_init__(self) -> None:
        a, b, m = (positive(k, getattr(self, k)) for k in ("a", "b", "mass"))
        if self.com_depth is None:
            d = 4.0 * b / (3.0 * math.pi)
        else:
            if self.inertia is None:
                raise ValueError(
                    "com_depth needs inertia too: the default inertia formula holds only "
                    "for the homogeneous lamina, whose com_depth is 4b/(3 pi)"
                )
            d = positive("com_depth", self.com_depth)
            if not d < b:
                raise ValueError(
                    f"com_depth must be < b = {b!r} (G inside the body), "
                    f"got {self.com_depth!r}"
                )
        inertia = (
            m * ((a * a + b * b) / 4.0 - d * d)
            if self.inertia is None
            else positive("inertia", self.inertia)
        )
        radius, height = a * a / b, b - d
        if radius < height * (1.0 - _REL_TOL):
            raise ValueError(
                f"upright pose is unstable: radius of curvature a**2/b = {radius:.6g} m is "
                f"smaller than the height of G above the contact point b - com_depth = "
                f"{height:.6g} m (need a**2/b >= b - com_depth)"
            )
        for key, value in (
            ("a", a),
            ("b", b),
            ("mass", m),
            ("com_depth", d),
            ("inertia", inertia),
        ):
            object.__setattr__(self, key, value)

    @classmethod
    def homogeneous(
        cls, a: float, b: float, mass: float, *, name: str = "semi_ellipse"
    ) -> "PlanarBody":
        """Homogeneous half-ellipse lamina (m, m, kg):
        d = 4b/(3π), I_G = m[(a²+b²)/4 − d²]."""
        return cls(a, b, mass, name=name)

    # --- geometry ----------------------------------------------------------------------
    def height_derivatives(
        self, theta: npt.ArrayLike
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(h, h′, h″) at θ (rad, array_like): the height of G above the floor (m) and its
        first and second derivatives (m/rad, m/rad²), in closed form.

        h = σ − d cos θ with σ = √(a² sin²θ + b² cos²θ);
        h′ = (a² − b²) sin θ cos θ/σ + d sin θ;
        h″ = a²b²/σ³ − σ + d cos θ (h + h″ = a²b²/σ³ is the radius of curvature of the
        edge at the contact point).
        """
        th = np.asarray(theta, dtype=float)
        s, c = np.sin(th), np.cos(th)
        a2, b2, d = self.a**2, self.b**2, self.com_depth
        sigma = np.sqrt(a2 * s * s + b2 * c * c)
        h = sigma - d * c
        hp = (a2 - b2) * s * c / sigma + d * s
        hpp = a2 * b2 / sigma**3 - sigma + d * c
        return h, hp, hpp

    def height(self, theta: npt.ArrayLike) -> np.ndarray:
        """Height h(θ) of G above the floor (m) at θ (rad, array_like)."""
        return self.height_derivatives(theta)[0]

    def contact_point(self, theta: npt.ArrayLike) -> ContactPoint:
        """The contact point at θ (rad, array_like); see :class:`ContactPoint` (m)."""
        th = np.asarray(theta, dtype=float)
        s, c = np.sin(th), np.cos(th)
        a2, b2, d = self.a**2, self.b**2, self.com_depth
        sigma = np.sqrt(a2 * s * s + b2 * c * c)
        from_com = -((a2 - b2) * s * c / sigma + d * s)
        return ContactPoint(from_com, from_com + d * s, -a2 * s / sigma, -b2 * c / sigma)

    # --- small oscillations and the default step -----------------------------------------
    @property
    def rest_height(self) -> float:
        """Height of G above the contact point at rest, b − d (m)."""
        return self.b - self.com_depth

    def rocking_frequency(self, g: float = 9.81, rolling: bool = True) -> float:
        """Angular frequency (rad/s) of small rocking about θ = 0.

        ω² = m g (a²/b − (b − d))/J with J = I_G + m(b − d)² when rolling (rotation about
        the contact point) and J = I_G when frictionless (G only moves vertically, to
        second order). 0 for a neutral body (a²/b = b − d).
        """
        g = positive("g", g)
        margin = self.a**2 / self.b - self.rest_height
        if margin <= _REL_TOL * self.rest_height:
            return 0.0
        inertia = self.inertia + (self.mass * self.rest_height**2 if rolling else 0.0)
        return math.sqrt(self.mass * g * margin / inertia)

    def default_dt(self, g: float = 9.81) -> float:
        """Default time step (s): 1/64 of the shorter small-rocking period (the frictionless
        one, its inertia being the smaller; docs/model.md).

        A (nearly) neutral body rocks slowly at small amplitude but not at large, so the
        period is capped at 2π√(b/g), the time scale of motion over the body's own depth
        (this only matters when a²/b − (b − d) is small against b).
        """
        g = positive("g", g)
        w = max(
            self.rocking_frequency(g, True),
            self.rocking_frequency(g, False),
            math.sqrt(g / self.b),
        )
        return 2.0 * math.pi / w / 64.0

    def describe(self) -> dict[str, Any]:
        """Plain-number description for result attributes."""
        return {
            "body_name": self.name,
            "a": self.a,
            "b": self.b,
            "mass": self.mass,
            "com_depth": self.com_depth,
            "inertia": self.inertia,
        }


PlanarBodies: TypeAlias = Union[
    PlanarBody, "npt.NDArray[np.object_]", Sequence["PlanarBodies"]
]
"""A planar body, or an array of them: an object array, or sequences nested to any
depth."""
