"""Trains the SMALL config on `point` in a fresh process; used by the resume and sharding tests.

usage: python -m tests.training._run MODE OUT [CKPT]
  MODE full: train to the end; interrupt: Ctrl-C after the first chunk; resume: continue CKPT
  (on as many devices as the process has, whatever the checkpoint was written on);
  in-flight: Ctrl-C after the first chunk while the second is held up on the device (an evaluator
  whose host callback sleeps $BLX_TEST_SLEEP seconds from its second call on); prints the time of
  the Ctrl-C.
Writes the final policy params (flattened leaves) to OUT.npz, with the number of local devices
and of the final state's leaves laid out otherwise than `place_state` lays them out.
"""

import os
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np

from blx import envs, training
from tests.training.tiny import SMALL, reach_latent


def main():
  mode, out = sys.argv[1], sys.argv[2]
  ckpt = sys.argv[3] if len(sys.argv) > 3 else None
  config = SMALL.replace(num_timesteps=4 * 16 * 5 * 2, num_evals=4) if mode != "dp" else SMALL

  def interrupt(row):
    print(f"interrupted at {time.time()}", flush=True)
    raise KeyboardInterrupt

  calls = []

  def held_up(x):
    calls.append(x)
    if len(calls) > 1:
      time.sleep(float(os.environ["BLX_TEST_SLEEP"]))
    return x

  def evaluate(policy, params, key):
    one = jnp.float32(1.0)
    return {"held_up": jax.pure_callback(held_up, jax.ShapeDtypeStruct((), jnp.float32), one)}

  try:
    env = envs.create("point", episode_length=20)
    result = training.train(env, reach_latent(), config, seeds=(3,),
                            progress=interrupt if mode in ("interrupt", "in-flight") else False,
                            checkpoint_dir=ckpt, resume=mode == "resume",
                            evaluate=evaluate if mode == "in-flight" else None)
  except KeyboardInterrupt:
    sys.exit(130)
  leaves = jax.tree.leaves(jax.device_get(result.params))
  # The state's leaves that are not laid out as place_state lays out a state for the chunk (the
  # layout the programs were compiled for): each such leaf would move between chunks.
  final = jax.tree.leaves(result.state)
  placed = jax.tree.leaves(training.place_state(result.state, config.num_envs))
  moved = sum(not a.sharding.is_equivalent_to(b.sharding, a.ndim) for a, b in zip(final, placed))
  np.savez(out, *leaves, devices=len(jax.local_devices()), moved=moved)


if __name__ == "__main__":
  main()
