"""The limits on the work one request may ask for, shown in the page and enforced by the
server before any computation starts."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

__all__ = ["Caps", "CapExceeded"]


class CapExceeded(ValueError):
    """A request asks for more work than a cap allows; the message names the cap and
    ``control`` the page's control that asks for it (None: several)."""

    def __init__(self, message: str, control: str | None = None) -> None:
        super().__init__(message)
        self.control = control


@dataclass(frozen=True)
class Caps:
    """Per-request limits of the explorer.

    Attributes
    ----------
    max_t_end : float
        Longest run (s of simulated time).
    max_steps : int
        Most time steps of one run (a long run of a stiff body at a small default step).
    max_point_masses : int
        Most point masses added to a body.
    max_map_num : int
        Most points along each axis of a map's declared grid.
    max_map_levels : int
        Most refinement levels of a map (each halves the spacing where the outcome changes).
    max_map_t_end : float
        Longest run (s) of one map point.
    max_frames : int
        Samples of a run sent to the page (the run itself keeps every step).
    max_fit_t_end : float
        Longest measurement (s) a fit in the page takes.
    max_fit_samples : int
        Most samples of a measurement loaded into the page.
    """

    max_t_end: float = 30.0
    max_steps: int = 200_000
    max_point_masses: int = 4
    max_map_num: int = 25
    max_map_levels: int = 2
    max_map_t_end: float = 10.0
    max_frames: int = 1000
    max_fit_t_end: float = 20.0
    max_fit_samples: int = 10_000

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def check(
        self, name: str, value: float, cap: str, unit: str = "", control: str | None = None
    ) -> None:
        """Raise :class:`CapExceeded` when ``value`` of input ``name`` exceeds the cap
        ``cap`` (an attribute name); ``control`` is the page's control it belongs to."""
        limit = getattr(self, cap)
        if value > limit:
            units = f" {unit}" if unit else ""
            raise CapExceeded(
                f"{name} = {value:g}{units} exceeds the explorer's cap "
                f"{cap} = {limit:g}{units}",
                control,
            )
