"""benchmarks/peer.py: the stand-in for jax.device_put_replicated that lets brax's PPO run on a jax
without it (jax 0.10+)."""

import importlib.util
import pathlib

import jax
import jax.numpy as jnp
import numpy as np

_PATH = pathlib.Path(__file__).resolve().parents[2] / "benchmarks" / "peer.py"
_spec = importlib.util.spec_from_file_location("peer", _PATH)
peer = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(peer)


def test_replicated_stacks_every_leaf_once_per_device_on_a_leading_axis():
  devices = jax.local_devices()
  tree = {"w": jnp.arange(6.0).reshape(2, 3), "step": jnp.int32(7)}
  out = peer.replicated(tree, devices)
  assert out["w"].shape == (len(devices), 2, 3) and out["step"].shape == (len(devices),)
  assert out["step"].dtype == jnp.int32
  for i in range(len(devices)):
    np.testing.assert_array_equal(out["w"][i], tree["w"])
  assert out["w"].sharding.spec == jax.sharding.PartitionSpec("devices")
  # What brax does with it: a pmap over the leading axis.
  summed = jax.pmap(lambda t: t["w"].sum() + t["step"])(out)
  np.testing.assert_allclose(np.asarray(summed), [15.0 + 7] * len(devices))


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
