"""The planar rocking semi-ellipse's kernels (MODEL.md section 8)."""
