"""Run-level reports over the per-image outputs."""
from __future__ import annotations

import os
from collections.abc import Iterable

import pandas as pd

from clothscope.core.atomic import write_text
from clothscope.prepare.image import read_status


def prepare_table(prepared_dirs: Iterable[str | os.PathLike[str]]) -> pd.DataFrame:
    """One row per image: id, path, status, reason, clipped fraction."""
    rows = []
    for folder in prepared_dirs:
        status = read_status(folder)
        rows.append(
            {
                "image_id": status["image_id"],
                "path": status["path"],
                "status": status["status"],
                "reason": status["reason"],
                "clipped_fraction": status.get("clipped_fraction", ""),
            }
        )
    return pd.DataFrame(rows, columns=["image_id", "path", "status", "reason", "clipped_fraction"])


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
