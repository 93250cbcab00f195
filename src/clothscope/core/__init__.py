"""The shared layer every stage uses: atomic writes (:mod:`.atomic`), image I/O (:mod:`.imageio`),
the config schema and its defaults (:mod:`.schema`, :mod:`.config`), the Mitsuba runtime
(:mod:`.runtime`), the sample sheet (:mod:`.samples`), job logs (:mod:`.joblog`), grid meshes
(:mod:`.mesh`), ground-truth records (:mod:`.truth`) and Fourier helpers (:mod:`.fourier`)."""
