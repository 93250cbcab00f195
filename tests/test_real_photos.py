"""real_photos.py: the design and confirmation halves of a folder of real photos."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from PIL import Image

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "workflow" / "benchmarks"))
import real_photos  # noqa: E402


def write_photo(path: Path, side: tuple[int, int], seed: int) -> None:
    """A small JPEG of noise, unique per seed."""
    path.parent.mkdir(parents=True, exist_ok=True)
    pixels = np.random.default_rng(seed).integers(0, 255, size=(side[1], side[0], 3), dtype=np.uint8)
    Image.fromarray(pixels).save(path)


@pytest.fixture()
def collection(tmp_path) -> Path:
    """Two classes of six usable photos, plus a duplicate and a photo too small in each."""
    root = tmp_path / "Images"
    for c, name in enumerate(("Denim", "Cotton")):
        for i in range(6):
            write_photo(root / name / f"{name}_{i:05d}.jpg", (40, 32), seed=10 * c + i)
        (root / name / f"{name}_00099.jpg").write_bytes((root / name / f"{name}_00000.jpg").read_bytes())
        write_photo(root / name / f"{name}_00100.jpg", (40, 20), seed=99 + c)
    return root


def test_halves_are_disjoint_deduplicated_large_enough_and_reproducible(collection):
    halves = real_photos.split_sets(collection, per_class=3, min_side=30, seed=7)
    assert list(halves["a"]) == ["cotton", "denim"]
    for fabric_class in ("cotton", "denim"):
        a, b = halves["a"][fabric_class], halves["b"][fabric_class]
        assert len(a) == len(b) == 3 and not set(a) & set(b)
        assert all("00099" not in p.name and "00100" not in p.name for p in a + b)
    assert real_photos.split_sets(collection, per_class=3, min_side=30, seed=7) == halves
    assert real_photos.split_sets(collection, per_class=3, min_side=30, seed=8) != halves


def test_a_half_is_copied_with_a_sheet_of_its_classes(collection, tmp_path):
    halves = real_photos.split_sets(collection, per_class=2, min_side=30, seed=7)
    sheet = pd.read_csv(real_photos.write_set(halves["b"], tmp_path / "out" / "b"), sep="\t", dtype=str)
    assert sorted(sheet["fabric_class"]) == ["cotton", "cotton", "denim", "denim"]
    assert all(Path(path).is_file() and "/out/b/photos/" in path for path in sheet["path"])


def test_too_few_usable_photos_is_one_clear_error(collection):
    with pytest.raises(ValueError, match="Cotton: 6 usable photos, fewer than the 8 2 sets need"):
        real_photos.split_sets(collection, per_class=4, min_side=30, seed=7)


def test_a_third_set_takes_the_next_photos_and_leaves_the_halves_as_they_were(collection):
    halves = real_photos.split_sets(collection, per_class=2, min_side=30, seed=7)
    three = real_photos.split_sets(collection, per_class=2, min_side=30, seed=7, names=("a", "b", "c"))
    assert {name: three[name] for name in ("a", "b")} == halves
    for fabric_class in ("cotton", "denim"):
        assert len(three["c"][fabric_class]) == 2
        assert not set(three["c"][fabric_class]) & set(halves["a"][fabric_class] + halves["b"][fabric_class])


def test_a_short_last_set_takes_what_is_left_and_leaves_the_earlier_sets_as_they_were(collection):
    two = real_photos.split_sets(collection, per_class=4, min_side=30, seed=7, names=("a",))
    short = real_photos.split_sets(collection, per_class=4, min_side=30, seed=7, names=("a", "b"), last_short=True)
    assert short["a"] == two["a"]
    assert {c: len(p) for c, p in short["b"].items()} == {"cotton": 2, "denim": 2}  # 6 usable, 4 in a
    with pytest.raises(ValueError, match="fewer than the 12 3 sets need"):  # nothing left for a third set
        real_photos.split_sets(collection, per_class=4, min_side=30, seed=7, names=("a", "b", "c"), last_short=True)
