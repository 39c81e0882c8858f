"""`rattlesweep design` writing into directories that hold something: it never replaces
another tool's files, installs a design so that a `design.toml` always means a complete
one, and does not lose a Ctrl-C that lands while trimesh is imported (issue 43,
defects 5 to 7)."""

import os
import subprocess
import sys
import textwrap

import pytest

import rattlesweep as rs
from rattlesweep.cli import main
from rattlesweep.design import Launches, design, load_body

from design_helpers import SHELL

CHEAP = dict(
    grid=(2, 2),
    refine=0,
    reversal_map=False,
    launches=Launches(spins=(5.0,), tilts=((0.01, 0.0),), n_mu=2, t_end=2.0),
)


def test_force_into_a_sweep_directory_is_refused_and_leaves_the_sweep_whole(
    tmp_path, capsys
):
    sweep_dir = tmp_path / "sweep"
    sweep = rs.Sweep(axes={"spin": [-5.0, 5.0]}, fixed={"body": "toy", "t_end": 0.2})
    rs.run_sweep(sweep, sweep_dir, progress=False)
    config = (sweep_dir / "sweep.toml").read_bytes()
    a, b, c = SHELL
    args = ["design", "--a", str(a), "--b", str(b), "--c", str(c)]
    assert main([*args, "--out", str(sweep_dir), "--force"]) == 2
    err = capsys.readouterr().err
    assert "a design never replaces another tool's files" in err
    assert (sweep_dir / "sweep.toml").read_bytes() == config
    assert rs.resume(sweep_dir, progress=False) is not None  # still the sweep's
    # a sweep.toml alone, of a sweep that is not a design's map, is another tool's too
    alone = tmp_path / "alone"
    alone.mkdir()
    (alone / "sweep.toml").write_bytes(config)
    with pytest.raises(ValueError, match=r"holds a sweep's configuration \(sweep.toml\)"):
        design(*SHELL, out=alone, overwrite=True, **CHEAP)


def test_an_install_interrupted_between_renames_leaves_no_design_toml(
    tmp_path, monkeypatch
):
    """A Ctrl-C after the third file moved in: the old design.toml is gone (no
    directory claims a design its files do not match), and --force again installs a
    whole design."""
    import rattlesweep.design.files as files

    out = tmp_path / "d"
    first = design(*SHELL, coin="usd_0.01", out=out, **CHEAP)
    assert (out / "design.toml").exists()
    moved = []
    real = os.replace

    def interrupted(src, dst):
        if len(moved) == 3:
            raise KeyboardInterrupt
        moved.append(dst)
        real(src, dst)

    monkeypatch.setattr(files.os, "replace", interrupted)
    with pytest.raises(KeyboardInterrupt):
        design(*SHELL, coin="usd_0.05", out=out, overwrite=True, **CHEAP)
    assert not (out / "design.toml").exists()
    monkeypatch.setattr(files.os, "replace", real)
    second = design(*SHELL, coin="usd_0.05", out=out, overwrite=True, **CHEAP)
    assert load_body(out / "design.toml").mass == pytest.approx(second.body.mass)
    assert second.body.mass != pytest.approx(first.body.mass)
    assert [p.name for p in tmp_path.iterdir()] == ["d"]  # no temporary left


def test_a_ctrl_c_during_the_trimesh_import_is_not_lost(tmp_path):
    """A stand-in trimesh whose import catches every exception (as parts of trimesh's
    do) gets a real SIGINT while it imports: the import finishes, then the Ctrl-C is
    raised."""
    fake = tmp_path / "trimesh.py"
    fake.write_text(
        textwrap.dedent(
            """
            import os, signal, time
            try:
                os.kill(os.getpid(), signal.SIGINT)
                time.sleep(0.2)
            except BaseException:
                pass
            LOADED = True
            """
        )
    )
    script = textwrap.dedent(
        f"""
        import sys
        sys.path.insert(0, {str(tmp_path)!r})
        from rattlesweep.design.mesh import trimesh_module
        try:
            module = trimesh_module()
        except KeyboardInterrupt:
            print("interrupted", sys.modules["trimesh"].LOADED)
        else:
            print("finished")
        """
    )
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=120
    )
    assert done.stdout.split() == ["interrupted", "True"], done.stderr


def test_the_millimetres_hint_is_given_only_where_it_is_plausible(capsys):
    """--wall 2 looks like millimetres (2 mm); --wall 0.05 does not (0.05 mm is no
    wall a printer makes): it is refused with the rule only."""
    args = [
        "design",
        "--a",
        "0.05",
        "--b",
        "0.015",
        "--c",
        "0.015",
        "--out",
        "/nonexistent/x",
    ]
    assert main([*args, "--wall", "2"]) == 2
    assert "2 looks like millimetres: give metres, e.g. 0.002" in capsys.readouterr().err
    assert main([*args, "--wall", "0.05"]) == 2
    err = capsys.readouterr().err
    assert "wall = 0.05 is invalid" in err and "millimetres" not in err
