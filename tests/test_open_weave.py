"""open_weave.py: the backdrop mask of a gauze photo, and the spec change it renders with."""
from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

from clothscope.synth.fabrics import FABRICS

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "workflow" / "benchmarks"))
import open_weave  # noqa: E402

FEW_SAMPLES = {"seed": 20261121, "resolution": 256, "spp": 4, "mesh_resolution": 768}


def test_the_backdrop_shows_through_the_holes_and_not_once_they_are_closed():
    holes = open_weave.backdrop_mask(open_weave.FABRIC, "red", FEW_SAMPLES)
    assert holes.shape == (256, 256) and 0.1 < holes.mean() < 0.6
    with open_weave.changed_spec(open_weave.FABRIC, {"open_weave": False}):
        closed = open_weave.backdrop_mask(open_weave.FABRIC, "red", FEW_SAMPLES)
    assert not closed.any()
    assert FABRICS[open_weave.FABRIC].open_weave  # the class is restored
    sheer = open_weave.backdrop_mask("chiffon", "red", FEW_SAMPLES)  # its yarns' own transmission is no hole
    assert 0.1 < sheer.mean() < 0.7 and FABRICS["chiffon"].sheer


def test_the_open_weaves_are_the_classes_with_holes():
    assert set(open_weave.OPEN_WEAVES) == {"chiffon", "cotton_gauze"}
    assert open_weave.variants("chiffon")["half relief"]["relief"] == FABRICS["chiffon"].relief / 2


def test_the_report_gives_medians_per_variant():
    rows = [{"variant": variant, "dye": dye, "roughness_true": 0.8, "roughness_fitted": fitted, "light_polar_true": 30.0,
             "light_polar_fitted": 30.0 + error, "light_azimuth_error": error, "left_out": 0.0, "psnr_db": 30.0,
             "status": "fitted"}
            for variant, fitted, error in (("as drawn", 0.4, 20.0), ("no holes", 0.7, 2.0)) for dye in ("red", "ivory")]
    rows.append({"variant": "no holes", "dye": "navy", "status": "failed: geometry: no light"})
    text = open_weave.markdown(pd.DataFrame(rows), "cotton_gauze", Path("sheet.tsv"), 1.0)
    assert "- not fitted: no holes, navy (failed: geometry: no light)" in text and "nan" not in text
    assert text.startswith("# What an open weave's holes cost the fit (cotton gauze, design draws)")
    assert "| as drawn | 0.800 | 0.400 | 0.400 | 20.0 | 20.0 | 0.0% | 30.0 |" in text
    assert "| no holes | 0.800 | 0.700 | 0.100 | 2.0 | 2.0 | 0.0% | 30.0 |" in text
