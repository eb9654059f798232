"""Simulated captures: a Gaussian test scene (:mod:`.scenes`) and a ray-cast multi-camera RAW capture
written to disk with its ground truth (:mod:`.capture`, scene geometry in :mod:`.geometry`)."""
