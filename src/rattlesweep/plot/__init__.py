"""Matplotlib pictures of results. Every function returns a ``matplotlib.figure.Figure``
(or, for :func:`animate`, writes a file) and never touches pyplot's global state, so
they work headless and inside libraries. Axis labels carry the variables' units."""

from .animation import InlineAnimation, animate, animate_inline
from .chaos import lyapunov_map, poincare_plot
from .maps import (
    OUTCOME_COLOURS,
    mpl_cmap,
    reversal_map,
    reversal_vs_growth,
    reversed_fraction,
    stability_map,
)
from .runs import contact_path, spin_history, time_series

__all__ = [
    "InlineAnimation",
    "OUTCOME_COLOURS",
    "animate",
    "animate_inline",
    "contact_path",
    "lyapunov_map",
    "mpl_cmap",
    "poincare_plot",
    "reversal_map",
    "reversal_vs_growth",
    "reversed_fraction",
    "spin_history",
    "stability_map",
    "time_series",
]
