"""The README's Python example, run as a user would (from a folder holding fixtures/genus2.obj)."""

import os
import re
import shutil
import subprocess
import sys

from conftest import FIXTURES, SOURCE


def test_the_readme_example_runs(tmp_path):
    text = (SOURCE / "README.md").read_text(encoding="utf-8")
    section = text[text.index("\n## Python\n"):]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    (tmp_path / "fixtures").mkdir()
    shutil.copy(FIXTURES / "genus2.obj", tmp_path / "fixtures" / "genus2.obj")
    env = dict(os.environ, MPLBACKEND="Agg")
    r = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, env=env,
                       timeout=300)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("hyperbolic ") and "['a1', 'b1', 'a2', 'b2']" in r.stdout
    assert (tmp_path / "out-python" / "report.json").is_file()
    assert (tmp_path / "out-python" / "mesh.obj").is_file()
    # matplotlib is one of tools/setup.sh's packages, so the plot is drawn.
    assert (tmp_path / "uv.png").stat().st_size > 10000
