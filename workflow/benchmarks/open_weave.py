"""Benchmark: what an open weave's holes cost the fit, on the design set's cotton gauze (or chiffon) draws.

    .venv/bin/python workflow/benchmarks/open_weave.py [--fabric cotton_gauze] [--dyes red,ivory,...] [--out DIR]

The generator draws cotton gauze's roughness at 0.70-0.85 and chiffon's at 0.35-0.50, yet the fit
returns both near 0.4, so the fitted BRDF cannot tell apart the two classes that every source
confuses most. This renders each draw of one open-weave class of the embedded design set (same
seed, size and samples as ``config/config.yaml``) three ways and fits every photo with the
workflow's defaults:

- ``as drawn``: the photo of the embedded set (a fifth to a third of it is holes showing the backdrop);
- ``no holes``: the same class with ``open_weave`` off, so the gaps between the yarns are cloth
  (the draw's other random numbers shift, so its roughness and light differ);
- ``half relief``: as drawn with half the yarns' relief and undulation (less thread-scale shadow);

and three times more with the pixels where the backdrop shows marked clipped in the prepared photo
as drawn, so a stage's loss does not see them: in every stage (``holes left out``), from the
material stage on (the geometry stage's fit as drawn kept) and in the normal-map stage alone.
Those pixels are found by rendering the draw, with opaque yarns, over a black backdrop that glows
white and one that does not: a pixel is a hole where more than half of it sees the backdrop. It is
an oracle no photo gives, to locate the fault.
Each row gives the true and fitted roughness, the fitted light's polar angle and azimuth against
the true light (the geometry stage places it), and the re-render PSNR over the pixels the fit saw.
Writes ``<out>/open_weave.{csv,md}`` (default ``results/bench/open_weave`` for gauze,
``results/bench/open_weave_<fabric>`` otherwise) and keeps the fits in ``<out>/run`` (and ``<out>/run_from_*``).
Nothing is chosen here.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import shutil
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pandas as pd
from harness import ROOT, publish, shown, snakemake, validated_config
from light_direction import azimuth_error

import clothscope.synth.generate as generate
from clothscope.core.config import FIT_STAGES
from clothscope.core.imageio import read_png, srgb_to_linear, write_png
from clothscope.fit.outputs import STATE_FILE
from clothscope.prepare.image import CLIPPED_FILE
from clothscope.synth.fabrics import FABRICS

#: the classes whose holes show a backdrop, and the one scored by default
OPEN_WEAVES = tuple(name for name, spec in FABRICS.items() if spec.open_weave)
FABRIC = "cotton_gauze"
DRAWN, MASKED = "as drawn", "holes left out"
#: the sample sheet's ``source`` of every photo: this prefix and its variant
SOURCE = "open_weave.py: "
#: the partly masked variants: the stages refitted with the holes left out, from the fits as drawn before them
FROM_STAGE = {"holes left out from the material stage": ("material", "normals"),
              "holes left out of the normal-map stage": ("normals",)}
#: a pixel is a hole where more than this share of it sees the backdrop (mostly backdrop, not a yarn's edge)
BACKDROP_SHARE = 0.5


def variants(fabric: str) -> dict[str, dict]:
    """How each rendered variant changes the class's FabricSpec."""
    spec = FABRICS[fabric]
    return {"as drawn": {}, "no holes": {"open_weave": False},
            "half relief": {"relief": spec.relief / 2, "undulation": spec.undulation / 2}}


@contextmanager
def changed_spec(fabric: str, change: dict) -> Iterator[None]:
    """Render ``fabric`` with ``change`` applied to its FabricSpec, restoring it afterwards."""
    original = FABRICS[fabric]
    FABRICS[fabric] = dataclasses.replace(original, **change)
    try:
        yield
    finally:
        FABRICS[fabric] = original


@contextmanager
def glowing_backdrop(radiance: float) -> Iterator[None]:
    """Render every backdrop black and glowing at ``radiance``, restoring the generator's scene afterwards: a pixel
    then reads the share of it where the backdrop is seen, whatever light and shadow fall on it."""
    original = generate.scene_dict

    def scene(mi, mesh, camera, light, effects, backdrop, seed):  # noqa: ANN001, ANN202 (the generator's signature)
        built = original(mi, mesh, camera, light, effects, None if backdrop is None else np.zeros(3), seed)
        if "backdrop" in built:
            built["backdrop"]["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": [radiance] * 3}}
        return built

    generate.scene_dict = scene
    try:
        yield
    finally:
        generate.scene_dict = original


def render(fabric: str, dye: str, settings: dict) -> generate.Synthetic:
    """One photo of ``fabric`` of the design seed in ``dye`` (with whatever spec and backdrop are in force)."""
    return generate.synthesize(fabric, list(generate.DYES).index(dye), int(settings["seed"]), int(settings["resolution"]),
                               int(settings["spp"]), int(settings["mesh_resolution"]), "llvm_ad_rgb", 2)


