"""Linear stability of steady upright spin (docs/model.md).

Spinning upright at rate n about the vertical is a relative equilibrium when G lies on the
body z axis and z is a principal axis of inertia (I_xz = I_yz = 0). Linearising the
rolling (no-slip) equations of the kernel about it gives four tilt eigenvalues; the
largest real part is the growth rate of the rattling that drives spin reversal.

Tilt state x = (γx, γy, ωx, ωy): the world up-vector γ in body components (γ ≈ (−pitch,
roll, 1) for small angles) and the horizontal body components of ω. With ℓ = c + G_z (the
height of G above the contact point), α = a²/c − ℓ, β = b²/c − ℓ, κ = (a² − b²)/c and
c_v the viscous torque coefficient, the exact linearisation of the kernel's stick
equations (I + m(|ρ|²𝟙 − ρρᵀ)) ω̇ = −ω×Iω − c_v ω + m ρ×(g n̂ − w) is::

    γ̇x = n γy − ωy,   γ̇y = −n γx + ωx
    M ω̇ = T_γ γ + T_ω ω,   M = [[I_xx + mℓ², I_xy], [I_xy, I_yy + mℓ²]]
    T_γ = [[m ℓ ṅ a²/c, −m g β + m ℓ n² κ], [m g α + m ℓ n² κ, m ℓ ṅ b²/c]]
    T_ω = [[n I_xy − c_v, n (I_yy − I_zz) − m ℓ n α],
           [n (I_zz − I_xx) + m ℓ n β, −n I_xy − c_v]]

with ṅ = −c_v n / I_zz. With damping the spin itself decays at that rate, so upright spin
is no longer an exact equilibrium: this is the linearisation at the instantaneous
("frozen") spin, the kernel's own Jacobian there, meaningful while c_v/I_zz is small
against the growth rates. The ṅ terms come from the tilt-dependence of the contact
inertia acting on ω̇_z.

(ρ = (0, 0, −ℓ) runs from G to the contact point; the contact point moves over the body
as ṡ = (a²/c ωy, −b²/c ωx, 0) to first order). Its trace, the sum of the real parts of
the eigenvalues, is (m ℓ n I_xy κ − c_v tr M) / det M: a misaligned body without
dissipation is unstable in both spin senses. Tests check the matrix against a central-
difference Jacobian of the kernel's own right-hand side (agreement ~1e-8 relative).

All functions are vectorised: parameters broadcast together.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from ._launches import distinct_bodies
from ._metadata import flag_attrs
from ._validation import fail_where
from .inputs import RATTLEBACK as INPUTS
from .rattleback.body import Bodies, Body

if TYPE_CHECKING:
    from .sweep import Sweep

__all__ = [
    "FRICTION_NOTE",
    "MODE_NAMES",
    "MODE_ATTRS",
    "body_arrays",
    "linearisation",
    "trace_identity",
    "eigen",
    "friction_dims",
    "zero_spin_frequencies",
    "small_spin_growth_rates",
    "stability_dataset",
]

MODE_NAMES = ("stable", "neutral", "pitch_unstable", "roll_unstable")
MODE_ATTRS = flag_attrs(
    "linear stability of steady upright spin",
    MODE_NAMES,
    "stable: every eigenvalue decays; neutral: the largest real part is zero (to 1e-9 of "
    "the largest |eigenvalue|); pitch_unstable / roll_unstable: the fastest growing mode "
    "is the pitch-like / roll-like one.",
)
STABLE, NEUTRAL, PITCH_UNSTABLE, ROLL_UNSTABLE = range(4)
_NEUTRAL_TOL = 1e-9


def _check_upright(com: np.ndarray, inertia: np.ndarray) -> None:
    scale = np.abs(inertia).max(axis=(-2, -1))
    if np.any(np.abs(com[..., :2]) > 1e-12) or np.any(
        np.abs(inertia[..., [0, 1], [2, 2]]) > 1e-12 * scale[..., None]
    ):
        raise ValueError(
            "upright steady spin is a relative equilibrium only when G lies on "
            "the body z axis (com x = y = 0) and z is a principal axis "
            "(I_xz = I_yz = 0); this body has com "
            f"{np.asarray(com).reshape(-1, 3)[0].tolist()} and inertia "
            f"{np.asarray(inertia).reshape(-1, 3, 3)[0].tolist()}"
        )


def body_arrays(body: Bodies) -> dict[str, np.ndarray]:
    """Per-body arrays (a, b, c, mass, ell, ixx, iyy, izz, ixy) for a Body or an array of
    Bodies, refusing bodies whose upright spin is no equilibrium."""
    arr = np.asarray(body, dtype=object) if not isinstance(body, Body) else None
    bodies: list[Any] = [body] if arr is None else list(arr.ravel())  # checked next
    if not bodies or not all(isinstance(b, Body) for b in bodies):
        raise ValueError(f"body must be a Body or an array of Body objects, got {body!r}")
    shape = () if arr is None else arr.shape
    table, inverse = distinct_bodies(bodies)
    com = np.array([b.com for b in table])
    inertia = np.array([b.inertia for b in table])
    _check_upright(com, inertia)
    cols = {
        "a": [b.a for b in table],
        "b": [b.b for b in table],
        "c": [b.c for b in table],
        "mass": [b.mass for b in table],
        "ell": [b.com_height for b in table],
        "ixx": inertia[:, 0, 0],
        "iyy": inertia[:, 1, 1],
        "izz": inertia[:, 2, 2],
        "ixy": inertia[:, 0, 1],
    }
    return {k: np.asarray(v, dtype=float)[inverse].reshape(shape) for k, v in cols.items()}


# the defaults of run_batch, from the inputs' descriptions
_G = INPUTS["g"].default
_DAMPING = INPUTS["damping"].default


def _check_inputs(
    spin: ArrayLike, g: ArrayLike, damping: ArrayLike
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The three as float arrays, each checked by its rule in
    :data:`rattlesweep.inputs.RATTLEBACK` with run_batch's message; a non-finite spin is
    refused too (a batch gives it a status instead, having no linearisation to make)."""
    arrays = {
        "spin": np.asarray(spin, dtype=float),
        "g": np.asarray(g, dtype=float),
        "damping": np.asarray(damping, dtype=float),
    }
    for name, values in arrays.items():
        rule = INPUTS[name].rule
        if rule is not None:
            fail_where(name, values, rule.bad(values), rule.message)
    return arrays["spin"], arrays["g"], arrays["damping"]


