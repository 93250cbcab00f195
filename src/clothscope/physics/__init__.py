"""Stage 6, rule ``physics``: the measured ArcSim material of each image's class
(:mod:`.materials`), written from the classifier's records (:mod:`.job`)."""
