"""Per-image feature rows (paper section 3.4) and the feature table.

One row per sample-sheet image and *source*. A source gives a 2-D map for
the paper's Algorithm 2 (a normal map, or a grey-level image), a scalar field
for the thread-structure descriptor (:mod:`clothscope.features.structure`: a relief, a
shading or a luminance) and, where there is one, the BSDF:

* ``fitted``: the inverse renderer's output, ``results/fit/<id>/normals/``
  (``state.json``: status, ``material`` {base_color, specular, roughness},
  ``texels_per_pixel``, ``runtime.mitsuba_variant``; ``normal.exr``: float32
  unit normals, read raw through Mitsuba's Bitmap, *not* through
  :func:`clothscope.core.imageio.decode_exr`, which clamps negative values to 0
  as it is meant for radiance; ``height.exr``, the height map the normals are derived from); the
  structure descriptor reads the height map or the normals lit by the fitted light
  (``features.fitted_field``, :func:`lit_normals`);
* ``truth``: the ground truth beside a synthetic image
  (:func:`clothscope.core.truth.truth_paths`: ``<stem>.truth-normal.png``,
  ``<stem>.truth-height.png`` and ``<stem>.truth.json``), which needs no fitting;
* ``photo``: the prepared photo alone, no inverse rendering
  (``results/prepared/<id>/image.exr``): its linear luminance is both the
  grey-level map of Algorithm 2 and the field of the structure descriptor;
  roughness and specular are 0 (constant columns, which the classifier drops).

Columns (:func:`feature_schema`, an explicit pyarrow schema):

* identity and provenance: ``image_id``, ``fabric_class`` (empty for a
  query), ``status`` (``ok``, or ``skipped`` / ``failed`` from the fit, or
  ``missing`` when the ground truth is absent), ``reason`` (one line, empty
  when ok), ``normal_source``, ``mitsuba_variant`` (from the fit state;
  ``"truth"`` in truth mode), ``config_hash`` (:func:`config_hash`),
  ``clothscope_version`` and ``texels_per_pixel``;
* the paper's features: ``roughness``; ``specular_norm``, the norm of the
  specular reflectance: our principled BSDF has one scalar ``specular`` *s*
  applied equally to R, G and B, so the reflectance vector is (s, s, s) and
  its Euclidean norm is ``sqrt(3) * s`` (:func:`specular_norm`; a constant
  factor, so the standardised classifier sees exactly the information in
  *s*); ``r_1..r_n``, ``z_1..z_n`` and ``n_peaks``
  (:func:`clothscope.features.paper.analyse_normal_map`);
* ``unexplained`` (:data:`FIT_COLUMNS`), the natural log of the share of the photo's variance that the fit's
  re-render leaves unexplained (``state.json``'s ``unexplained_share``,
  :func:`clothscope.fit.target.unexplained_share`): what the fit model cannot render, such as holes over a
  backdrop, sheer yarn or an anisotropic sheen; 0 on photo and truth rows (a constant column);
* this project's thread-structure descriptor, ``s_*``
  (:data:`clothscope.features.structure.STRUCTURE_COLUMNS`), its weave rings ``w_*``
  (:data:`clothscope.features.structure.WEAVE_COLUMNS`), its spectrum rings ``p_*``
  (:data:`clothscope.features.structure.SPECTRUM_COLUMNS`), and the plain texture
  baseline ``lbp_*`` (:data:`clothscope.features.structure.LBP_COLUMNS`), both of the
  source's field (the LBP at the canonical thread period, or at its pixels with
  ``features.structure.lbp_scale: pixels``); ``a_*``, the structure descriptor of the fitted shade
  texture (:data:`clothscope.features.structure.SHADE_COLUMNS`; zero without one);
* with ``extras: true`` only, the ``x_*`` columns of
  :func:`clothscope.features.extras.extra_features` and :func:`surface_features`.
  ``x_period_px`` (thread period in photo pixels) is deliberately *not*
  scale-invariant: it separates classes by thread density, and a photo taken
  at another zoom moves it.

A row that is not ``ok`` has zero-filled features (never NaN) and is never
used for training or scoring.

*Tile rows* (:func:`tile_schema`, ``features/<source>/tiles/``): with
``features.tiles.grid`` > 0, each usable image also gets one row per tile of
its field (:func:`clothscope.features.tiles.tile_fields`), and one per
view of it turned or zoomed (``features.tiles.turns`` and ``zooms``,
:func:`clothscope.features.tiles.view_fields`), with
``image_id``, ``tile`` and the :data:`TILE_FEATURES` (``s_*``, ``w_*``, ``p_*`` and ``lbp_*``)
of that tile; the classifier trains on them as extra rows of their image
(:func:`clothscope.classify.rows.with_tiles`).
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from clothscope import __version__
from clothscope.core.atomic import write_with
from clothscope.features.extras import extra_features
from clothscope.features.paper import SpectrumResult, SpectrumSettings, analyse_normal_map
from clothscope.features.plots import plot_analysis, plot_placeholder
from clothscope.features.sources import STATUS_OK, descriptor_period, finite_number, load_normal_input, unusable_input
from clothscope.features.structure import (
    LBP_COLUMNS,
    SHADE_COLUMNS,
    SPECTRUM_COLUMNS,
    STRUCTURE_COLUMNS,
    TILE_FEATURES,
    WEAVE_COLUMNS,
    StructureSettings,
    shade_features,
    texture_columns,
)
from clothscope.features.tiles import TileSettings, tile_columns

#: Keys of the ``features:`` config section that are SpectrumSettings fields.
SPECTRUM_KEYS = tuple(f.name for f in dataclasses.fields(SpectrumSettings))
#: Extra feature columns (spectrum.extra_features and surface_features), present only with ``extras: true``.
EXTRA_COLUMNS = ("x_angle_deg", "x_low_radius_ratio", "x_strong_to_low_radius", "x_flatness", "x_peak_fraction",
                 "x_tilt_mean_deg", "x_tilt_anisotropy", "x_period_px")
#: Provenance columns, in table order, with their types.
PROVENANCE = (
    ("image_id", pa.string()),
    ("fabric_class", pa.string()),
    ("status", pa.string()),
    ("reason", pa.string()),
    ("normal_source", pa.string()),
    ("mitsuba_variant", pa.string()),
    ("config_hash", pa.string()),
    ("clothscope_version", pa.string()),
    ("texels_per_pixel", pa.float64()),
)


def tile_schema() -> pa.Schema:
    """The explicit schema of tile rows: ``image_id``, ``tile`` (0 .. grid^2 - 1 the tiles, then the views) and :data:`TILE_FEATURES`."""
    fields = [pa.field("image_id", pa.string(), nullable=False), pa.field("tile", pa.int64(), nullable=False)]
    fields += [pa.field(name, pa.float64(), nullable=False) for name in TILE_FEATURES]
    return pa.schema(fields, metadata={b"clothscope_version": __version__.encode()})


def tile_rows(image_id: str, field: np.ndarray, structure: StructureSettings, tiles: TileSettings,
              period_px: float | None = None) -> list[dict[str, Any]]:
    """One row per tile and view of the field (:func:`clothscope.features.tiles.tile_columns`); none without either."""
    return [{"image_id": str(image_id), "tile": k, **{name: finite_number(values[name], name) for name in TILE_FEATURES}}
            for k, values in tile_columns(field, structure, tiles, period_px).items()]


def tile_settings(tiles_config: dict[str, Any]) -> TileSettings:
    """:class:`~clothscope.features.tiles.TileSettings` from ``features.tiles`` of the validated config."""
    return TileSettings(int(tiles_config["grid"]), float(tiles_config["size"]),
                        tuple(float(t) for t in tiles_config["turns"]), tuple(float(z) for z in tiles_config["zooms"]))


def specular_norm(specular: float) -> float:
    """Norm of the grey specular reflectance (s, s, s): ``sqrt(3) * s``."""
    return math.sqrt(3.0) * float(specular)


def spectrum_settings(features_config: dict[str, Any]) -> SpectrumSettings:
    """The :class:`SpectrumSettings` of a validated ``features:`` config section (other keys ignored)."""
    return SpectrumSettings(**{k: features_config[k] for k in SPECTRUM_KEYS})


def structure_settings(features_config: dict[str, Any]) -> StructureSettings:
    """The :class:`StructureSettings` of a validated ``features:`` config section."""
    return StructureSettings(**features_config["structure"])


def row_settings(features_config: dict[str, Any], source: str | None = None) -> dict[str, Any]:
    """The part of a ``features:`` section that changes a row of ``source`` (of any source when None).

    Everything but ``normal_source``; ``fitted_field`` only for the ``fitted`` source, ``photo_field`` only for ``photo``,
    ``period_source`` not for ``truth``.
    """
    skipped = {"normal_source"}
    if source == "truth":
        skipped.add("period_source")
    if source not in (None, "fitted"):
        skipped.add("fitted_field")
    if source not in (None, "photo"):
        skipped.add("photo_field")
    return {k: v for k, v in sorted(features_config.items()) if k not in skipped}


def config_hash(features_config: dict[str, Any], source: str) -> str:
    """12 hex digits identifying the feature settings and the normal source of a row."""
    payload = json.dumps({"features": row_settings(features_config, source), "normal_source": source}, sort_keys=True, default=str)
    return hashlib.sha256(payload.encode("utf-8")).hexdigest()[:12]


#: Columns of what the fit left unexplained (fitted rows; 0 elsewhere).
FIT_COLUMNS = ("unexplained",)


def paper_feature_columns(n_peaks: int) -> list[str]:
    """The paper's features: roughness, specular_norm, r_1..r_n, z_1..z_n, n_peaks."""
    return ["roughness", "specular_norm", *[f"r_{k}" for k in range(1, n_peaks + 1)],
            *[f"z_{k}" for k in range(1, n_peaks + 1)], "n_peaks"]


