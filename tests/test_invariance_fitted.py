"""invariance_fitted.py: the photos each transformation writes, and the refit that measures the benchmark's noise."""
from __future__ import annotations

import shutil
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from PIL import Image

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "workflow" / "benchmarks"))
import invariance_fitted as inv  # noqa: E402

ROOT = inv.ROOT


def test_refit_writes_the_photo_pixel_for_pixel_and_a_zoom_does_not(tmp_path, monkeypatch):
    sheet = pd.read_csv(ROOT / "config" / "samples.tsv", sep="\t", dtype=str, comment="#", keep_default_na=False).head(1)
    photo = tmp_path / sheet["path"][0]
    photo.parent.mkdir(parents=True)
    shutil.copy(ROOT / sheet["path"][0], photo)
    monkeypatch.setattr(inv, "ROOT", tmp_path)  # the benchmark writes its photos under the repository it reads from
    written = inv.transformed_sheet(sheet, tmp_path / "bench", ["refit", "zoom1.5"])
    assert list(written["image_id"]) == [f"{sheet['image_id'][0]}__refit", f"{sheet['image_id'][0]}__zoom1.5"]
    assert list(written["source"]) == [f"refit of {sheet['image_id'][0]}", f"zoom1.5 of {sheet['image_id'][0]}"]
    original = np.asarray(Image.open(ROOT / sheet["path"][0]).convert("RGB"))
    refit, zoomed = (np.asarray(Image.open(tmp_path / p).convert("RGB")) for p in written["path"])
    assert np.array_equal(refit, original)
    assert zoomed.shape == (171, 171, 3)  # the centre 1 / 1.5 of the photo; prepare resizes it


def test_an_unknown_transformation_stops_with_one_line(capsys, monkeypatch):
    monkeypatch.setattr(sys, "argv", ["invariance_fitted.py", "--transforms", "refit,mirror"])
    with pytest.raises(SystemExit) as stop:
        inv.main()
    assert stop.value.code == 2
    assert "unknown transformation(s) mirror" in capsys.readouterr().err
