"""The gait identification: the workflow (:mod:`.workflow`) over its stages, the smoother
and the fits, each a module of this package."""