def linearisation(
    body: Bodies, spin: ArrayLike, *, g: ArrayLike = _G, damping: ArrayLike = _DAMPING
) -> np.ndarray:
    """The 4×4 matrix A (…, 4, 4) of ẋ = A x, x = (γx, γy, ωx, ωy), for rolling about
    steady upright spin ``spin`` (rad/s); ``g`` (m/s²), ``damping`` (N m s).
    ``body`` may be an array of bodies; everything broadcasts."""
    p = body_arrays(body)
    n, g, cv = _check_inputs(spin, g, damping)
    a, b, c, m, ell = p["a"], p["b"], p["c"], p["mass"], p["ell"]
    ixx, iyy, izz, ixy = p["ixx"], p["iyy"], p["izz"], p["ixy"]
    shape = np.broadcast_shapes(a.shape, n.shape, g.shape, cv.shape)
    alpha, beta, kappa = a * a / c - ell, b * b / c - ell, (a * a - b * b) / c
    mxx, myy, mxy = ixx + m * ell * ell, iyy + m * ell * ell, ixy
    det = mxx * myy - mxy * mxy
    # T_γ and T_ω, then M⁻¹ times each
    tg01 = -m * g * beta + m * ell * n * n * kappa
    tg10 = m * g * alpha + m * ell * n * n * kappa
    spin_rate = -cv * n / izz  # ṅ: the spin decays under damping
    tg00 = m * ell * spin_rate * a * a / c
    tg11 = m * ell * spin_rate * b * b / c
    tw00, tw01 = n * ixy - cv, n * (iyy - izz) - m * ell * n * alpha
    tw10, tw11 = n * (izz - ixx) + m * ell * n * beta, -n * ixy - cv
    inv00, inv01, inv11 = myy / det, -mxy / det, mxx / det
    A = np.zeros(shape + (4, 4))
    A[..., 0, 1] = n
    A[..., 0, 3] = -1.0
    A[..., 1, 0] = -n
    A[..., 1, 2] = 1.0
    A[..., 2, 0] = inv00 * tg00 + inv01 * tg10
    A[..., 2, 1] = inv00 * tg01 + inv01 * tg11
    A[..., 3, 0] = inv01 * tg00 + inv11 * tg10
    A[..., 3, 1] = inv01 * tg01 + inv11 * tg11
    A[..., 2, 2] = inv00 * tw00 + inv01 * tw10
    A[..., 2, 3] = inv00 * tw01 + inv01 * tw11
    A[..., 3, 2] = inv01 * tw00 + inv11 * tw10
    A[..., 3, 3] = inv01 * tw01 + inv11 * tw11
    return A


