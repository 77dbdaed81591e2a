"""Trains the SMALL config on `point` in a fresh process; used by the resume and sharding tests.

usage: python -m tests.training._run MODE OUT [CKPT]
  MODE full: train to the end; interrupt: Ctrl-C after the first chunk; resume: continue CKPT.
Writes the final policy params (flattened leaves) to OUT.npz.
"""

import sys

import jax
import numpy as np

from blx import envs, training
from tests.training.tiny import SMALL, reach_latent


def main():
  mode, out = sys.argv[1], sys.argv[2]
  ckpt = sys.argv[3] if len(sys.argv) > 3 else None
  config = SMALL.replace(num_timesteps=4 * 16 * 5 * 2, num_evals=4) if mode != "dp" else SMALL

  def interrupt(row):
    raise KeyboardInterrupt

  try:
    env = envs.create("point", episode_length=20)
    result = training.train(env, reach_latent(), config, seeds=(3,),
                            progress=interrupt if mode == "interrupt" else False,
                            checkpoint_dir=ckpt, resume=mode == "resume")
  except KeyboardInterrupt:
    sys.exit(130)
  leaves = jax.tree.leaves(jax.device_get(result.params))
  np.savez(out, *leaves, devices=len(jax.local_devices()))


if __name__ == "__main__":
  main()
