"""The 3-D rattleback model's kernels (docs/model.md: the body to the dynamics)."""
