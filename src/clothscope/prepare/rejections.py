"""Run-level reports over the per-image outputs."""
from __future__ import annotations

import os
from collections.abc import Iterable

import pandas as pd

from clothscope.core.atomic import write_text
from clothscope.prepare.image import read_status


#: Working thread period (px) under which :func:`thread_scale_line` counts a photo as far below the band: the fit's
#: normals are central differences of its height map, whose response sin(2 pi / period) (period in texels, about
#: one per pixel) is largest at 4 and falls to zero at 2.
FAR_BELOW_PX = 4.0
PREPARE_COLUMNS = ("image_id", "path", "status", "reason", "clipped_fraction", "working_period_px", "period_band_px")


def prepare_table(prepared_dirs: Iterable[str | os.PathLike[str]]) -> pd.DataFrame:
    """One row per image: id, path, status, reason, clipped fraction, and the thread scale ``prepare`` chose.

    ``working_period_px`` is the thread period at the working resolution and
    ``period_band_px`` the band it was aimed at (``low-high``); both are empty
    where no period was measured (no lattice found, ``prepare.scale: frame``,
    or a rejected image).
    """
    rows = []
    for folder in prepared_dirs:
        status = read_status(folder)
        scale = status.get("scale") or {}
        band = scale.get("period_band") or []
        rows.append(
            {
                "image_id": status["image_id"],
                "path": status["path"],
                "status": status["status"],
                "reason": status["reason"],
                "clipped_fraction": status.get("clipped_fraction", ""),
                "working_period_px": scale.get("working_period_px", ""),
                "period_band_px": f"{band[0]:g}-{band[1]:g}" if len(band) == 2 else "",
            }
        )
    return pd.DataFrame(rows, columns=list(PREPARE_COLUMNS))


def thread_scale_line(table: pd.DataFrame) -> str:
    """One line: where the accepted photos' threads landed against the period band ``prepare`` aims at.

    ``table`` is :func:`prepare_table`'s (or ``prepared.tsv`` read back). Threads
    finer than the band were so even at full native resolution (``prepare``
    never magnifies by default); ``""`` where no accepted photo has a measured
    period, or where ``table`` predates the period columns.
    """
    if not {"working_period_px", "period_band_px"} <= set(table.columns):
        return ""
    accepted = table[table["status"] == "accepted"]
    period = pd.to_numeric(accepted["working_period_px"], errors="coerce")
    bands = accepted.loc[period.notna(), "period_band_px"].astype(str).unique()
    if period.notna().sum() == 0 or len(bands) != 1:
        return ""
    low, high = (float(v) for v in bands[0].split("-"))
    finer, coarser, far = int((period < low).sum()), int((period > high).sum()), int((period < FAR_BELOW_PX).sum())
    within, unmeasured = int(period.notna().sum()) - finer - coarser, int(period.isna().sum())
    return (f"Thread scale (prepare): of {len(accepted)} accepted photos, {within} show threads in the band the fit is "
            f"made for ({low:g}-{high:g} px at the working resolution), {finer} finer even at full native resolution "
            f"({far} of them under {FAR_BELOW_PX:g} px), {coarser} coarser, and {unmeasured} no lattice the period "
            "could be read from.")


def write_prepare_reports(prepared_dirs: Iterable[str | os.PathLike[str]], rejected_tsv: str, summary_tsv: str) -> tuple[int, int]:
    """Write the rejection report (header plus one line per rejected image) and the full status table.

    Returns
    -------
    tuple of int
        Accepted and rejected counts.
    """
    table = prepare_table(prepared_dirs)
    rejected = table[table["status"] == "rejected"]
    write_text(rejected_tsv, rejected[["image_id", "path", "reason"]].to_csv(sep="\t", index=False, lineterminator="\n"))
    write_text(summary_tsv, table.to_csv(sep="\t", index=False, lineterminator="\n"))
    return int((table["status"] == "accepted").sum()), len(rejected)
