"""benchmarks/peer.py: the stand-in for jax.device_put_replicated that lets brax's PPO run on a jax
without it (jax 0.10+)."""


import jax
import jax.numpy as jnp
import numpy as np
from tests.experiments import load_benchmark

peer = load_benchmark("peer")


def test_replicated_stacks_every_leaf_once_per_device_on_a_leading_axis():
  devices = jax.local_devices()
  tree = {"w": jnp.arange(6.0).reshape(2, 3), "step": jnp.int32(7)}
  out = peer.replicated(tree, devices)
  assert out["w"].shape == (len(devices), 2, 3) and out["step"].shape == (len(devices),)
  assert out["step"].dtype == jnp.int32
  for i in range(len(devices)):
    np.testing.assert_array_equal(out["w"][i], tree["w"])
  # What brax does with it: a pmap over the leading axis.
  summed = jax.pmap(lambda t: t["w"].sum() + t["step"])(out)
  np.testing.assert_allclose(np.asarray(summed), [15.0 + 7] * len(devices))


def test_a_pmapped_step_fed_its_own_output_after_the_replicated_state_traces_once():
  # brax's training loop: state = replicated(state); state = step(state); state = step(state) ...
  # A state laid out unlike pmap's outputs made the second call trace (and on a GPU compile) again.
  traces = []

  def step(t):
    traces.append(1)
    return jax.tree.map(lambda x: x + 1, t)

  pstep = jax.pmap(step, axis_name="i")  # brax's training step's axis name
  state = peer.replicated({"w": jnp.ones((2, 3)), "step": jnp.int32(0)}, jax.local_devices())
  for _ in range(3):
    state = pstep(state)
  assert len(traces) == 1
  np.testing.assert_array_equal(np.asarray(state["step"]), [3] * len(jax.local_devices()))


def test_a_jitted_evaluation_before_and_after_training_steps_compiles_once():
  # brax evaluates one slice of the state before training (the stand-in's output) and after every
  # epoch (its pmapped step's output, axis "i"). Arrays from pmaps of two axis names have two
  # shardings, and brax's evaluator compiled a third time on the GPU (session 15: 36 s).
  @jax.jit
  def evaluate(t):
    return t["w"].sum()

  pstep = jax.pmap(lambda t: jax.tree.map(lambda x: x + 1, t), axis_name="i")
  state = peer.replicated({"w": jnp.ones((2, 3))}, jax.local_devices())
  for _ in range(3):
    evaluate(jax.tree.map(lambda x: x[0], state))
    state = pstep(state)
  assert evaluate._cache_size() == 1


def test_the_patch_fills_only_a_missing_device_put_replicated(monkeypatch):
  try:
    existing = jax.device_put_replicated
  except AttributeError:
    existing = None
  if existing is not None:  # an older jax: nothing to patch, and the original stays
    assert peer.patch_jax_for_brax() is False and jax.device_put_replicated is existing
  else:
    monkeypatch.setattr(jax, "device_put_replicated", None, raising=False)
    monkeypatch.delattr(jax, "device_put_replicated")
    assert peer.patch_jax_for_brax() is True
    assert jax.device_put_replicated is peer.replicated


def test_steady_rate_ignores_a_compiling_chunk_and_two_reports_that_come_together():
  # Session 13's rows: brax evaluates at step 0, then compiles during its first two chunks;
  # blx's last two reports came 10 ms apart.
  brax = [{"wall_s": 35.5, "env_steps": 0}, {"wall_s": 73.5, "env_steps": 11_796_480},
          {"wall_s": 110.2, "env_steps": 23_592_960}] + [
              {"wall_s": 110.2 + 8.24 * i, "env_steps": 23_592_960 + 11_796_480 * i}
              for i in range(1, 8)]
  assert abs(peer.steady_rate(brax) - 11_796_480 / 8.24) < 1.0
  blx = [{"wall_s": 57.0 + 9.22 * i, "env_steps": 11_796_480 * (i + 1)} for i in range(9)]
  blx.append({"wall_s": blx[-1]["wall_s"] + 0.01, "env_steps": 117_964_800})
  assert abs(peer.steady_rate(blx) - 11_796_480 / 9.22) < 1.0
  assert peer.steady_rate(blx[:1]) is None
