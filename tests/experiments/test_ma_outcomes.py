"""benchmarks/ma_outcomes.py: what two agents did to each other, summarised from torso tracks."""


import numpy as np
from tests.experiments import load_benchmark

ma_outcomes = load_benchmark("ma_outcomes")


def test_summary_counts_catches_ring_outs_and_lengths_by_hand():
  steps = 10
  xy = np.zeros((3, steps, 2, 2))
  alive = np.ones((3, steps), bool)
  # Episode 0: the pursuer (agent1) closes in and the env ends it at step 4 (5 steps ran), 0.3 m apart.
  xy[0, :, 1, 0] = np.linspace(3.0, 0.3, steps)
  xy[0, 4, 1, 0] = 0.3
  alive[0, 5:] = False
  # Episode 1: runs to the end, 2 m apart, agent0 ends 4 m from the origin (out of a 3 m ring).
  xy[1, :, 0, 0] = 4.0
  xy[1, :, 1, 0] = 2.0
  # Episode 2: ends early at step 2 (3 steps) but 1 m apart: a fall, neither a catch nor an escape.
  xy[2, :, 1, 1] = 1.0
  alive[2, 3:] = False
  s = ma_outcomes.summarise(xy, alive, catch_distance=0.5, ring=3.0, escape_distance=1.5)
  assert s["episodes"] == 3
  np.testing.assert_allclose(s["ended_early"], 2 / 3)
  np.testing.assert_allclose(s["mean_length"], (5 + 10 + 3) / 3)
  np.testing.assert_allclose(s["caught"], 1 / 3)
  assert s["steps_to_catch"] == 5
  np.testing.assert_allclose(s["final_distance"], (0.3 + 2.0 + 1.0) / 3)
  # Episode 1 is 2 m apart but ran to the end: no escape (only an early end counts).
  assert s["escaped"] == 0 and s["steps_to_escape"] is None
  np.testing.assert_allclose(s["outside_ring"], [1 / 3, 0.0])


def test_an_early_end_far_apart_is_an_escape():
  xy = np.zeros((2, 6, 2, 2))
  xy[:, :, 1, 0] = 25.0
  alive = np.ones((2, 6), bool)
  alive[0, 4:] = False  # 4 steps, then the env ended it: 25 m apart
  s = ma_outcomes.summarise(xy, alive, catch_distance=0.5, ring=3.0, escape_distance=20.0)
  assert s["escaped"] == 0.5 and s["steps_to_escape"] == 4 and s["caught"] == 0


def test_no_catch_has_no_steps_to_catch():
  s = ma_outcomes.summarise(np.ones((2, 4, 2, 2)), np.ones((2, 4), bool), 0.5, 3.0)
  assert s["caught"] == 0 and s["steps_to_catch"] is None and s["ended_early"] == 0


def test_rollouts_let_the_policy_drive_only_the_trained_agents():
  import jax
  import jax.numpy as jnp

  from blx.experiments import runs
  spec = runs.RunSpec(env="chase", objective="task", objective_options={}, ppo={},
                      env_params={"main_agent": "point", "other_agent": "point",
                                  "episode_length": 30})
  env, objective, config = runs.build(spec)
  still = lambda params, obs: jnp.zeros((obs.shape[0], env.action_size))  # a policy that rests
  run = runs.Run("test", spec, env, objective, config, {"w": jnp.zeros((1,))}, still, {})
  rollouts = ma_outcomes.make_rollouts(run, seed_index=0, episodes=4, steps=30)
  key = jax.random.PRNGKey(0)
  moved = {}
  for trained in ((True, True), (True, False), (False, True)):
    xy, alive = rollouts(trained, key)
    assert xy.shape == (4, 30, 2, 2) and alive.shape == (4, 30) and alive[:, 0].all()
    moved[trained] = np.abs(xy[:, -1] - xy[:, 0]).sum(-1).mean(0)  # [agents]
  # The resting policy holds a trained point still; a random one wanders.
  np.testing.assert_allclose(moved[(True, True)], 0.0, atol=1e-3)
  assert moved[(True, False)][0] < 1e-3 < moved[(True, False)][1]
  assert moved[(False, True)][1] < 1e-3 < moved[(False, True)][0]
