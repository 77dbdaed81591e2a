"""The ``run_bound`` and ``xla_defaults`` marks (tests/conftest.py): a test so marked runs in a
process of its own at XLA's defaults, and what it asserts still decides the outcome."""

from __future__ import annotations

import os
import pathlib

import pytest

from tests import conftest

pytest_plugins = ("pytester",)


@pytest.mark.parametrize("mark", [pytest.param("run_bound", marks=pytest.mark.run_bound),
                                  pytest.param("xla_defaults", marks=pytest.mark.xla_defaults)])
def test_a_marked_test_runs_in_a_process_of_its_own_without_the_suites_compile_flags(mark):
  assert os.environ.get(conftest.RUN_BOUND_CHILD) == "1"
  assert conftest.FAST_COMPILE not in os.environ.get("XLA_FLAGS", "")
  assert conftest.NO_FUSION_EMITTERS not in os.environ.get("XLA_FLAGS", "")


def test_a_run_bound_test_that_fails_in_its_process_fails_with_its_message(pytester, monkeypatch):
  # The suite's conftest, in a project of two marked tests: one fails, one passes. Were the child's
  # failure lost (or the test run in the parent's process), the counts below would differ.
  pytester.makeconftest(pathlib.Path(conftest.__file__).read_text())
  pytester.makepyfile(test_marked="""
      import os
      import pytest

      @pytest.mark.run_bound
      def test_fails():
        assert os.environ["BLX_TEST_RUN_BOUND_CHILD"] == "1"
        assert 1 + 1 == 3, "the child's own message"

      @pytest.mark.run_bound
      def test_passes():
        assert os.environ["BLX_TEST_RUN_BOUND_CHILD"] == "1"
      """)
  monkeypatch.delenv(conftest.RUN_BOUND_CHILD, raising=False)
  result = pytester.runpytest_subprocess("-p", "no:xdist", "-o", "addopts=")
  result.assert_outcomes(passed=1, failed=1)
  result.stdout.fnmatch_lines(["*in a process of its own*exited with 1*",
                               "*the child's own message*"])
