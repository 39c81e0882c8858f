"""Adaptive refinement of a sweep's grid: which points each level simulates and how the
others are filled (:mod:`.plan`), and running the levels (:mod:`.run`) into their output
(:mod:`~rattlesweep.sweep._outputs.refined`)."""