def feature_columns(n_peaks: int, extras: bool) -> list[str]:
    """Every feature column of a table: the paper's, what the fit left unexplained, the structure descriptor's with its
    weave and spectrum rings, the LBP baseline's, the shade's, the extras."""
    return (paper_feature_columns(n_peaks) + list(FIT_COLUMNS) + list(STRUCTURE_COLUMNS) + list(WEAVE_COLUMNS) + list(SPECTRUM_COLUMNS)
            + list(LBP_COLUMNS) + list(SHADE_COLUMNS)
            + (list(EXTRA_COLUMNS) if extras else []))


def feature_schema(n_peaks: int, extras: bool) -> pa.Schema:
    """The explicit schema of feature rows and tables."""
    fields = [pa.field(name, kind, nullable=False) for name, kind in PROVENANCE]
    for name in feature_columns(n_peaks, extras):
        fields.append(pa.field(name, pa.int64() if name == "n_peaks" else pa.float64(), nullable=False))
    return pa.schema(fields, metadata={b"clothscope_version": __version__.encode()})


def _row(image_id: str, fabric_class: str | None, settings: SpectrumSettings, extras: bool, provenance: dict[str, Any],
         roughness: float, specular: float, features: dict[str, float], extra: dict[str, float],
         structure: dict[str, float]) -> dict[str, Any]:
    row: dict[str, Any] = {
        "image_id": str(image_id),
        "fabric_class": "" if fabric_class is None or (isinstance(fabric_class, float) and math.isnan(fabric_class))
        else str(fabric_class).strip(),
        "status": STATUS_OK,
        "reason": "",
        "normal_source": "truth",
        "mitsuba_variant": "truth",
        "config_hash": "",
        "clothscope_version": __version__,
        "texels_per_pixel": 1.0,
    }
    row.update(provenance)
    row["reason"] = " ".join(str(row["reason"]).split())
    row["roughness"] = finite_number(roughness, "roughness")
    row["specular_norm"] = specular_norm(finite_number(specular, "specular"))
    for name in paper_feature_columns(settings.n_peaks)[2:]:
        value = features.get(name, 0.0)
        row[name] = int(round(value)) if name == "n_peaks" else finite_number(value, name)
    for name in (*FIT_COLUMNS, *STRUCTURE_COLUMNS, *WEAVE_COLUMNS, *SPECTRUM_COLUMNS, *LBP_COLUMNS, *SHADE_COLUMNS):
        row[name] = finite_number(structure.get(name, 0.0), name)
    if extras:
        for name in EXTRA_COLUMNS:
            row[name] = finite_number(extra.get(name, 0.0), name)
    return row


