"""One import name: the distribution installs the package ``keepaway`` and nothing beside it, so a
project's own ``agents``, ``core`` or ``server`` (a folder or a file) neither shadows keepaway nor is
shadowed by it, and ``keepaway run`` works from such a project's directory."""

from __future__ import annotations

import importlib.metadata
import shutil
import subprocess
import sys
import zipfile

from conftest import REPO, keepaway_command

USER_MODULE = 'raise RuntimeError("the user\'s own {name} was imported instead of keepaway\'s")\n'


def test_the_installed_distribution_provides_only_the_keepaway_import_name():
    names = {name for name, dists in importlib.metadata.packages_distributions().items() if "keepaway" in dists}
    assert names == {"keepaway"}


def test_the_wheel_holds_the_keepaway_package_and_nothing_beside_it(tmp_path):
    source = tmp_path / "source"  # a copy: setuptools builds in the source tree, and leaves build/ there
    shutil.copytree(REPO, source, ignore=shutil.ignore_patterns(".git", "build", "*.egg-info", "out", ".venv",
                                                                "__pycache__"))
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(tmp_path), str(source)],
                   check=True, capture_output=True, timeout=600)
    (wheel,) = tmp_path.glob("keepaway-*.whl")
    tops = {name.split("/")[0] for name in zipfile.ZipFile(wheel).namelist()}
    assert {top for top in tops if not top.endswith(".dist-info")} == {"keepaway"}
    names = set(zipfile.ZipFile(wheel).namelist())
    assert {"keepaway/server/app.py", "keepaway/agents/player.py", "keepaway/viewer/static/index.html"} <= names


def test_keepaway_run_works_from_a_directory_with_its_own_agents_core_and_server(processes, tmp_path):
    project = tmp_path / "project"
    (project / "agents").mkdir(parents=True)
    (project / "core").mkdir()
    for name in ("server", "core", "agents", "protocol", "runner"):
        (project / f"{name}.py").write_text(USER_MODULE.format(name=name))
    for package in ("agents", "core"):
        (project / package / "__init__.py").write_text(USER_MODULE.format(name=f"{package}/"))
    run = processes.popen(keepaway_command("run", "--episodes", "3", "--no-progress", "--out", "out"),
                          cwd=project, stdout=subprocess.PIPE)
    out, _ = run.communicate(timeout=300)
    assert run.returncode == 0, processes.stderr_tail(run)
    assert "episodes        3" in out.decode()
    assert (project / "out" / "keepaway.kwy").exists()
