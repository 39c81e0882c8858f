"""The default sweep behind ``rattlesweep demo`` (the README's main job)."""

__all__ = ["DEMO_TOML"]

DEMO_TOML = """\
# rattlesweep demo: where does the toy rattleback reverse?
# Spin x misalignment for Coulomb friction (mu = 0.3) and pure rolling (mu = inf),
# launched from a 0.5 degree roll, up to 5 s of motion each. The declared 41 x 33 grid
# is refined 3 times where the outcome changes, to 321 x 257, and each launch stops at
# its first reversal.
name = "demo: toy rattleback, spin x misalignment"
stop = "first_reversal"

[axes]
spin = { start = -30, stop = 30, num = 41 }
delta_deg = { start = -8, stop = 8, num = 33 }
mu = [0.3, inf]

[fixed]
t_end = 5.0
roll_deg = 0.5

[refine]
levels = 3
"""
