"""The synthetic benchmark's scoring: the fit against ground truth (:mod:`.accuracy`, rule
``fit_accuracy``) and predictions under rotation, zoom and hue shift (:mod:`.invariance`)."""
