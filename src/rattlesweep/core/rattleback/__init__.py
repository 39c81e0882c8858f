"""The 3-D rattleback model's kernels (MODEL.md sections 2-4)."""
