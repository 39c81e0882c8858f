"""Adaptive refinement of a sweep's grid: which points each level simulates and how the
others are filled (:mod:`.plan`), and running the levels into a resumable directory
(:mod:`.run`)."""
