# Stage 4: Fourier features of each image's normal map (paper section 3.4), one cached
# one-row Parquet file per image and source (and one row per tile of its map, tiles/), then the feature
# table and the tile table (concatenations).
# {source} is the normal source: "fitted" (rule fit_normals) or "truth" (synthetic ground truth).
ruleorder: feature_table > features


rule features:
    input:
        unpack(feature_inputs),
    output:
        row=features_path("{source}", "{image}.parquet"),
        tiles=features_path("{source}", os.path.join("tiles", "{image}.parquet")),
        plot=report(
            features_path("{source}", "{image}.png"),
            caption="../report/spectrum.rst",
            category="Spectra",
            subcategory="{source}",
            labels={"image": "{image}", "source": "{source}"},
        ),
    log:
        os.path.join(RESULTS, "logs", "features", "{source}", "{image}.log"),
    benchmark:
        os.path.join(RESULTS, "benchmarks", "features", "{source}", "{image}.tsv")
    wildcard_constraints:
        image=r"(?!table$)[A-Za-z0-9][A-Za-z0-9_.-]*",
    conda:
        "../../environment.yml"
    threads: 1
    resources:
        mem_mb=1500,
        runtime=5,
    params:
        settings=source_feature_settings,
        fabric_class=lambda wildcards: SAMPLES.loc[wildcards.image, "fabric_class"],
        path=sheet_path,
    script:
        "../scripts/features.py"


rule feature_table:
    input:
        rows=feature_rows,
        tiles=tile_rows,
    output:
        table=features_path("{source}", "table.parquet"),
        tiles=tile_table("{source}"),
    log:
        os.path.join(RESULTS, "logs", "feature_table", "{source}.log"),
    conda:
        "../../environment.yml"
    threads: 1
    resources:
        mem_mb=1000,
        runtime=5,
    script:
        "../scripts/feature_table.py"
