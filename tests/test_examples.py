"""Every example script in scripts/examples runs (so they never rot)."""

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "scripts" / "examples"


def run(script: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(EXAMPLES / script), *args], capture_output=True, text=True,
                          timeout=600, cwd=ROOT)


def test_every_example_is_covered():
    assert sorted(p.name for p in EXAMPLES.glob("*.py")) == ["compare_recording.py", "rectangle_ur5.py"]


def test_rectangle_then_compare(tmp_path):
    planned = run("rectangle_ur5.py", "--out", str(tmp_path / "rectangle"))
    assert planned.returncode == 0, planned.stderr
    assert "5 corners" in planned.stdout and "of the straight line" in planned.stdout and planned.stderr == ""
    compared = run("compare_recording.py", str(tmp_path / "rectangle"))
    assert compared.returncode == 0, compared.stdout + compared.stderr
    assert "limits: hold" in compared.stdout
    missing = run("compare_recording.py", str(tmp_path / "nothing"))
    assert missing.returncode == 2 and missing.stderr.startswith("error: ") and missing.stderr.count("\n") == 1