def surface_features(normals: np.ndarray, result: SpectrumResult, texels_per_pixel: float) -> dict[str, float]:
    """Extras from the normal map itself: mean tilt, tilt anisotropy and the thread period in photo pixels.

    ``x_tilt_mean_deg``: mean angle between normal and surface normal (relief depth);
    ``x_tilt_anisotropy``: smaller over larger eigenvalue of the second moment of
    (n_x, n_y), in [0, 1] (1 = isotropic relief, rotation-invariant);
    ``x_period_px``: dominant spectral period in photo pixels (0 without a peak).
    """
    if normals.ndim != 3:
        return {"x_tilt_mean_deg": 0.0, "x_tilt_anisotropy": 0.0, "x_period_px": 0.0}
    nx, ny, nz = normals[..., 0], normals[..., 1], normals[..., 2]
    tilt = float(np.degrees(np.arccos(np.clip(nz, -1.0, 1.0))).mean())
    moment = np.array([[np.mean(nx * nx), np.mean(nx * ny)], [np.mean(nx * ny), np.mean(ny * ny)]])
    low, high = np.linalg.eigvalsh(moment)
    period = result.dominant_period_px
    return {"x_tilt_mean_deg": tilt, "x_tilt_anisotropy": float(low / high) if high > 1e-12 else 0.0,
            "x_period_px": float(period / texels_per_pixel) if period and texels_per_pixel > 0 else 0.0}


