"""Axis labels from CF attributes, shared by every picture."""

from __future__ import annotations

import xarray as xr

__all__ = ["axis_label"]


def axis_label(da: xr.DataArray, fallback: str) -> str:
    """``long_name [units]`` of a variable (no brackets for dimensionless ones)."""
    name = da.attrs.get("long_name", fallback)
    units = da.attrs.get("units")
    return f"{name} [{units}]" if units and units != "1" else name
