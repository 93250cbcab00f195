"""The sample sheet of a rendered synthetic set (held-out or field), with each image's dye or colour scheme."""
from __future__ import annotations

import json
import os
from pathlib import Path

import pandas as pd

from clothscope.core.atomic import write_text
from clothscope.core.samples import COLUMNS, sheet_to_tsv
from clothscope.core.truth import truth_paths


def colour_of(path: Path) -> str:
    """The dye (held-out set) or dyes and colour scheme (field set) of a rendered image."""
    truth = json.loads(truth_paths(path)["json"].read_text(encoding="utf-8"))
    if "draw" not in truth:
        return truth["dye"]
    scheme, dyes = truth["draw"]["colour_scheme"], truth["draw"]["dyes"]
    if scheme in ("solid", "melange"):  # melange mixes two shades of the first dye
        return dyes[0] if scheme == "solid" else f"melange {dyes[0]}"
    return f"{scheme} {'+'.join(dyes)}"


def dataset_sheet_job(images: list[str | os.PathLike[str]], dataset: str, seed: int, target: str | os.PathLike[str]) -> int:
    """The ``dataset_sheet`` rules: write the sheet of ``images`` (``<root>/<class>/<id>.<ext>``); returns the row count."""
    rows = [{"image_id": path.stem, "path": str(path), "fabric_class": path.parent.name, "dye_color": colour_of(path),
             "source": f"{dataset} seed={seed}"} for path in map(Path, images)]
    write_text(target, sheet_to_tsv(pd.DataFrame(rows, columns=COLUMNS)))
    return len(rows)
