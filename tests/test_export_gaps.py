"""Tests for behaviour of planner.export that no existing test checks (found by mutation testing)."""
import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from planner import get_family, paper
from planner.export import read_trajectory_csv, write_json, write_trajectory_csv

ROOT = Path(__file__).resolve().parents[1]

_WRITE_IN_AN_ASCII_LOCALE = r"""
import sys
from pathlib import Path
import numpy as np
from planner import get_family, paper
from planner.export import read_trajectory_csv, write_json, write_trajectory_csv
folder = Path(sys.argv[1])
names = ["\u8098", "\u00e9paule", "joint 3", "wrist 1", "wrist 2", "\u624b\u9996"]  # ASCII source: argv is ASCII here
write_json(folder / "indented.json", {"\u5173\u8282": "\u8098", "names": names})
write_json(folder / "lines.json", {"\u5173\u8282": "\u8098", "names": names}, value_per_line=True)
trajectory = get_family("hybrid").build(np.deg2rad(paper.VIA_POINTS_DEG), paper.DURATIONS_S)
write_trajectory_csv(folder / "t.csv", trajectory, 5.0, names)
times, values = read_trajectory_csv(folder / "t.csv")
np.save(folder / "values.npy", values)
"""


def test_outputs_are_utf8_whatever_the_locale(tmp_path):
    """summary.json, coefficients.json and trajectory.csv are UTF-8 files (joint and task names may be any
    text), also when the process's locale encoding is ASCII (LC_ALL=C without Python's UTF-8 mode), and
    read_trajectory_csv reads such a CSV back."""
    env = dict(os.environ, LC_ALL="C", LANG="C", PYTHONUTF8="0", PYTHONCOERCECLOCALE="0", PYTHONIOENCODING="utf-8")
    done = subprocess.run([sys.executable, "-c", _WRITE_IN_AN_ASCII_LOCALE, str(tmp_path)], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    for name in ("indented.json", "lines.json"):
        assert json.loads((tmp_path / name).read_bytes().decode("utf-8"))["关节"] == "肘"
    header = (tmp_path / "t.csv").read_bytes().decode("utf-8").splitlines()[0]
    assert header.startswith("time_s,q_肘_deg,q_épaule_deg")
    trajectory = get_family("hybrid").build(np.deg2rad(paper.VIA_POINTS_DEG), paper.DURATIONS_S)
    np.testing.assert_allclose(np.load(tmp_path / "values.npy"), trajectory.sample(5.0)[1], rtol=1e-8, atol=1e-12)


def test_torque_columns_are_named_tau_joint_nm(tmp_path):
    """write_trajectory_csv's documented column names include ``tau_<joint>_Nm`` for the torques."""
    via = np.deg2rad(np.random.default_rng(2).uniform(-60, 60, (4, 2)))
    family = get_family("hybrid")
    trajectory = family.build(via, np.full(family.segment_count(4), 0.8))
    write_trajectory_csv(tmp_path / "t.csv", trajectory, 20.0, ["a", "b"], torques=lambda t: np.ones((len(t), 2)))
    with (tmp_path / "t.csv").open(encoding="utf-8") as handle:
        header = next(csv.reader(handle))
    assert header[-2:] == ["tau_a_Nm", "tau_b_Nm"] and len(header) == 1 + 5 * 2
    times, values = read_trajectory_csv(tmp_path / "t.csv")
    assert values.shape == (4, len(times), 2)


def test_json_is_indented_by_two_spaces_unless_asked_for_a_value_per_line(tmp_path):
    """summary.json's layout (write_json's default): the document indented by two spaces, as Python's json
    writes it, one number per line in an array; the value-per-line layout only when asked for."""
    data = {"task": "pick", "limits": {"velocity": [1.5, 2.0]}, "feasible": True}
    write_json(tmp_path / "default.json", data)
    assert (tmp_path / "default.json").read_text(encoding="utf-8") == json.dumps(data, indent=2) + "\n"
    assert (tmp_path / "default.json").read_text(encoding="utf-8").splitlines()[2] == '  "limits": {'
    write_json(tmp_path / "lines.json", {"a": np.array([1.0, 2.0]), "b": "x"}, value_per_line=True)
    assert (tmp_path / "lines.json").read_text(encoding="utf-8") == '{\n  "a": [1.0, 2.0],\n  "b": "x"\n}\n'
