"""MAPPO: PPO with one policy, value network and loss per agent, in the same trainer."""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from blx import envs, objectives, training
from blx.objectives import task
from blx.training import networks, ppo
from tests.training.tiny import SMALL, reach_latent

EDGE = "evader__pursuer"


def pursuit_desc():
  """An evader (2 m/s top speed) at the origin and a pursuer (3 m/s) 3 m away. The pursuer earns
  -distance and catches within 0.5 m, which ends the episode; the evader earns +distance."""
  point = lambda gear, pos: dict(component="point", component_params=dict(gear=gear), pos=pos)
  return dict(
      components=dict(evader=point(4.0, (0.0, 0.0, 0.0)), pursuer=point(6.0, (3.0, 0.0, 0.0))),
      edges={EDGE: dict(extra_observers=[dict(observer_type="root_vec", indices=(0, 1))],
                        reward_fns=dict(catch=dict(reward_type="root_dist", min_dist=0.5),
                                        flee=dict(reward_type="root_dist", scale=-1.0)))},
      global_options=dict(timestep=0.05, substeps=2),
      agent_groups=dict(evader=dict(reward_names=(f"{EDGE}/flee",)),
                        pursuer=dict(reward_names=(f"{EDGE}/catch",))))


@functools.lru_cache(maxsize=None)
def pursuit():
  return envs.create(desc=pursuit_desc(), episode_length=50)


def episodes_program(env, trainer, n=64):
  """A jitted ``(params, key, random_evader, random_pursuer, scripted_pursuer) -> (catch rate, mean
  episode length, mean distance)`` over ``n`` episodes with sampled actions: the episode length is
  the time to catch (50 = never caught), the distance is between the two, over each episode's steps
  and then over episodes (what the pursuer's reward is the minus of). ``random_<agent>`` replaces
  that agent's actions by uniform noise, ``scripted_pursuer`` sends the pursuer straight at the
  evader at full speed. The three switches are traced, so every variant runs the one program."""
  base = envs.unwrap(env)
  idx, vec = base.agent_action_indices, base.obs_layout[f"{EDGE}/root_vec_pos[0,1]"]
  evader, pursuer = (jnp.asarray(idx[agent]) for agent in ("evader", "pursuer"))
  assert evader.shape == pursuer.shape  # one draw of noise serves either agent

  @jax.jit
  def run(params, key, random_evader, random_pursuer, scripted_pursuer):
    state = jax.vmap(env.reset)(jax.random.split(key, n))

    def act(obs, k):
      policy_key, noise_key = jax.random.split(k)
      action = trainer.policy(params, obs, key=policy_key, deterministic=False)
      noise = jax.random.uniform(noise_key, (n, evader.shape[0]), minval=-1.0, maxval=1.0)
      for agent, noisy in ((evader, random_evader), (pursuer, random_pursuer)):
        action = action.at[:, agent].set(jnp.where(noisy, noise, action[:, agent]))
      # evader - pursuer, normalised
      towards = obs[:, vec] / jnp.linalg.norm(obs[:, vec], axis=-1, keepdims=True)
      return action.at[:, pursuer].set(jnp.where(scripted_pursuer, towards, action[:, pursuer]))

    record = lambda s, a, nxt: (jnp.linalg.norm(nxt.obs[:, vec], axis=-1), nxt.done)
    _, (dist, done) = envs.rollout(env, act, state, 50, key, record)
    alive = envs.alive_before(done)
    caught = ((dist < 0.5) & (alive > 0)).any(0)
    distance = (dist * alive).sum(0) / jnp.maximum(alive.sum(0), 1)
    return caught.mean(), alive.sum(0).mean(), distance.mean()

  def episodes(params, key, *, random=None, scripted_pursuer=False):
    if random not in (None, "evader", "pursuer"):
      raise ValueError(f"episodes: random must be None, 'evader' or 'pursuer', got {random!r}")
    out = run(params, key, random == "evader", random == "pursuer", scripted_pursuer)
    return tuple(float(x) for x in out)

  return episodes