def compute_row(image_id: str, fabric_class: str | None, normals: np.ndarray, field: np.ndarray, roughness: float,
                specular: float, settings: SpectrumSettings, structure: StructureSettings, extras: bool,
                shade: np.ndarray | None = None, period_px: float | None = None, unexplained: float = 0.0,
                **provenance: Any) -> tuple[dict[str, Any], SpectrumResult]:
    """:func:`feature_row` and the :class:`SpectrumResult` it came from (for the plot); ``period_px``: the field's
    thread period measured elsewhere (:func:`clothscope.features.structure.structure_features`); ``unexplained``:
    the fit's log unexplained share (:data:`FIT_COLUMNS`)."""
    result = analyse_normal_map(normals, settings)
    extra = {}
    if extras:
        extra = extra_features(result) | surface_features(np.asarray(normals), result, float(provenance.get("texels_per_pixel", 1.0)))
    described = texture_columns(field, structure, period_px) | shade_features(shade, structure) | {"unexplained": unexplained}
    row = _row(image_id, fabric_class, settings, extras, provenance, roughness, specular, result.features, extra, described)
    return row, result


def feature_row(image_id: str, fabric_class: str | None, normals: np.ndarray, field: np.ndarray, roughness: float,
                specular: float, settings: SpectrumSettings, structure: StructureSettings, extras: bool,
                **provenance: Any) -> dict[str, Any]:
    """One image's feature row.

    Parameters
    ----------
    image_id, fabric_class
        From the sample sheet; an empty class marks a query.
    normals
        (N, N, 3) tangent-space unit normals (or an (N, N) z map).
    field
        (H, W) scalar field of the structure descriptor (relief, shading or luminance).
    roughness, specular
        The BSDF's roughness and scalar specular *s* (``specular_norm = sqrt(3) * s``).
    settings
        Spectrum analysis settings.
    structure
        Structure descriptor settings.
    extras
        Also compute the ``x_*`` extra features.
    **provenance
        Overrides of the provenance columns (``normal_source``,
        ``mitsuba_variant``, ``config_hash``, ``texels_per_pixel``, ...).

    Returns
    -------
    dict
        Column name to value, in :func:`feature_schema` order; every number finite.

    Raises
    ------
    ValueError
        On an unusable normal map or non-finite roughness / specular.
    """
    return compute_row(image_id, fabric_class, normals, field, roughness, specular, settings, structure, extras,
                       **provenance)[0]


def unusable_row(image_id: str, fabric_class: str | None, settings: SpectrumSettings, extras: bool, status: str, reason: str,
                 **provenance: Any) -> dict[str, Any]:
    """A row for an image without usable features: ``status`` and ``reason`` set, features zero-filled."""
    if status == STATUS_OK:
        raise ValueError("an unusable row needs a status other than 'ok'")
    return _row(image_id, fabric_class, settings, extras, {**provenance, "status": status, "reason": reason or status},
                0.0, 0.0, {}, {}, {})


# --------------------------------------------------------------------------- rows, tables and plots


def row_table(rows: list[dict[str, Any]], schema: pa.Schema) -> pa.Table:
    """Rows as a pyarrow table of ``schema`` (extra keys are an error)."""
    names = schema.names
    for row in rows:
        if set(row) != set(names):
            raise ValueError(f"row {row.get('image_id')!r} has columns {sorted(row)}, schema expects {names}")
    return pa.Table.from_pylist([{k: row[k] for k in names} for row in rows], schema=schema)


