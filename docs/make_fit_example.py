"""Makes the fit guide's example: ``guide/fit/phyphox-gyroscope.csv``, a gyroscope
recording in phyphox's format made by the model with known inputs, and ``guide/fit/
fit.png``, the picture ``rattlesweep fit`` draws of it (the guide's command).

    .venv/bin/python docs/make_fit_example.py
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

import rattlesweep as rs
from rattlesweep.fitting.measurement import write_phyphox

HERE = Path(__file__).parent / "guide" / "fit"
TRUTH = {"mu": 0.4, "damping": 2e-4, "roll_deg": 1.0, "spin": -3.0}
BIAS = (0.02, -0.01, 0.03)  # rad/s
NOISE = 0.02  # rad/s


def main() -> None:
    HERE.mkdir(parents=True, exist_ok=True)
    run = rs.simulate(rs.Body.preset("kane_levinson"), t_end=5.0, record_every=1, **TRUTH)
    t = np.arange(0.0, 5.0, 0.01)
    rates = np.stack(
        [np.interp(t, run.time.values, run.omega.values[:, k]) for k in range(3)], 1
    )
    rates += np.array(BIAS) + np.random.default_rng(11).normal(0.0, NOISE, rates.shape)
    csv = write_phyphox(HERE / "phyphox-gyroscope.csv", t, rates)
    with tempfile.TemporaryDirectory() as out:
        command = [
            sys.executable, "-m", "rattlesweep", "fit", str(csv), "--body", "kane_levinson",
            "--free", "damping=1e-5:1e-3", "--free", "roll_deg=0.2:3",
            "--free", "spin=-5:-1", "--fixed", "mu=0.4", "--out", out,
        ]  # fmt: skip
        subprocess.run(command, check=True)
        shutil.copy(Path(out) / "fit.png", HERE / "fit.png")


if __name__ == "__main__":
    main()
