"""Matplotlib figures without pyplot: a new figure, and its PNG written atomically.

matplotlib is imported when the first figure is made (about 0.5 s), so a module
that can draw is cheap to import for a job that does not.
"""
from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any

from clothscope.core.atomic import write_with

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def new_figure(width: float, height: float, **options: Any) -> Figure:
    """A figure of ``width`` x ``height`` inches on the Agg canvas (``options`` go to ``Figure``)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), **options)
    FigureCanvasAgg(fig)
    return fig


def save_png(fig: Figure, target: str | os.PathLike[str], dpi: int) -> None:
    """Write ``fig`` to ``target`` as a PNG, atomically."""
    write_with(target, lambda tmp: fig.savefig(tmp, format="png", dpi=dpi))
