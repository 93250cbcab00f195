"""Snakemake job: the sample sheet of the held-out synthetic set (paths as rendered by rule synthesize)."""
from pathlib import Path

import pandas as pd

from clothscope.atomic import write_text
from clothscope.joblog import job_log
from clothscope.samples import COLUMNS, sheet_to_tsv

with job_log(snakemake.log[0], "holdout_set") as log:
    rows = []
    for path in map(Path, snakemake.input):
        fabric = path.parent.name
        rows.append({"image_id": path.stem, "path": str(path), "fabric_class": fabric,
                     "dye_color": path.stem.removeprefix(f"{fabric}_"), "source": f"synthetic seed={snakemake.params.seed}"})
    write_text(snakemake.output[0], sheet_to_tsv(pd.DataFrame(rows, columns=COLUMNS)))
    log.info("%d held-out images, seed %d", len(rows), snakemake.params.seed)
