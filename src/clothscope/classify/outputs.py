"""The names of the files the ``classify`` rule writes into ``results/reports/<source>/``, and of the model folder's.

A module of constants only, so the Snakefile can read them without importing scikit-learn.
"""

#: Files of a source's reports folder (``results/reports/<source>/``) that the ``classify`` rule writes.
ACCURACY_FILE = "accuracy.json"
CONFUSION_CSV_FILE = "confusion.csv"
CONFUSION_FILE = "confusion.png"
PER_CLASS_FILE = "per_class.csv"
PREDICTIONS_FILE = "predictions.csv"
IMAGES_FILE = "images.tsv"
SUMMARY_FILE = "summary.md"
#: Each image's record (status, prediction, posteriors), which the ``physics`` rule reads.
RECORDS_FILE = "records.json"
#: Every report of the ``classify`` rule, and those shown in the Snakemake report (``snakemake --report``).
REPORT_FILES = (ACCURACY_FILE, CONFUSION_CSV_FILE, CONFUSION_FILE, PER_CLASS_FILE, PREDICTIONS_FILE, IMAGES_FILE, SUMMARY_FILE)
IN_SNAKEMAKE_REPORT = (SUMMARY_FILE, CONFUSION_FILE, PER_CLASS_FILE)
#: The physics table a trained model is used with, kept in its folder (``results/models/<source>/``) by the
#: ``physics`` rule, so that ``clothscope predict`` needs neither ``config/physics.yaml`` nor the clone.
MODEL_PHYSICS_FILE = "physics.json"
