"""benchmarks/feature_dims.py: MI and H(s) per observation dimension of a policy."""

import math
import pathlib

import jax
import jax.numpy as jnp
import numpy as np

from blx import objectives
from tests.conftest import make_env
from tests.experiments import load_benchmark

feature_dims = load_benchmark("feature_dims")


def _split_on_x(params, obs, z, key=None, deterministic=False):
  """Skill 0 pushes the point to +x at full force, skill 1 to -x; nothing moves it in y."""
  return jnp.stack([z[:, 0] - z[:, 1], jnp.zeros(z.shape[0])], -1)


def test_scan_finds_the_skill_in_the_dimension_the_policy_uses_and_none_elsewhere(tmp_path):
  env = make_env("point")  # observation: x, y, vx, vy
  objective = objectives.make("diayn", num_skills=2, obs_indices="pos_xy", env=env)
  scan = jax.jit(lambda key: feature_dims.scan(env, objective, _split_on_x, None, [0, 1, 2, 3], key,
                                                last_steps=25))  # as scan_run runs it
  r = jax.device_get(scan(jax.random.PRNGKey(0)))
  # x velocity: the two skills never share a bin, so MI = H(s) = log 2 (two equal skills).
  assert r["mi"][2] == np.float32(math.log(2)) and r["entropy"][2] == np.float32(math.log(2))
  # y and its velocity stay 0 for both skills: no information and no spread.
  np.testing.assert_allclose(r["mi"][[1, 3]], 0.0, atol=1e-6)
  np.testing.assert_allclose(r["entropy"][[1, 3]], 0.0, atol=1e-6)
  # x position: the skills part too, but both leave the +-obs_scale box the estimator bins, so
  # only the samples still inside count.
  assert 0.0 < r["mi"][0] < math.log(2)

  results = {"split": {k: np.stack([v, v]) for k, v in r.items()}}
  path = str(tmp_path / "dims.png")
  feature_dims.plot(results, [0, 1, 2, 3], path)
  assert pathlib.Path(path).stat().st_size > 10_000
