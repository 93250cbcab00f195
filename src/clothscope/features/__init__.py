"""Stage 4, rules ``features`` and ``feature_table``: one feature row per image and source.

:mod:`.sources` loads the maps (ground truth, a fit, or the photo), :mod:`.paper` is the paper's
Algorithm 2, :mod:`.period` the thread period, :mod:`.extras` and :mod:`.structure` the other
descriptors, :mod:`.table` the rows and the Parquet table, :mod:`.plots` the figures and
:mod:`.diagnosis` the fitted-against-true spectra report (rule ``spectra_diagnosis``)."""
