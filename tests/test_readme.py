"""Every Python code block of the README runs."""

import os
import re

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
with open(os.path.join(ROOT, "README.md")) as f:
  BLOCKS = re.findall(r"```python\n(.*?)```", f.read(), flags=re.S)


def test_readme_has_python_blocks():
  assert len(BLOCKS) >= 4


@pytest.mark.parametrize("index", range(len(BLOCKS)))
def test_readme_block_runs(index, capsys):
  exec(compile(BLOCKS[index], f"README block {index}", "exec"), {})
  out = capsys.readouterr().out
  assert out.strip(), "the block prints its results"
  if index == 0:
    assert out.splitlines()[0] == "129 12" and "(17, 18)" in out
  if "evaluate_mimax" in BLOCKS[index]:
    # 10 skills settled at distinct goals: MI near log 10 (two may share one of the 1000 bins).
    assert 2.1 < float(out.split()[-2]) <= 2.303 and out.split()[-1] == "0.0"
