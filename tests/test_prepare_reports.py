"""The run-level prepare reports: the status table and the line on where the threads landed against the band."""
from __future__ import annotations

import pandas as pd

from clothscope.core.atomic import write_json
from clothscope.prepare.image import STATUS_FILE
from clothscope.prepare.rejections import prepare_table, thread_scale_line, write_prepare_reports


def _prepared(root, image_id: str, status: str = "accepted", working: float | None = None, method: str = "threads"):
    """A prepared folder holding only the status record ``prepare`` writes."""
    scale = {"method": method, "crop_px": 256}
    if method == "threads":
        scale["period_band"] = [8.0, 16.0]
        if working is not None:
            scale["working_period_px"] = working
    record = {"image_id": image_id, "path": f"photos/{image_id}.jpg", "status": status,
              "reason": "" if status == "accepted" else "62% of the image is clipped (limit 50%)",
              "clipped_fraction": 0.0, **({"scale": scale} if status == "accepted" else {})}
    folder = root / image_id
    write_json(folder / STATUS_FILE, record)
    return folder


def test_the_status_table_keeps_each_photo_s_working_period_and_band(tmp_path):
    folders = [_prepared(tmp_path, "fine", working=2.7), _prepared(tmp_path, "none"),
               _prepared(tmp_path, "clipped", status="rejected")]
    table = prepare_table(folders).set_index("image_id")
    assert table.at["fine", "working_period_px"] == 2.7 and table.at["fine", "period_band_px"] == "8-16"
    assert table.at["none", "working_period_px"] == "" and table.at["clipped", "period_band_px"] == ""


def test_the_thread_scale_line_counts_accepted_photos_against_the_band_after_a_round_trip(tmp_path):
    folders = [_prepared(tmp_path / "p", name, working=period)
               for name, period in (("a", 2.7), ("b", 5.0), ("c", 11.3), ("d", 30.0), ("e", None))]
    folders.append(_prepared(tmp_path / "p", "f", status="rejected"))
    summary = tmp_path / "prepared.tsv"
    assert write_prepare_reports(folders, str(tmp_path / "rejected.tsv"), str(summary)) == (5, 1)
    line = thread_scale_line(pd.read_csv(summary, sep="\t", dtype={"period_band_px": str}))
    assert line.startswith("Thread scale (prepare): of 5 accepted photos, 1 show threads in the band the fit is made "
                           "for (8-16 px at the working resolution), 2 finer even at full native resolution (1 of them "
                           "under 4 px")
    assert line.endswith("(1 of them under 4 px), 1 coarser, and 1 no lattice the period could be read from.")


def test_no_thread_scale_line_where_prepare_measured_no_period(tmp_path):
    framed = prepare_table([_prepared(tmp_path, "a", method="frame"), _prepared(tmp_path, "b", method="frame")])
    assert thread_scale_line(framed) == ""
    assert thread_scale_line(prepare_table([_prepared(tmp_path, "c", status="rejected")])) == ""
    older = prepare_table([_prepared(tmp_path, "d", working=11.0)]).drop(columns=["working_period_px", "period_band_px"])
    assert thread_scale_line(older) == ""  # a prepared.tsv written before the columns existed
