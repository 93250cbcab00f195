"""Command line: ``clothscope predict``, ``clothscope sheet`` and ``clothscope synthesize``.

Errors are printed as one line (``clothscope: error: ...``) with exit code 2.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import pandas as pd

from clothscope import __version__
from clothscope.core.atomic import write_text
from clothscope.core.config import schema_defaults
from clothscope.core.samples import COLUMNS, sheet_from_folder, sheet_to_tsv
from clothscope.core.schema import InputError


def cmd_sheet(args: argparse.Namespace) -> None:
    """Print (or write) a sample sheet built from a folder tree <root>/<class>/<image>."""
    text = sheet_to_tsv(sheet_from_folder(args.root, source=args.source))
    if args.output:
        write_text(args.output, text)
    else:
        sys.stdout.write(text)


def cmd_synthesize(args: argparse.Namespace) -> None:
    """Regenerate the synthetic dataset (all of it, or the ids given) into a folder."""
    # here, not at the top: the renderer's imports add ~1.5 s to every command, `clothscope sheet` included
    from clothscope.synth.generate import dataset_index, save, synthesize

    wanted = set(args.ids or [])
    out = Path(args.out)
    started = time.perf_counter()
    rows = []
    for fabric, dye_index, image_id in dataset_index(args.colors_per_class):
        path = out / fabric / f"{image_id}.png"
        rows.append({"image_id": image_id, "path": str(path), "fabric_class": fabric,
                     "dye_color": image_id.removeprefix(f"{fabric}_"), "source": f"synthetic seed={args.seed}"})
        if wanted and image_id not in wanted:
            continue
        image = synthesize(fabric, dye_index, args.seed, args.resolution, args.spp, args.mesh_resolution, args.variant, args.threads)
        save(image, path)
        print(f"{image_id}\t{image.truth['provenance']['render_seconds']:.2f} s", flush=True)
    if args.sheet:
        write_text(args.sheet, sheet_to_tsv(pd.DataFrame(rows, columns=COLUMNS)))
    print(f"total\t{time.perf_counter() - started:.1f} s")


def cmd_predict(args: argparse.Namespace) -> int:
    """Classify photos with a trained model; one line per photo. Exit 1 when no photo could be classified."""
    # here, not at the top: the fit stack's imports add ~1.5 s to every command, `clothscope sheet` included
    import logging

    from tqdm import tqdm

    from clothscope.classify.model import load_model
    from clothscope.predict import STAGES, Prediction, model_physics_table, model_sources, predict_photo, unique_ids

    model = load_model(args.model)
    physics = model_physics_table(model, args.model, args.physics)
    out = Path(args.out)
    log_path = out / "predict.log"
    out.mkdir(parents=True, exist_ok=True)
    log = logging.getLogger("clothscope.predict")
    log.handlers[:] = [logging.FileHandler(log_path, encoding="utf-8")]
    log.setLevel(logging.INFO)
    log.propagate = False
    stages = [s for s in STAGES if args.render or "fitted" in model_sources(model) or not s.startswith("fit_")]
    results: list[Prediction] = []
    for photo, image_id in zip(args.photos, unique_ids(args.photos)):
        with tqdm(total=len(stages), desc=image_id, unit="stage", leave=False, disable=args.quiet) as bar:
            def step(stage: str) -> None:
                bar.n = stages.index(stage)
                bar.set_postfix_str(stage)

            try:
                result = predict_photo(photo, image_id, model, physics, out, args.threads, log, step, args.render)
            except (ValueError, OSError) as err:
                result = Prediction(photo, image_id, None, None, None, str(err).splitlines()[0])
        results.append(result)
        if result.predicted_class is None:
            print(f"{photo}\tnot classified\t{result.reason}", flush=True)
        else:
            print(f"{photo}\t{result.predicted_class}\t{result.posterior:.3f}\t{result.physics_path}", flush=True)
            if result.note:
                log.info("%s: %s", photo, result.note)
                print(f"clothscope: note: {photo}: {result.note}", file=sys.stderr, flush=True)
    return 0 if any(r.predicted_class for r in results) else 1


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="clothscope", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"clothscope {__version__}")
    commands = parser.add_subparsers(dest="command", required=True)
    pred = commands.add_parser("predict", help="fabric class and physics of photos, with a model the workflow trained",
                               description="Prepares each photo, fits it (when the model reads fitted-map "
                                           "features, or with --render), computes its features with the settings the model was trained "
                                           "with, and prints one tab-separated line per photo: photo, class, posterior, "
                                           "physics JSON (or 'not classified' and the reason). Exit code 0 when any "
                                           "photo was classified, 1 when none was, 2 when the model is missing or bad.")
    pred.add_argument("photos", nargs="+", metavar="PHOTO", help="PNG, JPEG, TIFF, BMP, WebP or OpenEXR files")
    pred.add_argument("--model", default="results/models/fitted",
                      help="folder with model.json and model.npz, written by the workflow's classify rule "
                           "(default: results/models/fitted; make it with: snakemake --cores 2)")
    pred.add_argument("--out", default="predictions", help="receives one folder per photo (default: predictions)")
    pred.add_argument("--physics", help="fabric class -> ArcSim table (default: physics.json in the model folder, else the path its record names)")
    pred.add_argument("--threads", type=int, default=None, help="Dr.Jit threads of the fit (default: all cores)")
    pred.add_argument("--render", action="store_true",
                      help="fit every photo, also when the model reads only the photo: the BRDF, normal map and scene for a renderer")
    pred.add_argument("--quiet", action="store_true", help="no progress bars")
    pred.set_defaults(func=cmd_predict)
    sheet = commands.add_parser("sheet", help="build a sample sheet from <root>/<class>/<image>")
    sheet.add_argument("root", help="folder whose sub-folders are fabric classes")
    sheet.add_argument("-o", "--output", help="write the TSV here instead of standard output")
    sheet.add_argument("--source", default="", help="value of the 'source' column")
    sheet.set_defaults(func=cmd_sheet)
    synth = commands.add_parser("synthesize", help="render the synthetic dataset with ground truth")
    synth.add_argument("--out", default="data/synthetic", help="output folder (default: data/synthetic)")
    defaults = schema_defaults()  # the config schema's, as the workflow's synthesize rule
    synth.add_argument("--seed", type=int, default=defaults["synthesize"]["seed"])
    synth.add_argument("--resolution", type=int, default=defaults["synthesize"]["resolution"])
    synth.add_argument("--spp", type=int, default=defaults["synthesize"]["spp"])
    synth.add_argument("--mesh-resolution", type=int, default=defaults["synthesize"]["mesh_resolution"])
    synth.add_argument("--colors-per-class", type=int, default=defaults["synthesize"]["colors_per_class"])
    synth.add_argument("--variant", default=defaults["variant"])
    synth.add_argument("--threads", type=int, default=None)
    synth.add_argument("--sheet", help="also write the sample sheet of the generated set here")
    synth.add_argument("ids", nargs="*", help="only these image ids")
    synth.set_defaults(func=cmd_synthesize)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except (InputError, ValueError, OSError) as err:
        print(f"clothscope: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    raise SystemExit(main())
