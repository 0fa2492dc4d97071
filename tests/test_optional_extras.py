"""The package works without its optional extras: the README's first set-up command installs
``armpath`` alone (no ``[mesh]``, ``[urdf]`` or ``[dask]``), and ``armpath run`` must write its
figures and animations there. The test environment has every extra installed, so each check
runs in a fresh interpreter in which importing an extra's package fails, as it would where the
package is missing."""

import subprocess
import sys
import textwrap

import independent

#: The packages of the optional extras (and of the tests' peers) that no module outside the
#: mesh extra's own may need.
OPTIONAL = ("trimesh", "coal", "yourdfpy", "dask", "distributed", "fcl", "pinocchio", "eaik")
#: The modules that are the ``[mesh]`` extra: they may need its packages.
MESH_EXTRA = {"armpath.geometry.mesh", "armpath.geometry.proxies"}


def _without_extras(body: str, *args: str) -> subprocess.CompletedProcess[str]:
    """Run ``body`` in a fresh interpreter where importing an :data:`OPTIONAL` package fails."""
    blocker = f"import sys\nfor _name in {OPTIONAL!r}:\n    sys.modules[_name] = None\n"
    return subprocess.run(
        [sys.executable, "-c", blocker + textwrap.dedent(body), *args],
        capture_output=True,
        text=True,
        timeout=600,
    )


def test_every_module_imports_without_the_optional_extras():
    proc = _without_extras(
        """
        import importlib, pkgutil
        import armpath
        for m in pkgutil.walk_packages(armpath.__path__, "armpath."):
            if m.name.endswith("__main__"):
                continue
            try:
                importlib.import_module(m.name)
            except ImportError as exc:
                print(m.name, "|", exc)
        """
    )
    assert proc.returncode == 0, proc.stderr
    failed = {line.split(" | ")[0]: line for line in proc.stdout.splitlines()}
    assert set(failed) == MESH_EXTRA, proc.stdout
    # the extra's entry point names what to install
    assert "pip install 'armpath[mesh]'" in failed["armpath.geometry.mesh"]


def test_a_reach_writes_its_figures_and_animation_without_the_optional_extras(tmp_path):
    """`armpath reach --out --animate` (what `armpath run` writes for Task 1): the figures, the
    GIF and the result, and the result's last state puts the tool point on the target as the
    independent forward kinematics computes it."""
    out = tmp_path / "reach"
    proc = _without_extras(
        """
        import sys
        sys.argv = ["armpath", *sys.argv[1:]]
        from armpath.cli import main
        main()
        """,
        "reach", "300", "200", "300", "--out", str(out), "--animate",
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    names = {p.name for p in out.iterdir()}
    assert {"reach.json", "reach.csv", "reach_motion.png", "reach_joints.png", "reach.gif"} <= names
    for name in ("reach_motion.png", "reach_joints.png", "reach.gif"):
        assert (out / name).stat().st_size > 10_000, name
    from armpath.results import load_result

    result = load_result(out / "reach.json")
    tip = independent.points(result.sequence.states()[-1] / 10.0)[-1]
    assert abs(tip - [300.0, 200.0, 300.0]).max() <= 0.05 + 1e-9