def trace_identity(
    body: Bodies, spin: ArrayLike, *, g: ArrayLike = _G, damping: ArrayLike = _DAMPING
) -> np.ndarray:
    """Closed-form sum of the four eigenvalues' real parts (1/s):
    (m ℓ n I_xy (a² − b²)/c − c_v (M_xx + M_yy)) / det M."""
    p = body_arrays(body)
    n, g, cv = _check_inputs(spin, g, damping)
    m, ell = p["mass"], p["ell"]
    mxx, myy = p["ixx"] + m * ell**2, p["iyy"] + m * ell**2
    det = mxx * myy - p["ixy"] ** 2
    kappa = (p["a"] ** 2 - p["b"] ** 2) / p["c"]
    return (m * ell * n * p["ixy"] * kappa - cv * (mxx + myy)) / det


def eigen(
    body: Bodies, spin: ArrayLike, *, g: ArrayLike = _G, damping: ArrayLike = _DAMPING
) -> dict[str, np.ndarray]:
    """Tilt eigenvalues and their modes.

    Returns a dict of arrays over the broadcast shape: ``eigenvalues`` (…, 4) complex
    (1/s), sorted pitch-like pair first; ``pitch_growth_rate``, ``roll_growth_rate``
    (largest real part of each mode pair, 1/s), ``pitch_frequency``,
    ``roll_frequency`` (largest magnitude of an imaginary part, rad/s), ``growth_rate``
    (largest real part of all four, 1/s) and ``mode`` (:data:`MODE_NAMES` codes). A mode is
    pitch-like when its eigenvector tilts more about body y (γx) than about body x (γy).
    """
    A = linearisation(body, spin, g=g, damping=damping)
    lam, vec = np.linalg.eig(A)
    share = np.abs(vec[..., 0, :]) ** 2 / (
        np.abs(vec[..., 0, :]) ** 2 + np.abs(vec[..., 1, :]) ** 2
    )
    # conjugate pairs share the same pitch share: the two largest are the pitch pair
    order = np.argsort(-share, axis=-1, kind="stable")
    lam = np.take_along_axis(lam, order, axis=-1)
    pitch, roll = lam[..., :2], lam[..., 2:]
    out = {
        "eigenvalues": lam,
        "pitch_growth_rate": pitch.real.max(axis=-1),
        "roll_growth_rate": roll.real.max(axis=-1),
        "pitch_frequency": np.abs(pitch.imag).max(axis=-1),
        "roll_frequency": np.abs(roll.imag).max(axis=-1),
        "growth_rate": lam.real.max(axis=-1),
    }
    tol = _NEUTRAL_TOL * np.abs(lam).max(axis=-1)
    mode = np.where(
        out["pitch_growth_rate"] >= out["roll_growth_rate"], PITCH_UNSTABLE, ROLL_UNSTABLE
    )
    mode = np.where(np.abs(out["growth_rate"]) <= tol, NEUTRAL, mode)
    mode = np.where(out["growth_rate"] < -tol, STABLE, mode)
    out["mode"] = mode.astype(np.int8)
    return out


def zero_spin_frequencies(
    body: Bodies, *, g: ArrayLike = _G
) -> tuple[np.ndarray, np.ndarray]:
    """(pitch-like, roll-like) rocking frequencies (rad/s) of the rolling body at zero
    spin, from the linearisation (equal to :meth:`Body.small_oscillation_frequencies`)."""
    e = eigen(body, 0.0, g=g)
    return e["pitch_frequency"], e["roll_frequency"]


