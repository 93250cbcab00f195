"""Snakemake job: the sample sheet of a rendered synthetic set (held-out or field), paths as rendered."""
import json
from pathlib import Path

import pandas as pd

from clothscope.core.atomic import write_text
from clothscope.core.joblog import job_log
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


with job_log(snakemake.log[0], snakemake.rule) as log:
    rows = [{"image_id": path.stem, "path": str(path), "fabric_class": path.parent.name, "dye_color": colour_of(path),
             "source": f"{snakemake.params.dataset} seed={snakemake.params.seed}"}
            for path in map(Path, snakemake.input)]
    write_text(snakemake.output[0], sheet_to_tsv(pd.DataFrame(rows, columns=COLUMNS)))
    log.info("%d images, seed %d", len(rows), snakemake.params.seed)