def backdrop_mask(fabric: str, dye: str, settings: dict) -> np.ndarray:
    """Pixels of the photo as drawn where the backdrop shows through a hole (see the module's docstring).

    The two looks are rendered with opaque yarns, so a sheer cloth's own transmission does not count as a hole.
    """
    looks = []
    for radiance in (0.0, 1.0):
        with glowing_backdrop(radiance), changed_spec(fabric, {"sheer": False}):
            looks.append(srgb_to_linear(render(fabric, dye, settings).image.astype(np.float64)))
    return np.abs(looks[1] - looks[0]).mean(axis=2) > BACKDROP_SHARE


def image_id(variant: str, dye: str) -> str:
    """The sample sheet's id of one variant of one dye's draw."""
    return f"{variant.replace(' ', '_')}_{dye}"


def sheet_row(variant: str, dye: str, path: Path, fabric: str) -> dict[str, str]:
    """One row of the benchmark's sample sheet."""
    return {"image_id": image_id(variant, dye), "path": str(path), "fabric_class": fabric, "dye_color": dye,
            "source": SOURCE + variant}


def write_photos(fabric: str, dyes: list[str], folder: Path, settings: dict) -> tuple[Path, dict[str, np.ndarray]]:
    """Render every variant of every dye into ``folder``; returns the sample sheet and the backdrop masks by dye.

    The masked variant's rows name the photos as drawn (same file, another id).
    """
    rows = []
    for name, change in variants(fabric).items():
        with changed_spec(fabric, change):
            for dye in dyes:
                path = folder / fabric / f"{image_id(name, dye)}.png"
                path.parent.mkdir(parents=True, exist_ok=True)
                generate.save(render(fabric, dye, settings), path)
                rows.append(sheet_row(name, dye, path, fabric))
    rows += [sheet_row(MASKED, dye, folder / fabric / f"{image_id(DRAWN, dye)}.png", fabric) for dye in dyes]
    sheet = folder / "samples.tsv"
    pd.DataFrame(rows).to_csv(sheet, sep="\t", index=False)
    return sheet, {dye: backdrop_mask(fabric, dye, settings) for dye in dyes}


def variant_of(sample: pd.Series) -> str:
    """The variant a sample sheet row was rendered as."""
    return str(sample["source"]).removeprefix(SOURCE)


def drawn_photos(samples: pd.DataFrame) -> pd.DataFrame:
    """The rows of the photos as drawn."""
    return samples[samples["source"] == SOURCE + DRAWN]


def mark_clipped(run: Path, masks: dict[str, np.ndarray], variant: str) -> None:
    """Add each dye's backdrop mask to the clipped pixels of its ``variant``'s prepared photo, which every fit stage
    leaves out of its loss."""
    for dye, mask in masks.items():
        path = run / "prepared" / image_id(variant, dye) / CLIPPED_FILE
        clipped = read_png(path) > 0.5
        if clipped.shape != mask.shape:
            raise SystemExit(f"open_weave.py: error: {shown(path)} is {clipped.shape}, the backdrop mask {mask.shape}")
        write_png(path, (clipped | mask).astype(np.float64))


def refit_from(run: Path, folder: Path, stages: tuple[str, ...], samples: pd.DataFrame, masks: dict[str, np.ndarray]) -> None:
    """Refit ``stages`` of the photos as drawn in ``folder`` with the holes left out, from ``run``'s earlier stages."""
    drawn = drawn_photos(samples)
    shutil.rmtree(folder, ignore_errors=True)
    for photo in drawn["image_id"]:
        shutil.copytree(run / "prepared" / photo, folder / "prepared" / photo)
        for stage in FIT_STAGES[:FIT_STAGES.index(stages[0])]:
            shutil.copytree(run / "fit" / photo / stage, folder / "fit" / photo / stage)
    mark_clipped(folder, masks, DRAWN)
    sheet = folder / "samples.tsv"
    drawn.to_csv(sheet, sep="\t", index=False)
    snakemake(["--allowed-rules", *[f"fit_{stage}" for stage in stages], "--config", f"samples={sheet}", f"results={folder}",
               "--", *[str(folder / "fit" / i / "normals") for i in drawn["image_id"]]])


def image_row(run: Path, sample: pd.Series, variant: str | None = None) -> dict:
    """True and fitted roughness, light and PSNR of one fitted photo (``variant``: else its sample sheet's)."""
    truth = json.loads(Path(str(sample["path"]).removesuffix(".png") + ".truth.json").read_text(encoding="utf-8"))
    normals = json.loads((run / "fit" / sample["image_id"] / "normals" / STATE_FILE).read_text(encoding="utf-8"))
    if normals.get("status") != "fitted":
        return {"variant": variant or variant_of(sample), "dye": sample["dye_color"],
                "status": f"{normals.get('status')}: {normals.get('reason', '')}"}
    light = normals["scene"]["light"]
    azimuth = azimuth_error(light["azimuth_deg"], truth["light"]["azimuth_deg"])
    return {"variant": variant or variant_of(sample), "dye": sample["dye_color"],
            "roughness_true": truth["roughness"], "roughness_fitted": normals["material"]["roughness"],
            "light_polar_true": truth["light"]["polar_deg"], "light_polar_fitted": light["polar_deg"],
            "light_azimuth_error": azimuth, "left_out": float(np.mean(read_png(run / "prepared" / sample["image_id"] / CLIPPED_FILE) > 0.5)),
            "psnr_db": normals["psnr_db"], "status": "fitted"}


