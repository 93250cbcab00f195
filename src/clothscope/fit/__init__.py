"""Inverse rendering of one prepared photo in three cached stages.

``geometry`` (64 x 64 plane mesh, Large Steps), ``material`` (base colour,
specular, roughness) and ``normals`` (height-map-derived normal map, then a
joint refinement with the BSDF). :mod:`.model` builds the fit scene,
:mod:`.effects` decides which light transport each stage simulates and
:mod:`.loop` is the shared, NaN-proof optimisation loop.
"""
