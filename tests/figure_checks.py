"""Checks of rendered figures: no two texts (or a text and a legend) overlap, and every
text and legend lies inside the figure."""

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.legend import Legend
from matplotlib.text import Text


def layout_problems(fig, dpi: float = 100.0, tolerance: float = 1.0) -> list[str]:
    """What overlaps or sticks out of ``fig`` drawn at ``dpi``: a list of descriptions
    (empty when the layout is clean). ``tolerance`` (pixels) forgives touching boxes."""
    FigureCanvasAgg(fig)
    fig.set_dpi(dpi)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    legends = [a for a in fig.findobj(Legend) if a.get_visible()]
    in_legend = {id(t) for leg in legends for t in leg.findobj(Text)}
    items = [
        (
            f"legend {[t.get_text() for t in leg.get_texts()][:3]}",
            leg.get_window_extent(renderer),
        )
        for leg in legends
    ]
    # tick labels: only those of ticks inside the view (matplotlib keeps, but does not
    # draw, labels of the ticks its locator gives beyond the limits)
    tick_labels: set[int] = set()
    shown = []
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            lo, hi = sorted(axis.get_view_interval())
            span = 1e-9 * max(abs(lo), abs(hi), 1e-300)
            for tick in axis.get_major_ticks() + axis.get_minor_ticks():
                labels = (tick.label1, tick.label2)
                tick_labels.update(id(t) for t in labels)
                loc = tick.get_loc()
                if loc is not None and lo - span <= loc <= hi + span:
                    shown += [t for t in labels if t.get_visible()]
    shown_ids = {id(t) for t in shown}
    for t in {id(t): t for t in [*fig.findobj(Text), *shown]}.values():
        if (
            id(t) in in_legend
            or (id(t) in tick_labels and id(t) not in shown_ids)
            or not t.get_visible()
            or not t.get_text().strip()
        ):
            continue
        items.append((repr(t.get_text()), t.get_window_extent(renderer)))
    problems = []
    box = fig.bbox
    for name, b in items:
        if (
            b.x0 < box.x0 - tolerance
            or b.y0 < box.y0 - tolerance
            or b.x1 > box.x1 + tolerance
            or b.y1 > box.y1 + tolerance
        ):
            problems.append(
                f"{name} sticks out of the figure at dpi {dpi}: {b.bounds} "
                f"outside {box.bounds}"
            )
    for i, (n1, b1) in enumerate(items):
        for n2, b2 in items[i + 1 :]:
            w = min(b1.x1, b2.x1) - max(b1.x0, b2.x0)
            h = min(b1.y1, b2.y1) - max(b1.y0, b2.y0)
            if w > tolerance and h > tolerance:
                problems.append(f"{n1} overlaps {n2} at dpi {dpi} ({w:.0f} x {h:.0f} px)")
    return problems
