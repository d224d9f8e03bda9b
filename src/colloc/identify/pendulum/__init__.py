"""The pendulum study: the workflow (:mod:`.workflow`), its settings and its outputs."""
