"""The sample sheet: which images to process, and their labels.

A tab-separated file with columns ``image_id``, ``path``, ``fabric_class``
(empty: a query image to classify), ``dye_color`` and ``source``. It is
validated before any job runs; :func:`sheet_from_folder` builds one from a
folder tree ``<root>/<class>/<image>``.
"""
from __future__ import annotations

import csv
import io
import os
from pathlib import Path

import pandas as pd

from clothscope.core.schema import SCHEMA_DIR, InputError, load_schema, validate

#: The sample sheet's schema.
SAMPLES_SCHEMA_PATH = SCHEMA_DIR / "samples.schema.yaml"
COLUMNS = ["image_id", "path", "fabric_class", "dye_color", "source"]
IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".webp", ".exr"}
#: Files beside synthetic images that hold ground truth, never samples.
TRUTH_MARKER = ".truth"


def duplicate_ids(sheet: pd.DataFrame) -> list[str]:
    """Image ids that occur more than once, each listed once."""
    ids = sheet["image_id"]
    return ids[ids.duplicated()].unique().tolist()


def _read_table(path: Path) -> pd.DataFrame:
    try:
        table = pd.read_csv(path, sep="\t", dtype=str, keep_default_na=False, comment="#")
    except FileNotFoundError:
        raise InputError(f"{path}: sample sheet does not exist") from None
    except (pd.errors.EmptyDataError, pd.errors.ParserError, UnicodeDecodeError) as err:
        raise InputError(f"{path}: not a readable TSV sample sheet: {str(err).splitlines()[0]}") from None
    return table


def load_sample_sheet(path: str | os.PathLike[str], schema_path: str | os.PathLike[str]) -> pd.DataFrame:
    """Read and validate a sample sheet.

    Parameters
    ----------
    path
        The TSV file.
    schema_path
        :data:`SAMPLES_SCHEMA_PATH`: column types and defaults.

    Returns
    -------
    pandas.DataFrame
        Indexed by ``image_id``, with every column of :data:`COLUMNS`.

    Raises
    ------
    InputError
        One line naming the file, the row and the problem.
    """
    path = Path(path)
    table = _read_table(path)
    schema = load_schema(schema_path)
    if table.empty:
        raise InputError(f"{path}: sample sheet has no rows")
    unknown = [c for c in table.columns if c not in schema["properties"]]
    if unknown:
        raise InputError(f"{path}: unknown column(s) {', '.join(map(repr, unknown))}; allowed: {', '.join(COLUMNS)}")
    rows = []
    for line, record in enumerate(table.to_dict(orient="records"), start=2):
        cleaned = {k: v.strip() for k, v in record.items() if not (k in ("fabric_class", "dye_color", "source") and v.strip() == "")}
        rows.append(validate(cleaned, schema, f"{path} line {line}"))
    sheet = pd.DataFrame(rows, columns=COLUMNS)
    duplicated = duplicate_ids(sheet)
    if duplicated:
        raise InputError(f"{path}: duplicate image_id(s): {', '.join(duplicated)}")
    return sheet.set_index("image_id", drop=False)


def is_sample_file(path: Path) -> bool:
    """True for image files that are samples (not ground truth or hidden files)."""
    return path.is_file() and path.suffix.lower() in IMAGE_SUFFIXES and TRUTH_MARKER not in path.name and not path.name.startswith(".")


def sheet_from_folder(root: str | os.PathLike[str], source: str = "") -> pd.DataFrame:
    """Build a sample sheet from ``<root>/<class>/<image>``; images directly in ``root`` are queries.

    Ids are ``<class>_<file stem>`` (made safe for file names).

    Raises
    ------
    InputError
        If ``root`` is not a folder, holds no images, or two images map to the same id.
    """
    root = Path(root)
    if not root.is_dir():
        raise InputError(f"{root}: not a folder")
    rows = []
    for image in sorted(p for p in root.rglob("*") if is_sample_file(p)):
        relative = image.relative_to(root)
        fabric_class = relative.parts[0].lower().replace("-", "_").replace(" ", "_") if len(relative.parts) > 1 else ""
        stem = "".join(ch if ch.isalnum() or ch in "_.-" else "_" for ch in image.stem)
        image_id = f"{fabric_class}_{stem}" if fabric_class else stem
        if not image_id[0].isalnum():
            image_id = "img" + image_id
        rows.append({"image_id": image_id, "path": str(image), "fabric_class": fabric_class, "dye_color": "", "source": source})
    if not rows:
        raise InputError(f"{root}: no images found (looked for {', '.join(sorted(IMAGE_SUFFIXES))})")
    sheet = pd.DataFrame(rows, columns=COLUMNS)
    duplicated = duplicate_ids(sheet)
    if duplicated:
        raise InputError(f"{root}: images map to the same id(s): {', '.join(duplicated)}; rename them")
    return sheet


def sheet_to_tsv(sheet: pd.DataFrame) -> str:
    """Serialise a sample sheet to TSV text with the canonical column order."""
    buffer = io.StringIO()
    sheet[COLUMNS].to_csv(buffer, sep="\t", index=False, quoting=csv.QUOTE_MINIMAL, lineterminator="\n")
    return buffer.getvalue()
