"""Stage 1-3: inverse rendering of one prepared photo in three cached stages.

``geometry`` (64 x 64 plane mesh, Large Steps), ``material`` (base colour,
specular, roughness) and ``normals`` (height-map-derived normal map, then a
joint refinement with the BSDF); rules ``fit_geometry``, ``fit_material`` and
``fit_normals`` call :mod:`.jobs`.

:mod:`.target` is the photo a stage compares its renders with, :mod:`.model`
builds the fit scene, :mod:`.effects` decides which light transport each stage
simulates, :mod:`.loop` is the shared, NaN-proof optimisation loop and
:mod:`.outputs` names and reads the files a stage writes.
"""
