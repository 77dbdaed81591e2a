"""benchmarks/cheetah_step.py: the divergence horizon, the behaviour signatures, the candidates it
refuses, and its MJX and float64 rollouts of the same actions from the same (non-default) pose."""


import numpy as np
import pytest
from tests.experiments import load_benchmark

cheetah_step = load_benchmark("cheetah_step")

DT = 0.05


def _still(steps=10, nq=9):
  return np.zeros((steps, nq))


def test_horizon_is_the_first_step_outside_the_x_or_pitch_band():
  a = _still()
  assert cheetah_step.horizon(a, a.copy(), DT) == pytest.approx(10 * DT)   # never leaves
  b = a.copy()
  b[3:, 0] += 0.06                                                        # x: 6 cm from step 3
  assert cheetah_step.horizon(a, b, DT) == pytest.approx(3 * DT)
  c = a.copy()
  c[5:, 2] -= 0.2                                                         # pitch: 0.2 rad from 5
  c[:, 0] += 0.04                                                         # x within 5 cm
  assert cheetah_step.horizon(a, c, DT) == pytest.approx(5 * DT)
  d = a.copy()
  d[:, 3:] += 1.0                                                         # joints do not count
  assert cheetah_step.horizon(a, d, DT) == pytest.approx(10 * DT)


def test_signatures_read_velocity_height_pitch_rate_and_flips():
  q = np.zeros((2, 5, 9))
  q[0, :, 0] = 0.1 * np.arange(5)          # episode 0 moves 0.1 m per step: 2 m/s
  q[1, :, 0] = -0.1 * np.arange(5)         # episode 1: -2 m/s
  q[:, :, 1] = -0.2                        # torso z = 0.6 - 0.2
  q[1, 2:, 2] = np.pi                      # episode 1 flips at step 2 and stays over
  s = cheetah_step.signatures(q, DT)
  assert s["vx_mean"] == pytest.approx(0.0, abs=1e-6)
  assert s["vx_std"] == pytest.approx(2.0)
  assert s["z_mean"] == pytest.approx(0.4)
  assert s["flipped"] == pytest.approx(3 / 10)
  assert s["pitch_rate"] == pytest.approx(np.pi / DT / 8)   # one jump of pi among 8 differences
  assert s["finite"]


def test_candidates_must_keep_the_50_ms_env_step_and_name_real_options():
  with pytest.raises(ValueError, match="must stay 0.05 s"):
    cheetah_step.make({"substeps": 10})
  with pytest.raises(ValueError, match="unknown global_options.*'substep'"):
    cheetah_step.make({"substep": 8})


def test_mjx_rollout_follows_the_float64_truth_from_the_pose_given():
  env = cheetah_step.make({})
  qpos0 = np.asarray(env.init_qpos, np.float64)[None].copy()
  qpos0[0, 3] += 0.3                                  # bthigh 0.3 rad off its default
  actions = np.random.default_rng(0).uniform(-1, 1, (1, 3, env.action_size))
  mjx = cheetah_step.mjx_rollout(env, actions, qpos0)[0]
  truth = cheetah_step.truth_rollout(env, actions[0], qpos0[0])
  default = cheetah_step.truth_rollout(env, actions[0], np.asarray(env.init_qpos))
  # Three steps are well inside blx's step's horizon (0.7 s on the H200): float32 MJX with four
  # Newton iterations stays within a millimetre of the converged float64 solve.
  np.testing.assert_allclose(mjx, truth, atol=2e-3)
  assert np.abs(mjx[:, 3] - default[:, 3]).max() > 0.1   # the pose given was the one stepped