def write_rows(rows: list[dict[str, Any]], schema: pa.Schema, target: str | os.PathLike[str]) -> None:
    """Write rows as Parquet, atomically."""
    table = row_table(rows, schema)
    write_with(target, lambda tmp: pq.write_table(table, tmp))


def concat_rows(paths: list[str | os.PathLike[str]]) -> pa.Table:
    """Concatenate one-row Parquet files into one table; their schemas must agree."""
    if not paths:
        raise ValueError("no feature rows to concatenate")
    tables = [pq.read_table(p) for p in paths]
    schema = tables[0].schema
    for path, table in zip(paths, tables):
        if not table.schema.equals(schema, check_metadata=False):
            raise ValueError(f"{path}: schema differs from {paths[0]}; rerun the features rule for every image")
    table = pa.concat_tables(tables)
    ids = table.column("image_id").to_pylist()
    if len(set(ids)) != len(ids):
        raise ValueError("feature rows repeat an image_id")
    return table


def feature_table_job(rows: list[str | os.PathLike[str]], target: str | os.PathLike[str],
                      tiles: list[str | os.PathLike[str]], tiles_target: str | os.PathLike[str]) -> pa.Table:
    """The ``feature_table`` rule: the one-row files of :func:`features_job` concatenated into one Parquet table,
    and its tile files into ``tiles_target``, each atomically."""
    table = concat_rows(rows)
    tile_table = pa.concat_tables([pq.read_table(p).cast(tile_schema()) for p in tiles]) if tiles else tile_schema().empty_table()
    write_with(tiles_target, lambda tmp: pq.write_table(tile_table, tmp))
    write_with(target, lambda tmp: pq.write_table(table, tmp))
    return table


def read_table(path: str | os.PathLike[str]):
    """A feature table as a pandas DataFrame."""
    return pq.read_table(path).to_pandas()


def features_job(image_id: str, fabric_class: str | None, source: str, image_path: str, source_dir: str | None,
                 features_config: dict[str, Any], row_path: str, plot_path: str, log: Any = None,
                 tiles_path: str | None = None, prepared_dir: str | None = None) -> dict[str, Any]:
    """The ``features`` rule for one image: load its source, write the one-row Parquet, the plot and,
    with ``tiles_path``, the rows of its tiles (none for an unusable image). ``prepared_dir``: the prepared
    photo, whose thread period the photo and fitted maps' descriptor take with ``period_source: prepare``."""
    settings = spectrum_settings(features_config)
    structure = structure_settings(features_config)
    extras = bool(features_config["extras"])
    schema = feature_schema(settings.n_peaks, extras)
    loaded = load_normal_input(source, image_path, source_dir, features_config.get("fitted_field"),
                               features_config.get("photo_field"))  # a row's settings hold only its own source's field
    provenance = {"normal_source": source, "mitsuba_variant": loaded.mitsuba_variant or "unknown",
                  "config_hash": config_hash(features_config, source), "texels_per_pixel": loaded.texels_per_pixel}
    title = f"{image_id} ({fabric_class or 'query'}, {source} {features_config['photo_field'] if source == 'photo' else 'normals'})"
    row, result, tiles = None, None, []
    if loaded.status == STATUS_OK:
        try:
            period = None if source == "truth" else descriptor_period(  # a truth row's settings lack period_source
                source, prepared_dir, loaded.texels_per_pixel, features_config["period_source"])
            row, result = compute_row(image_id, fabric_class, loaded.normals, loaded.field, loaded.roughness,
                                      loaded.specular, settings, structure, extras, loaded.shade, period,
                                      loaded.unexplained, **provenance)
            tiles = tile_rows(image_id, loaded.field, structure, tile_settings(features_config["tiles"]),
                              period) if tiles_path else []
        except ValueError as err:
            row, result, tiles = None, None, []
            loaded = unusable_input("failed", f"spectrum analysis: {err}", loaded.mitsuba_variant)
    if row is None:
        row = unusable_row(image_id, fabric_class, settings, extras, loaded.status, loaded.reason, **provenance)
    if tiles_path is not None:
        write_rows(tiles, tile_schema(), tiles_path)
    write_rows([row], schema, row_path)
    if result is not None:
        plot_analysis(result, plot_path, title=title)
    else:
        plot_placeholder(plot_path, title, f"{row['status']}: {row['reason']}")
    if log is not None:
        log.info("%s: %s %s", image_id, row["status"], row["reason"])
    return row