@pytest.mark.run_bound
def test_mappo_learns_to_pursue_and_to_evade():
  # 120 k steps, three seeds vmapped. One seed's pursuer is no verdict: in this arms race it loses
  # in some seeds, and which ones changes with the CPU's float rounding (seed 0 caught its evader
  # in 91 % of episodes on one machine and in none on another, with the same code). Baselines,
  # measured in the same scene, per seed: a pursuer acting at random keeps about 6-8 m from the
  # trained evader (the pair start 3 m apart), and the pursuer that runs straight at the evader
  # catches an evader acting at random after 13 steps. Seeds 0-4 on an Intel Xeon under the tests'
  # XLA flags: the trained pursuer keeps 2.3, 1.5, 1.7, 1.9 and 10.3 m from the trained evader
  # (against a random pursuer's 8.4, 7.5, 8.0, 5.8 and 7.8), and the trained evader lasts 50, 42,
  # 30, 38 and 50 steps against the scripted pursuer. Seeds 0-2 on a 2-core AMD EPYC with AVX-512
  # at XLA's default optimisation (session 82; ``run_bound``, tests/conftest.py): the trained
  # pursuer keeps 0.24, 0.41 and 0.28 times a random pursuer's distance, and the trained evader
  # lasts 30, 18 and 30 steps longer than a random one against the scripted pursuer.
  env = pursuit()
  config = training.ppo_defaults("point", num_timesteps=120_000, num_evals=2, reward_scaling=0.1,
                                 entropy_cost=0.01)
  seeds = (0, 1, 2)
  result = training.train(env, task(), config, seeds=seeds, progress=False)
  episodes = episodes_program(env, training.make_trainer(env, task(), config))
  key = jax.random.PRNGKey(1)
  closer, longer = [], []
  for i in range(len(seeds)):
    params = jax.tree.map(lambda x, i=i: x[i], result.params)
    trained = episodes(params, key)[2]
    random_pursuer = episodes(params, key, random="pursuer")[2]
    closer.append(trained / random_pursuer)
    evader_time = episodes(params, key, scripted_pursuer=True)[1]
    random_time = episodes(params, key, scripted_pursuer=True, random="evader")[1]
    longer.append(evader_time - random_time)
  # the pursuers learned to close in on the evader they trained with, and the evaders to flee
  assert np.median(closer) <= 0.5, closer
  assert np.median(longer) >= 10, longer
  last = result.metrics[-1]
  assert {"train/reward/evader", "train/reward/pursuer", "eval/episode_reward/evader",
          "eval/episode_reward/pursuer", "eval/episode_score/pursuer"} <= set(last)
  # The two agents' rewards are +-distance, so their evaluation totals cancel.
  np.testing.assert_allclose(last["eval/episode_reward/evader"],
                             -np.asarray(last["eval/episode_reward/pursuer"]), rtol=1e-4)


def test_mappo_vmaps_over_seeds_like_separate_runs():
  train = training.make_train(pursuit(), task(), SMALL)
  keys = jax.random.split(jax.random.PRNGKey(0), 2)
  batched_state, batched = jax.jit(jax.vmap(train))(keys)
  for i in range(2):
    state, metrics = jax.jit(train)(keys[i])
    for a, b in zip(jax.tree.leaves(state.params), jax.tree.leaves(batched_state.params)):
      np.testing.assert_allclose(a, b[i], rtol=1e-4, atol=1e-5)
    np.testing.assert_allclose(metrics["eval/episode_reward/pursuer"],
                               batched["eval/episode_reward/pursuer"][i], rtol=1e-4, atol=1e-4)


def test_each_agent_has_its_own_networks_and_its_loss_moves_only_them():
  env = envs.unwrap(pursuit())
  learner = ppo.make_learner(env.observation_size, env.action_size, task(), SMALL,
                             agents=env.agents)
  x = jnp.ones((3, env.observation_size))
  params = learner.policy_net.init(jax.random.PRNGKey(0), x)
  assert set(params["params"]) == {"evader", "pursuer"}
  logits = learner.policy_net.apply(params, x)
  raw = jax.random.normal(jax.random.PRNGKey(1), (3, env.action_size))
  per_agent = learner.log_prob(logits, raw)
  assert per_agent.shape == (3, 2)
  np.testing.assert_allclose(per_agent.sum(-1), networks.log_prob_raw(logits, raw), rtol=1e-5)
  # The pursuer's log-probability depends on the pursuer's parameters only.
  grads = jax.grad(lambda p: learner.log_prob(learner.policy_net.apply(p, x), raw)[:, 1].sum())(
      params)
  assert all(float(jnp.abs(g).max()) == 0.0 for g in jax.tree.leaves(grads["params"]["evader"]))
  assert any(float(jnp.abs(g).max()) > 0.0 for g in jax.tree.leaves(grads["params"]["pursuer"]))
  # Its actions come from its own network: the pursuer's means sit at its action indices.
  sub = {"params": params["params"]["pursuer"]}
  own = networks.MLP((*SMALL.policy_hidden, 4)).apply(sub, x)
  idx = env.agent_action_indices["pursuer"]
  np.testing.assert_allclose(logits[:, idx], own[:, :2], rtol=1e-6)
  values = learner.value(learner.value_net.init(jax.random.PRNGKey(2), x), x)
  assert values.shape == (3, 2)


