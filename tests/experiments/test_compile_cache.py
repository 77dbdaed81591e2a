"""The CLI's persistent compilation cache: where it goes, how it is turned off, and that a bad
directory only turns it off. Each case runs in a fresh process, since JAX's cache is set once per
process (and this test session has its own, from conftest)."""

from __future__ import annotations

import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
COMPILE = ("from blx.experiments import compile_cache; d = compile_cache.enable(); "
           "import jax, jax.numpy as jnp; "
           "jax.config.update('jax_persistent_cache_min_compile_time_secs', 0.0); "
           "jax.jit(lambda x: jnp.sin(x) * 2)(jnp.ones(3)).block_until_ready(); print(d)")


def _run(setting: str | None, home: str):
  env = {**os.environ, "PYTHONPATH": ROOT, "XDG_CACHE_HOME": home}
  env.pop("BLX_COMPILATION_CACHE")
  env.pop("JAX_COMPILATION_CACHE_DIR", None)
  if setting is not None:
    env["BLX_COMPILATION_CACHE"] = setting
  proc = subprocess.run([sys.executable, "-c", COMPILE], capture_output=True, text=True, env=env,
                        timeout=300)
  assert proc.returncode == 0, proc.stderr[-2000:]
  return proc.stdout.strip().splitlines()[-1], proc.stderr


def test_on_by_default_in_the_user_cache_directory(tmp_path):
  directory, _ = _run(None, str(tmp_path))
  assert directory == str(tmp_path / "blx" / "jax")
  assert os.listdir(directory)  # the compiled program was stored


def test_a_directory_of_ones_own_and_off(tmp_path):
  mine = tmp_path / "mine"
  directory, _ = _run(str(mine), str(tmp_path / "home"))
  assert directory == str(mine) and os.listdir(mine)
  assert not (tmp_path / "home").exists()
  directory, _ = _run("off", str(tmp_path / "home"))
  assert directory == "None" and not (tmp_path / "home").exists()


def test_an_unusable_directory_turns_it_off_with_a_warning(tmp_path):
  (tmp_path / "file").write_text("")
  directory, stderr = _run(str(tmp_path / "file" / "cache"), str(tmp_path))
  assert directory == "None"
  assert "[blx] compilation cache off: cannot use" in stderr and "BLX_COMPILATION_CACHE" in stderr
