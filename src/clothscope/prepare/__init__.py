"""Stage 0, rule ``prepare``: decode a photo into a linear working image, choose its scale from the
threads, or reject it saying why (:mod:`.image`); the photo's shading with dye colours divided out
(:mod:`.shading`); the run's list of rejected images (:mod:`.rejections`, rule ``rejection_report``)."""