def test_an_objective_without_per_agent_rewards_is_refused_by_name():
  env = pursuit()
  diayn = objectives.diayn(num_skills=4, obs_indices="evader/pos_xy", env=env)
  with pytest.raises(ValueError, match=r"the env is multi-agent \(agents \['evader', "
                                       r"'pursuer'\]\), so MAPPO needs one reward per agent that "
                                       r"follows the env's, but objective 'diayn' gives every "
                                       r"agent the same reward"):
    training.make_trainer(env, diayn, SMALL)
  with pytest.raises(ValueError, match=r"objective 'tiny' gives a reward of shape \(\)"):
    training.make_trainer(env, reach_latent(), SMALL)


def skills_and_goal_desc():
  """Point a has no task; point b, starting at (0, 2), is paid -||p_b - (3, 0)||."""
  goal = dict(goal=dict(reward_type="root_goal", sdcomp="pos", indices=(0, 1),
                        target_goal=(3.0, 0.0)))
  return dict(components=dict(a=dict(component="point"),
                              b=dict(component="point", pos=(0.0, 2.0, 0.0), reward_fns=goal)),
              global_options=dict(timestep=0.05, substeps=2),
              agent_groups=dict(a=dict(), b=dict(reward_agents=("b",))))


def test_a_reward_free_objective_for_one_agent_learns_beside_a_task_agent():
  # DIAYN (4 skills on a's position) pays agent a only; b keeps its goal reward. Baselines: the
  # discriminator's chance accuracy is 0.25, and b's untrained policy scores below -150 (it stays
  # about 3.6 m from its goal for 50 steps). Seed 0 reached accuracy 0.95 and b -41 at 75 k steps.
  env = envs.create(desc=skills_and_goal_desc(), episode_length=50)
  diayn = objectives.diayn(num_skills=4, obs_indices="a/pos_xy", env=env)
  objective = objectives.for_agent(diayn, agent=0, num_agents=2)
  config = training.ppo_defaults("point", num_timesteps=100_000, num_evals=2)
  trainer = training.make_trainer(env, objective, config)
  untrained = jax.jit(trainer.evaluate)(
      training.policy_params(jax.jit(trainer.init)(jax.random.PRNGKey(0))), jax.random.PRNGKey(1))
  result = training.train(env, objective, config, seeds=(0,), progress=False)
  last = result.metrics[-1]
  assert float(untrained["eval/episode_reward/b"]) < -150
  assert last["eval/episode_reward/b"][0] > -75, last["eval/episode_reward/b"]
  assert last["disc/accuracy"][0] > 0.6, last["disc/accuracy"]


def test_for_agent_pays_the_objective_to_one_agent_and_the_env_to_the_others():
  from blx.objectives.base import Transition
  env = envs.create(desc=skills_and_goal_desc(), episode_length=50)
  diayn = objectives.diayn(num_skills=4, obs_indices="a/pos_xy", env=env)
  objective = objectives.for_agent(diayn, agent=0, num_agents=2)
  assert objective.name == "diayn@agent0" and objective.latent_size == diayn.latent_size
  params = objective.init(jax.random.PRNGKey(0), env.observation_size)
  obs = jnp.arange(env.observation_size, dtype=jnp.float32) / 10
  t = Transition(obs, jnp.zeros(env.action_size), obs, jnp.asarray([3.0, -2.0]),
                 jax.nn.one_hot(1, 4))
  reward = objective.reward(params, t)
  np.testing.assert_allclose(reward, [float(diayn.reward(params, t._replace(env_reward=3.0))),
                                      -2.0], rtol=1e-6)
  with pytest.raises(ValueError, match=r"for_agent: agent must be an index in 0..1, got 2"):
    objectives.for_agent(diayn, agent=2, num_agents=2)
  with pytest.raises(ValueError, match=r"for_agent: num_agents must be an int >= 2, got 1"):
    objectives.for_agent(diayn, agent=0, num_agents=1)
  with pytest.raises(ValueError, match=r"the env's reward has shape \(\), not \(2,\)"):
    objective.reward(params, t._replace(env_reward=jnp.zeros(())))
