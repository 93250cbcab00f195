"""gpu_presets.py: the report of runs of which some, or none, finished within their budget."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "workflow" / "benchmarks"))
import gpu_presets  # noqa: E402

FIGURES = {"psnr_db": 37.5, "fold_normal_error_deg": 6.9, "roughness_error": 0.05, "period_error": 0.01}


def run_rows(preset: str, images: list[str], finished: bool) -> pd.DataFrame:
    """Rows as ``mode_rows`` writes them for a whole-sheet run that finished every image, or none."""
    costs = {f"{stage}_s": (2.0 if finished else np.nan) for stage in gpu_presets.STAGES} | {"max_rss_mb": 500.0}
    rows = [{"image_id": image, "fit_s": 6.0 if finished else np.nan, **costs, **(FIGURES | {"status": "fitted"} if finished else {})}
            for image in images]
    return pd.DataFrame(rows).assign(preset=preset, variant="cuda_ad_rgb", device="GPU", jobs=len(images), images_asked=len(images),
                                     images_finished=len(images) if finished else 0, run_wall_s=30.0, run_complete=finished,
                                     results="results/none", mode="sheet")


def test_a_run_that_finished_no_image_is_reported_not_raised(tmp_path):
    paper = run_rows("paper", ["a", "b"], finished=False)
    text = gpu_presets.markdown(paper, tmp_path / "none.csv")
    assert "| 0/2 " in text and "beside the default" not in text


def test_the_paper_rows_that_finished_sit_beside_the_default_fits(tmp_path):
    table = pd.concat([run_rows("default", ["a", "b"], True), run_rows("paper", ["a"], True)], ignore_index=True)
    text = gpu_presets.markdown(table, tmp_path / "none.csv")
    assert "beside the default" in text and "| a " in text and "| 2/2 " in text and "| 1/1 " in text
