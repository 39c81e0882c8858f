"""The planar rocking semi-ellipse's kernels (docs/model.md: the planar rocking
semi-ellipse)."""
