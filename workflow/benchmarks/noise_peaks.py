"""Benchmark: how many spectral "peaks" each peak test finds in maps that hold no threads.

For white noise, Gaussian-smoothed noise (coloured, like a fitted relief's fibre noise), a
constant map and a black photo's sensor noise, at 64, 256 and 512 texels, this counts the
peaks per map of

- the paper's Algorithm 2 test (``features.significance: 0``, the default of the paper features);
- the same with the noise-calibrated ring test (``features.significance: 6``);
- the lattice test of the thread-structure descriptor (``features.structure``, ring-relative
  peaks; what the classifier of record and ``prepare``'s thread scale read).

    .venv/bin/python workflow/benchmarks/noise_peaks.py [--maps 50]

Writes ``results/bench/noise_peaks.{csv,md}``. A false peak per map is the false-alarm
rate each test runs at on that kind of map.
"""
from __future__ import annotations

import argparse
from collections.abc import Callable
from dataclasses import replace

import numpy as np
import pandas as pd
from harness import ROOT, publish, validated_config
from scipy import ndimage

from clothscope.features.paper import analyse_normal_map
from clothscope.features.structure import StructureSettings, analysis_field, find_lattice, spectrum
from clothscope.features.table import spectrum_settings, structure_settings

SIZES = (64, 256, 512)


def noise_maps(size: int, rng: np.random.Generator) -> dict[str, Callable[[], np.ndarray]]:
    """Generators of z maps without threads, by name."""
    return {
        "white noise": lambda: rng.standard_normal((size, size)),
        "smoothed noise (sigma 2)": lambda: ndimage.gaussian_filter(rng.standard_normal((size, size)), 2.0, mode="wrap"),
        "black photo (sensor noise on 0.002)": lambda: 0.002 + 0.0005 * rng.standard_normal((size, size)),
        "constant": lambda: np.full((size, size), 0.5),
    }


def lattice_peaks(z: np.ndarray, settings: StructureSettings) -> int:
    """Peaks the structure descriptor's lattice test finds (0 when it finds no lattice)."""
    lattice = find_lattice(spectrum(analysis_field(z, 0.0)), settings)
    return len(lattice.peaks) if lattice.found else 0


def count_peaks(maps: int, seed: int = 0) -> pd.DataFrame:
    """Mean and maximum peaks per map, per map kind, size and test."""
    config = validated_config()["features"]
    paper = spectrum_settings(config)
    tests = {"paper (significance 0)": lambda z: len(analyse_normal_map(z, replace(paper, significance=0.0)).raw_peaks),
             "calibrated (significance 6)": lambda z: len(analyse_normal_map(z, replace(paper, significance=6.0)).raw_peaks),
             "structure lattice": lambda z: lattice_peaks(z, structure_settings(config))}
    rows = []
    for size in SIZES:
        for kind, draw in noise_maps(size, np.random.default_rng(seed)).items():
            fields = [draw() for _ in range(maps)]
            for test, peaks in tests.items():
                counts = [peaks(z) for z in fields]
                rows.append({"map": kind, "size": size, "test": test, "mean peaks": float(np.mean(counts)),
                             "max peaks": int(np.max(counts)), "maps with a peak": float(np.mean(np.array(counts) > 0))})
    return pd.DataFrame(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--maps", type=int, default=50, help="maps per kind and size")
    args = parser.parse_args()
    table = count_peaks(args.maps)
    wide = table.pivot_table(index=["map", "size"], columns="test", values="mean peaks", sort=False).reset_index()
    text = "\n".join([f"Mean spectral peaks per map over {args.maps} maps of each kind and size (no threads in any).",
                      "", wide.to_markdown(index=False, floatfmt=".2f"), ""])
    publish(ROOT / "results" / "bench", "noise_peaks", table, text, float_format="%.4g")


if __name__ == "__main__":
    main()