def markdown(table: pd.DataFrame, fabric: str, sheet: Path, minutes: float) -> str:
    """The report: per-variant medians, then every image (and a line for each photo the workflow did not fit)."""
    failed = table[table["status"] != "fitted"]
    table = table[table["status"] == "fitted"]
    table = table.assign(roughness_error=(table["roughness_fitted"] - table["roughness_true"]).abs(),
                         polar_error=(table["light_polar_fitted"] - table["light_polar_true"]).abs())
    medians = table.groupby("variant", sort=False)[["roughness_true", "roughness_fitted", "roughness_error", "polar_error",
                                                   "light_azimuth_error", "left_out", "psnr_db"]].median()
    lines = [f"# What an open weave's holes cost the fit ({fabric.replace('_', ' ')}, design draws)", "",
             f"{table['dye'].nunique()} draws of the embedded design set, each fitted by the workflow with the defaults as "
             f"rendered and changed ({shown(sheet)}; {minutes:.1f} min on 2 cores). `holes left out`: the photo as drawn, "
             "its hole pixels (more than half of each sees the backdrop, an oracle mask) marked clipped, so no stage's "
             "loss sees them; `... from the material stage` and `... of the normal-map stage`: only those stages "
             "refitted so, from the fits as drawn before them. The light is the one the geometry stage placed; PSNR "
             "is over the pixels the fit saw. Medians:", "",
             "| variant | roughness, true | fitted | error | light polar error (deg) | light azimuth error (deg) | "
             "pixels left out | PSNR (dB) |", "|---|---|---|---|---|---|---|---|"]
    lines += [f"| {v} | {r.roughness_true:.3f} | {r.roughness_fitted:.3f} | {r.roughness_error:.3f} | {r.polar_error:.1f} | "
              f"{r.light_azimuth_error:.1f} | {r.left_out:.1%} | {r.psnr_db:.1f} |" for v, r in medians.iterrows()]
    lines += [f"- not fitted: {r.variant}, {r.dye} ({r.status})" for r in failed.itertuples()]
    lines += ["", "Every image:", "", "| variant | dye | roughness, true | fitted | light polar, true | fitted | "
              "azimuth error | PSNR (dB) |", "|---|---|---|---|---|---|---|---|"]
    lines += [f"| {r.variant} | {r.dye} | {r.roughness_true:.3f} | {r.roughness_fitted:.3f} | {r.light_polar_true:.1f} | "
              f"{r.light_polar_fitted:.1f} | {r.light_azimuth_error:.1f} | {r.psnr_db:.1f} |" for r in table.itertuples()]
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fabric", default=FABRIC, choices=OPEN_WEAVES, help=f"open-weave class (default: {FABRIC})")
    parser.add_argument("--dyes", default=",".join(generate.DYES), help="dyes of its draws (default: all six)")
    parser.add_argument("--out", type=Path, help="report folder (default: results/bench/open_weave[_<fabric>])")
    args = parser.parse_args()
    out = args.out or ROOT / "results" / "bench" / ("open_weave" if args.fabric == FABRIC else f"open_weave_{args.fabric}")
    dyes = [d for d in args.dyes.split(",") if d]
    unknown = sorted(set(dyes) - set(generate.DYES))
    if unknown:
        raise SystemExit(f"open_weave.py: error: unknown dyes {', '.join(unknown)}; known: {', '.join(generate.DYES)}")
    started = time.perf_counter()
    settings = validated_config()["synthesize"]
    sheet, masks = write_photos(args.fabric, dyes, out / "photos", settings)
    run = out / "run"
    shutil.rmtree(run, ignore_errors=True)  # fits of earlier photos or code would pass for current under mtime triggers
    config = [f"samples={sheet}", f"results={run}"]
    snakemake(["--config", *config, "--", *[str(run / "prepared" / image_id(MASKED, dye)) for dye in masks]])
    mark_clipped(run, masks, MASKED)
    samples = pd.read_csv(sheet, sep="\t", dtype=str)
    snakemake(["--config", *config, "--", *[str(run / "fit" / i / "normals") for i in samples["image_id"]]])
    rows = [image_row(run, sample) for _, sample in samples.iterrows()]
    for variant, stages in FROM_STAGE.items():
        folder = out / f"run_from_{stages[0]}"
        refit_from(run, folder, stages, samples, masks)
        rows += [image_row(folder, sample, variant) for _, sample in drawn_photos(samples).iterrows()]
    table = pd.DataFrame(rows)
    publish(out, "open_weave", table, markdown(table, args.fabric, sheet, (time.perf_counter() - started) / 60),
            float_format="%.4f")


if __name__ == "__main__":
    main()