def small_spin_growth_rates(
    body: Bodies, spin: ArrayLike, *, g: ArrayLike = _G, damping: ArrayLike = _DAMPING
) -> tuple[np.ndarray, np.ndarray]:
    """First-order-in-spin growth rates (1/s) of the (pitch-like, roll-like) modes, in
    closed form (the Walker / Garcia–Hubbard small-spin expansion).

    In tilt angles θ = (γy, −γx) the rolling body obeys M θ̈ + C θ̇ + K θ = 0 with, to
    first order in n, C = n M J − T_ω (J = [[0, −1], [1, 0]]). For a zero-spin mode φ_k
    normalised by φ_kᵀ M φ_k = 1, the growth rate is σ_k = −½ φ_kᵀ C φ_k + O(n²); with
    damping it includes −½ c_v φ_kᵀφ_k (the O(n c_v) stiffness terms of the frozen-spin
    linearisation shift only frequencies at this order). For comparison with :func:`eigen`,
    valid while ``abs(n)`` is small against the rocking frequencies.
    """
    p = body_arrays(body)
    n, g, cv = _check_inputs(spin, g, damping)
    a, b, c, m, ell = p["a"], p["b"], p["c"], p["mass"], p["ell"]
    ixx, iyy, izz, ixy = p["ixx"], p["iyy"], p["izz"], p["ixy"]
    shape = np.broadcast_shapes(a.shape, n.shape, g.shape, cv.shape)
    alpha, beta = a * a / c - ell, b * b / c - ell
    # in θ = (θ1, θ2) = (γy, −γx): ω = θ̇ + n J θ, stiffness K0 = m g diag(β, α)
    M = np.zeros(shape + (2, 2))
    M[..., 0, 0] = ixx + m * ell * ell
    M[..., 1, 1] = iyy + m * ell * ell
    M[..., 0, 1] = M[..., 1, 0] = ixy
    K = np.zeros(shape + (2, 2))
    K[..., 0, 0] = m * g * beta
    K[..., 1, 1] = m * g * alpha
    Tw = np.zeros(shape + (2, 2))
    Tw[..., 0, 0] = n * ixy - cv
    Tw[..., 0, 1] = n * (iyy - izz) - m * ell * n * alpha
    Tw[..., 1, 0] = n * (izz - ixx) + m * ell * n * beta
    Tw[..., 1, 1] = -n * ixy - cv
    J = np.array([[0.0, -1.0], [1.0, 0.0]])
    C = n[..., None, None] * (M @ J) - Tw if np.ndim(n) else n * (M @ J) - Tw
    # zero-spin modes: K φ = ω² M φ via Cholesky M = L Lᵀ
    L = np.linalg.cholesky(M)
    Linv = np.linalg.inv(L)
    w2, U = np.linalg.eigh(Linv @ K @ np.swapaxes(Linv, -1, -2))
    phi = np.swapaxes(Linv, -1, -2) @ U  # columns M-orthonormal
    sigma = -0.5 * np.einsum("...ik,...ij,...jk->...k", phi, C, phi)
    # pitch-like: more motion in θ2 (about body y)
    pitch_first = np.abs(phi[..., 1, 0]) > np.abs(phi[..., 1, 1])
    s_pitch = np.where(pitch_first, sigma[..., 0], sigma[..., 1])
    s_roll = np.where(pitch_first, sigma[..., 1], sigma[..., 0])
    return s_pitch, s_roll


