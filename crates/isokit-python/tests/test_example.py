"""The Python modeling script in examples/ runs and checks its own results."""

import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[3]


def test_examples_python_part(tmp_path):
    r = subprocess.run([sys.executable, str(ROOT / "examples" / "python" / "part.py"), str(tmp_path)],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout + r.stderr
    assert (tmp_path / "part.png").read_bytes()[:4] == b"\x89PNG"
    assert (tmp_path / "part.json").exists()
