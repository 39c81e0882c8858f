"""Adaptive refinement of a sweep's grid: which points each level simulates and how the
others are filled (:mod:`.plan`), and the levels as stages of the sweep's execution
(:mod:`.stages`), held by their output (:mod:`~rattlesweep.sweep._outputs.refined`)."""
