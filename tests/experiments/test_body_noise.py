"""benchmarks/body_noise.py: how long a body stays up from rest under action noise, on a stand-in
body whose fall is known."""

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from blx.envs.env import State
from tests.experiments import load_benchmark

body_noise = load_benchmark("body_noise")


class _Tips:
  """Tips over once the pushes it got add up to 3 (each step adds |action|), or at step 12 if
  nothing pushes it."""

  observation_size, action_size = 1, 2

  def reset(self, key):
    return State(data=jnp.zeros(2), obs=jnp.zeros(1), reward=jnp.zeros(()), done=jnp.zeros(()))

  def step(self, state, action):
    pushed, t = state.data[0] + jnp.abs(action).sum(), state.data[1] + 1.0
    return state.replace(data=jnp.stack([pushed, t]),
                         done=((pushed >= 3.0) | (t >= 12.0)).astype(jnp.float32))


def test_each_episode_ends_where_its_body_falls_or_at_the_step_limit():
  key = jax.random.PRNGKey(0)
  # a push of 1 each step (0.5 on each action) tips it at step 3; no push, at step 12
  pushes = body_noise.episode_lengths(_Tips(), lambda k: jnp.full(2, 0.5), key, 4, 20)
  np.testing.assert_array_equal(pushes, [3, 3, 3, 3])
  np.testing.assert_array_equal(body_noise.episode_lengths(_Tips(), lambda k: jnp.zeros(2), key,
                                                           2, 20), [12, 12])
  # cut at 8 steps: the unpushed body is still up, and reads the limit
  np.testing.assert_array_equal(body_noise.episode_lengths(_Tips(), lambda k: jnp.zeros(2), key,
                                                           2, 8), [8, 8])
  # random pushes: each episode draws its own, so the lengths differ between episodes
  lengths = body_noise.episode_lengths(
      _Tips(), lambda k: jax.random.uniform(k, (2,), minval=-1.0, maxval=1.0), key, 64, 20)
  assert lengths.min() >= 2 and lengths.max() <= 12 and len(set(lengths.tolist())) > 2
  row = body_noise.summary(np.array([3, 5, 8, 8]), 8)
  assert row["mean"] == 6.0 and row["median"] == 6.5 and row["still_up"] == 0.5


def test_the_policys_stds_are_read_by_joint_and_a_file_for_another_body_is_refused(tmp_path):
  path = tmp_path / "action_noise.json"
  path.write_text(json.dumps({"per_seed": {
      "0": {"action_std": 0.2, "action_std_by_joint": {"a/knee": 0.2, "a/hip": 0.4}},
      "1": {"action_std": 0.3, "action_std_by_joint": {"a/knee": 0.4, "a/hip": 0.2}}}}))
  np.testing.assert_allclose(body_noise.joint_sigmas(str(path), ("a/hip", "a/knee")), [0.3, 0.3])
  with pytest.raises(ValueError, match=r"no std for \['a/elbow'\]: it was written for another "
                                       r"body \(its joints: \['a/hip', 'a/knee'\]\)"):
    body_noise.joint_sigmas(str(path), ("a/hip", "a/elbow"))
  old = tmp_path / "old.json"
  old.write_text(json.dumps({"per_seed": {"0": {"action_std": 0.2}}}))
  with pytest.raises(ValueError, match="holds no action_std_by_joint"):
    body_noise.joint_sigmas(str(old), ("a/hip",))


@pytest.mark.parametrize("argv, message", [
    (["--env", "point", "--steps", "51"], "point's episodes end at 50 steps"),
    (["--env", "point", "--episodes", "0"], "--episodes 0 and --steps 400: give 1 or more"),
    (["--env", "spider"], "unknown env 'spider'"),
])
def test_bad_input_is_named(capsys, argv, message):
  with pytest.raises(SystemExit) as exit_:
    body_noise.main(argv)
  assert exit_.value.code == 2 and message in capsys.readouterr().err


def test_the_command_writes_every_arm(tmp_path):
  # the point mass never ends an episode early: every arm is still up at the limit
  out = tmp_path / "body_noise.json"
  assert body_noise.main(["--env", "point", "--episodes", "3", "--steps", "10",
                          "--out", str(out)]) == 0
  result = json.loads(out.read_text())
  assert sorted(result["arms"]) == ["uniform", "zero"]
  assert result["arms"]["uniform"]["episodes"] == 3 and result["arms"]["zero"]["episodes"] == 1
  assert all(arm["mean"] == 10 and arm["still_up"] == 1.0 for arm in result["arms"].values())
