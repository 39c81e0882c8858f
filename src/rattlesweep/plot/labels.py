"""Labels from the CF attributes of results, in the units and symbols a person reads
("rad/s", "°", "μ = ∞ (rolling)"), shared by every picture. The files keep CF units
("rad s-1", "degree"); only the pictures translate them."""

from __future__ import annotations

import math
from typing import Any, Hashable

import xarray as xr

__all__ = ["HUMAN_UNITS", "axis_label", "human_units", "value_label"]

HUMAN_UNITS = {
    "rad s-1": "rad/s",
    "m s-1": "m/s",
    "m s-2": "m/s²",
    "s-1": "1/s",
    "degree": "°",
    "kg m2": "kg m²",
    "kg m2 s-1": "kg m²/s",
    "rad s-2": "rad/s²",
}
"""CF unit strings of results and how pictures write them; others read as they are."""

_SYMBOLS = {
    "mu": "μ",
    "mu_static": "μ_static",
    "mu_spin": "μ_spin",
    "mu_roll": "μ_roll",
    "delta_deg": "δ",
    "roll_deg": "roll",
    "pitch_deg": "pitch",
    "yaw_deg": "yaw",
    "launch_spin": "spin",
}
"""How titles and legends name a coordinate: a symbol, or the word without its code
suffix (the units say degrees)."""


def human_units(units: str | None) -> str:
    """A CF unit string as a person writes it (``"rad s-1"`` -> ``"rad/s"``); ``""`` for
    none or dimensionless (``"1"``)."""
    if not units or units == "1":
        return ""
    return HUMAN_UNITS.get(str(units), str(units))


def axis_label(da: xr.DataArray, fallback: str) -> str:
    """``long_name [units]`` of a variable in human units (no brackets for dimensionless
    ones)."""
    name = da.attrs.get("long_name", fallback)
    units = human_units(da.attrs.get("units"))
    return f"{name} [{units}]" if units else name


def value_label(ds: xr.Dataset | xr.DataArray, name: Hashable, value: Any) -> str:
    """``name = value units`` for a coordinate value in a title or legend: ``μ = 0.3``,
    ``μ = ∞ (rolling)``, ``δ = 4°``, ``spin = 5 rad/s``."""
    units = (
        human_units(ds[name].attrs.get("units"))
        if name in ds.coords or (isinstance(ds, xr.Dataset) and name in ds)
        else ""
    )
    label = _SYMBOLS.get(str(name), str(name))
    if isinstance(value, (float, int)) and not isinstance(value, bool):
        if math.isinf(value):
            text = "∞" if value > 0 else "-∞"
            if name == "mu":
                text += " (rolling)"
        else:
            text = f"{value:g}"
    else:
        text = str(value)
    if units == "°":
        return f"{label} = {text}°"
    return f"{label} = {text}" + (f" {units}" if units and not text.endswith(")") else "")
