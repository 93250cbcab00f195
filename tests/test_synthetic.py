"""The embedded synthetic dataset: determinism, reproduction of the committed set, truth consistency."""
from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import SYNTHETIC

from clothscope.core.config import schema_defaults
from clothscope.core.imageio import read_png
from clothscope.core.truth import decode_normal, truth_paths
from clothscope.synth.fabrics import FABRICS
from clothscope.synth.generate import dataset_index, save, synthesize
from clothscope.synth.verify import compare_image

#: the committed set's settings, the config schema's defaults
DEFAULTS = schema_defaults()
SYNTH = DEFAULTS["synthesize"]

TRUTHS = sorted(SYNTHETIC.glob("*/*.truth.json"))


def load_truth(image_id: str) -> dict:
    return json.loads(next(SYNTHETIC.glob(f"*/{image_id}.truth.json")).read_text())


def fundamental_period(normal: np.ndarray, dc_radius: float = 4.0, strong: float = 0.2) -> float:
    """Period (texels) of the lowest-frequency strong peak of the normal map's spectrum.

    Power of all three components (Hann window, DC disc of ``dc_radius`` bins
    removed), maximised over rings of one frequency bin; the first local
    maximum above ``strong`` times the strongest one is the thread frequency
    (thin yarns put comparable power into its harmonics).
    """
    size = normal.shape[0]
    window = np.outer(np.hanning(size), np.hanning(size))
    power = sum(np.abs(np.fft.fftshift(np.fft.fft2((c - c.mean()) * window))) ** 2 for c in np.moveaxis(normal, -1, 0))
    yy, xx = np.mgrid[:size, :size] - size // 2
    radius = np.hypot(yy, xx)
    power[radius < dc_radius] = 0
    rings = np.round(radius).astype(int)
    profile = np.zeros(rings.max() + 1)
    np.maximum.at(profile, rings.ravel(), power.ravel())
    profile[size // 2 :] = 0  # beyond Nyquist along the axes
    peaks = [r for r in range(1, len(profile) - 1) if profile[r] >= strong * profile.max() and profile[r] >= profile[r - 1] and profile[r] >= profile[r + 1]]
    ring = peaks[0]
    # sub-bin position of the peak inside its ring
    candidates = np.where(rings == ring, power, 0)
    return size / radius.flat[np.argmax(candidates)]


def test_committed_set_is_complete_and_small():
    assert len(TRUTHS) == len(dataset_index(SYNTH["colors_per_class"])) == 42
    total = sum(p.stat().st_size for p in SYNTHETIC.rglob("*") if p.is_file())
    assert total < 15e6
    for fabric, _, image_id in dataset_index(SYNTH["colors_per_class"]):
        assert all(p.is_file() for p in truth_paths(SYNTHETIC / fabric / f"{image_id}.png").values())


@pytest.mark.parametrize("truth_path", TRUTHS, ids=lambda p: p.stem.removesuffix(".truth"))
def test_truth_is_consistent(truth_path):
    truth = json.loads(truth_path.read_text())
    spec = FABRICS[truth["fabric_class"]]
    image_path = truth_path.with_name(truth_path.name.replace(".truth.json", ".png"))
    image = read_png(image_path)
    normal = decode_normal(read_png(truth_paths(image_path)["normal"]))
    assert image.shape == normal.shape == (256, 256, 3)
    assert np.all(normal[..., 2] > 0), "ground-truth normals must face out of the cloth"
    assert truth["effects"]["integrator"] == ("path" if spec.sheer else "direct")
    assert truth["effects"]["sheen"] == bool(spec.sheen) and truth["effects"]["diffuse_transmission"] == spec.sheer
    assert not truth["effects"]["spectral"] and not truth["effects"]["polarized"]
    if spec.periodic:
        period = truth["thread_period_px"]
        assert period >= 6.0
        measured = fundamental_period(normal)
        assert abs(measured - period) / period < 0.05, f"spectrum peaks at {measured:.2f} px, truth says {period:.2f}"
    else:
        assert truth["thread_period_px"] is None and truth["fibre_scale_px"] > 0


def test_generator_is_deterministic():
    first = synthesize("velvet", 2, seed=7, resolution=64, spp=4, mesh_resolution=128, variant=DEFAULTS["variant"], threads=2)
    second = synthesize("velvet", 2, seed=7, resolution=64, spp=4, mesh_resolution=128, variant=DEFAULTS["variant"], threads=2)
    other = synthesize("velvet", 2, seed=8, resolution=64, spp=4, mesh_resolution=128, variant=DEFAULTS["variant"], threads=2)
    assert np.array_equal(first.maps["normal"], second.maps["normal"]) and np.array_equal(first.fold, second.fold)
    assert np.abs(first.image - second.image).max() <= 1 / 255 + 1e-6
    assert not np.array_equal(first.maps["normal"], other.maps["normal"])
    first.truth.pop("provenance"), second.truth.pop("provenance")
    assert first.truth == second.truth


@pytest.mark.slow
@pytest.mark.parametrize("fabric, dye_index", [("broadcloth", 0), ("chiffon", 5)])
def test_regeneration_reproduces_committed_files(tmp_path, fabric, dye_index):
    image_id = dataset_index(SYNTH["colors_per_class"])[list(FABRICS).index(fabric) * SYNTH["colors_per_class"] + dye_index][2]
    save(synthesize(fabric, dye_index, load_truth(image_id)["seed"], SYNTH["resolution"], SYNTH["spp"], SYNTH["mesh_resolution"],
                   DEFAULTS["variant"], threads=2), tmp_path / fabric / f"{image_id}.png")
    row = compare_image(tmp_path / fabric / f"{image_id}.png", SYNTHETIC / fabric / f"{image_id}.png")
    assert row["truth_identical"], row
    assert row["reproduced"], row