def stability_dataset(
    sweep: Sweep | str | Path, *, command: str | None = None
) -> xr.Dataset:
    """Linear stability over the grid of a :class:`rattlesweep.Sweep` (or a TOML path or
    text): the same dimensions, coordinates and units as the sweep's result (for a
    refined sweep, its finest grid, every point computed).

    Uses each point's body, spin, g and damping; launch angles, friction and numerics do
    not enter the linearisation (they are kept as coordinates). Random draws of body
    parameters, spin, g or damping are honoured per repeat.
    """
    from .sweep import Sweep
    from .sweep._outputs.merge import grid_coords, sweep_attrs

    if not isinstance(sweep, Sweep):
        sweep = Sweep.from_toml(sweep)
    config, sweep = sweep, sweep.finest()
    bodies, kwargs = sweep.points(0, sweep.size)
    e = eigen(bodies, kwargs["spin"], g=kwargs["g"], damping=kwargs["damping"])
    p0, r0 = zero_spin_frequencies(bodies, g=kwargs["g"])
    dims, shape = sweep.dims, sweep.shape

    def var(
        values: ArrayLike, units: str, long_name: str, extra: dict[str, str] | None = None
    ) -> tuple[tuple[str, ...], np.ndarray, dict[str, Any]]:
        attrs = {"units": units, "long_name": long_name}
        return (dims, np.asarray(values).reshape(shape), {**attrs, **(extra or {})})

    lam = e["eigenvalues"].reshape(shape + (4,))
    data = {
        "growth_rate": var(
            e["growth_rate"],
            "s-1",
            "growth rate of rattling",
            {"comment": "largest real part of the four tilt eigenvalues"},
        ),
        "pitch_growth_rate": var(
            e["pitch_growth_rate"], "s-1", "growth rate of the pitch-like mode"
        ),
        "roll_growth_rate": var(
            e["roll_growth_rate"], "s-1", "growth rate of the roll-like mode"
        ),
        "pitch_frequency": var(
            e["pitch_frequency"], "rad s-1", "frequency of the pitch-like mode"
        ),
        "roll_frequency": var(
            e["roll_frequency"], "rad s-1", "frequency of the roll-like mode"
        ),
        "zero_spin_pitch_frequency": var(
            p0, "rad s-1", "pitch-like rocking frequency at zero spin"
        ),
        "zero_spin_roll_frequency": var(
            r0, "rad s-1", "roll-like rocking frequency at zero spin"
        ),
        "mode": (dims, e["mode"].reshape(shape), dict(MODE_ATTRS)),
        "eigenvalue_real": (
            dims + ("eigenvalue",),
            lam.real,
            {
                "units": "s-1",
                "long_name": "real part of the tilt eigenvalues (pitch-like pair first)",
            },
        ),
        "eigenvalue_imag": (
            dims + ("eigenvalue",),
            lam.imag,
            {
                "units": "rad s-1",
                "long_name": "imaginary part of the "
                "tilt eigenvalues (pitch-like pair first)",
            },
        ),
    }
    with np.errstate(divide="ignore"):
        efold = np.where(e["growth_rate"] > 0, 1.0 / e["growth_rate"], np.inf)
    data["e_folding_time"] = var(efold, "s", "1 / growth_rate (inf when not growing)")
    for rp in sweep.random_params:
        index = np.arange(sweep.size)
        data[rp.name] = var(
            rp.result_draw(sweep.seed, index),
            rp.result_units,
            f"{rp.long_name} (random draw)",
        )
    ds = xr.Dataset(data, coords=grid_coords(sweep))
    ds.attrs.update(
        sweep_attrs(
            config, f"rattlesweep linear stability of steady spin: {sweep.name}", command
        )
    )
    ds.attrs.update(
        {
            "Conventions": "CF-1.8",
            "model": "rolling contact linearised about steady upright spin",
            "references": "S. Jones and H. E. M. Hunt, Am. J. Phys. 87, 699 (2019)",
            "friction": FRICTION_NOTE,
        }
    )
    repeated = friction_dims(ds)
    if repeated:
        ds.attrs["friction"] += f"; the values repeat along {', '.join(repeated)}"
    return ds


FRICTION_NOTE = (
    "friction does not enter: the linearisation is that of rolling contact without "
    "couples, the same for every mu > 0, mu_spin and mu_roll (a frictionless floor, "
    "mu = 0, cannot hold a rolling contact, and is not described)"
)
"""What a stability file says of its friction coefficients."""


def friction_dims(ds: xr.Dataset) -> list[str]:
    """The dimensions of a stability file along which only friction varies: its values
    repeat along them."""
    return [str(d) for d in ds.dims if d in ("mu", "mu_static", "mu_spin", "mu_roll")]
