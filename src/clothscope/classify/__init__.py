"""Stage 5, rules ``classify``, ``feature_sets``, ``paper_tables`` and ``sweep``.

:mod:`.qda` is the floored QDA, :mod:`.rows` the labelled and query rows of a feature table,
:mod:`.loocv` leave-one-out scoring and the inner choice of feature set, :mod:`.model` the trained
model and its files, :mod:`.reports` the LOOCV reports (:mod:`.outputs` names their files),
:mod:`.job` the ``classify`` rule,
:mod:`.feature_sets` the sets side by side and :mod:`.paper_tables` the paper's experiments."""
