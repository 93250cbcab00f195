"""Figures of the features stage: the paper's Figure 3 per map, and a placeholder figure for a map that has none."""
from __future__ import annotations

import os
import textwrap

from clothscope.core.figures import new_figure, save_png
from clothscope.features.paper import SpectrumResult


def plot_analysis(result: SpectrumResult, target: str | os.PathLike[str], title: str = "", dpi: int = 100) -> None:
    """Write a 2x2 PNG like the paper's Figure 3, atomically.

    Panels: z map; log spectrum; filtered spectrum after DC removal; the
    filtered spectrum with the analysis annulus and the chosen peaks (and their
    mirror twins, hollow) marked.

    Parameters
    ----------
    result : SpectrumResult
        Output of :func:`analyse_normal_map`.
    target : path
        PNG file to write.
    title : str
        Figure title.
    dpi : int
        Resolution of the PNG.
    """
    from matplotlib.patches import Circle  # matplotlib is loaded by new_figure in any case

    size = result.z_map.shape[0]
    centre = size // 2
    fig = new_figure(8.0, 8.0)
    axes = fig.subplots(2, 2)
    panels = [
        (result.z_map, "z component of the normal map", "gray"),
        (result.log_spectrum, "log |FFT|", "magma"),
        (result.filtered_spectrum, "DC removed, mean filtered", "magma"),
        (result.filtered_spectrum, f"peaks ({len(result.peaks)} chosen of {len(result.candidates)})", "magma"),
    ]
    for ax, (image, label, cmap) in zip(axes.ravel(), panels):
        ax.imshow(image, cmap=cmap, interpolation="nearest")
        ax.set_title(label, fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
    ax = axes[1, 1]
    for radius, style in ((result.dc_radius_bins, "--"), (size / 2, ":")):
        ax.add_patch(Circle((centre, centre), radius, fill=False, ec="white", ls=style, lw=0.8))
    for k, peak in enumerate(result.peaks, start=1):
        ax.plot(peak.col, peak.row, "o", mfc="none", mec="cyan", ms=10)
        ax.plot(2 * centre - peak.col, 2 * centre - peak.row, "o", mfc="none", mec="cyan", ms=6, alpha=0.5)
        ax.annotate(f"{k}: r={peak.radius_bins:.1f}, z={peak.height:.2f}", (peak.col, peak.row), color="cyan", fontsize=7,
                    xytext=(4, -4), textcoords="offset points")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    try:
        save_png(fig, target, dpi=dpi)
    finally:
        fig.clf()


def plot_placeholder(target: str | os.PathLike[str], title: str, reason: str) -> None:
    """A PNG that says why an image has no spectrum plot, atomically."""
    fig = new_figure(6.0, 3.0)
    ax = fig.add_subplot(1, 1, 1)
    ax.axis("off")
    ax.text(0.5, 0.5, textwrap.fill(reason, 70), ha="center", va="center", fontsize=9, wrap=True)
    fig.suptitle(title)
    save_png(fig, target, dpi=80)
