"""Shared helpers of the Python tests: where the CLI, the sources and the shared meshes are.

Run by the README's test command through CTest (tests/CMakeLists.txt sets PYTHONPATH to the
build's python/ folder, RICCI_CLI and RICCI_SOURCE_DIR); by hand:
    PYTHONPATH=build/python RICCI_CLI=build/ricci /usr/bin/python3 -m pytest tests/python
"""

import os
import pathlib
import subprocess

import pytest

# Subprocesses (the README example, the batch's workers) run in other folders: a relative
# PYTHONPATH entry would no longer find the package.
if os.environ.get("PYTHONPATH"):
    os.environ["PYTHONPATH"] = os.pathsep.join(os.path.abspath(p) for p in os.environ["PYTHONPATH"].split(os.pathsep) if p)

SOURCE = pathlib.Path(os.environ.get("RICCI_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
FIXTURES = SOURCE / "fixtures"
SHARED = SOURCE.parent / "shared" / "meshes"
CLI = os.environ.get("RICCI_CLI", str(SOURCE / "build" / "ricci"))

GOOD_FIXTURES = ["genus2.obj", "torus.obj", "disk.obj", "annulus.obj", "icosphere.obj", "sphere-3holes.obj",
                 "genus2-1hole.obj", "genus3.obj", "genus2-finger.obj"]


def run_cli(*args, check=True):
    """The ricci executable with `args`; returns the CompletedProcess (text)."""
    proc = subprocess.run([CLI, *map(str, args)], capture_output=True, text=True)
    if check and proc.returncode != 0:
        raise AssertionError(f"ricci {' '.join(map(str, args))} exited {proc.returncode}: {proc.stderr}")
    return proc


def read_metric_csv(path):
    """u per vertex (validated numbering) and length per edge of a metric.csv."""
    u, lengths = [], []
    section = None
    for line in open(path, encoding="utf-8"):
        if line.startswith("# vertex,"):
            section = "v"
        elif line.startswith("# edge,"):
            section = "e"
        elif not line.startswith("#") and line.strip():
            fields = line.strip().split(",")
            if section == "v":
                u.append(float(fields[2]))
            elif section == "e":
                lengths.append(float(fields[3]))
    return u, lengths


def read_obj_uv(path):
    """Per-corner (u, v) of an OBJ's faces, in face order."""
    vt, corners = [], []
    for line in open(path, encoding="utf-8"):
        if line.startswith("vt "):
            vt.append(tuple(float(x) for x in line.split()[1:3]))
        elif line.startswith("f "):
            for word in line.split()[1:]:
                corners.append(vt[int(word.split("/")[1]) - 1])
    return corners


@pytest.fixture(scope="session")
def cli():
    if not os.path.exists(CLI):
        pytest.fail(f"the ricci executable is not at {CLI} (set RICCI_CLI)")
    return CLI
