"""The registered environments, written as descs (Braxlines' single-agent registry on MJX).

``ant``, ``humanoid`` and ``halfcheetah`` are the paper's stock Brax v1 envs on the Brax bodies
(``blx.envs.brax_bodies``), with Brax's control steps: ant 50 ms (5 ms x 10 substeps), humanoid 15 ms
(3 ms x 5), half-cheetah 50 ms (3.125 ms x 16, Brax's own substep), and Brax's rewards (the ant's
small contact cost, -0.5e-3 sum clip(contact dv)^2, is left out). ``gym_ant``, ``gym_humanoid`` and
``gym_halfcheetah`` are the same tasks on the light MuJoCo/Gymnasium bodies. The point mass steps at
50 ms x 2 (100 ms). All use the MJX-friendly solver defaults of ``blx.envs.composer.GLOBAL_OPTIONS``
(one Newton iteration) except the half-cheetah, ``ant_push`` and ``ant_chase``, which need four for
a converged solve (see ``CHEETAH_OPTIONS``, ``ant_push`` and ``ant_chase``).
"""

from __future__ import annotations

from blx.envs.brax_bodies import ANT_OPTIONS, CHEETAH_OPTIONS, HUMANOID_OPTIONS
from blx.envs.registry import register_env

POINT_OPTIONS = dict(timestep=0.05, substeps=2)


def _run_goal(target=(4.0, 0.0)):
  """Braxlines' running task: r = 5 - ||v_xy - target||."""
  return dict(reward_type="root_goal", sdcomp="vel", indices=(0, 1), target_goal=target, offset=5.0)


def _plain(component: str, *, forward: float, healthy: float, control: float, options=None):
  rewards = dict(forward=dict(reward_type="forward", scale=forward),
                 control=dict(reward_type="control", scale=-control))
  if healthy:
    rewards["healthy"] = dict(reward_type="constant", value=healthy)
  desc = dict(components=dict(agent1=dict(component=component, reward_fns=rewards)))
  if options:
    desc["global_options"] = dict(options)
  return desc


def point():
  """A point mass in the plane with no task reward: the cheap body for reward-free runs on CPU."""
  return dict(components=dict(agent1=dict(component="point")), global_options=dict(POINT_OPTIONS))


def point_goal(target: tuple = (3.0, 0.0)):
  """The point mass rewarded for reaching ``target``: r = -||p_xy - target||."""
  goal = dict(reward_type="root_goal", sdcomp="pos", indices=(0, 1), target_goal=tuple(target))
  return dict(components=dict(agent1=dict(component="point", reward_fns=dict(goal=goal))),
              global_options=dict(POINT_OPTIONS))


def ant_run():
  return dict(components=dict(agent1=dict(component="ant", reward_fns=dict(goal=_run_goal()))),
              global_options=dict(ANT_OPTIONS))


def pro_ant_run(num_legs: int = 4):
  return dict(components=dict(agent1=dict(component="pro_ant",
                                          component_params=dict(num_legs=num_legs),
                                          reward_fns=dict(goal=_run_goal()))))


def humanoid_run():
  return dict(components=dict(agent1=dict(component="humanoid", reward_fns=dict(goal=_run_goal()))),
              global_options=dict(HUMANOID_OPTIONS))


def halfcheetah_run():
  return dict(components=dict(agent1=dict(component="halfcheetah",
                                          reward_fns=dict(goal=_run_goal()))),
              global_options=dict(CHEETAH_OPTIONS))


def ant_push():
  """An ant pushes a ball (radius 0.5) to a target velocity of 5 m/s in x and y, staying near it.

  Four Newton iterations, as ``ant_chase``: with one, the ant-and-ball solve at 5 ms substeps is
  not converged and float32 MJX and float64 MuJoCo part by 5 mm in the first step.
  """
  return dict(
      global_options=dict(ANT_OPTIONS, iterations=4),
      components=dict(
          agent1=dict(component="ant"),
          cap1=dict(component="singleton", component_params=dict(size=0.5), pos=(1.0, 0.0, 0.0),
                    observers=("root_z_joints",),
                    reward_fns=dict(goal=dict(reward_type="root_goal", sdcomp="vel", indices=(0, 1),
                                              target_goal=5.0, offset=5.0))),
      ),
      edges=dict(agent1__cap1=dict(
          extra_observers=[dict(observer_type="root_vec", indices=(0, 1))],
          reward_fns=dict(dist=dict(reward_type="root_dist", offset=5.0)))),
  )


def ant_chase():
  """agent1 chases agent2, which runs at 4 m/s; the episode ends when agent1 is within 1 m.

  Four Newton iterations: with one, the two-ant constraint solve is not converged and float32 MJX
  and float64 MuJoCo part by 2.6 cm in three random steps; with four they agree to 3e-7.
  """
  return dict(
      global_options=dict(ANT_OPTIONS, iterations=4),
      components=dict(
          agent1=dict(component="ant"),
          agent2=dict(component="ant", pos=(0.0, 2.0, 0.0), reward_fns=dict(goal=_run_goal())),
      ),
      edges=dict(agent1__agent2=dict(
          extra_observers=[dict(observer_type="root_vec", indices=(0, 1))],
          reward_fns=dict(dist=dict(reward_type="root_dist", offset=5.0, min_dist=1.0)))),
  )


register_env("point", point, episode_length=50)
register_env("point_goal", point_goal, episode_length=50)
register_env("ant", lambda: _plain("ant", forward=1.0, healthy=1.0, control=0.5,
                                   options=ANT_OPTIONS))
register_env("humanoid", lambda: _plain("humanoid", forward=1.25, healthy=5.0, control=0.01,
                                        options=HUMANOID_OPTIONS))
register_env("halfcheetah", lambda: _plain("halfcheetah", forward=1.0, healthy=0.0, control=0.1,
                                           options=CHEETAH_OPTIONS))
register_env("gym_ant", lambda: _plain("gym_ant", forward=1.0, healthy=1.0, control=0.5))
register_env("gym_humanoid", lambda: _plain("gym_humanoid", forward=1.25, healthy=5.0,
                                            control=0.1, options=HUMANOID_OPTIONS))
register_env("gym_halfcheetah", lambda: _plain("gym_halfcheetah", forward=1.0, healthy=0.0,
                                               control=0.1))
register_env("ant_run", ant_run)
register_env("ant_push", ant_push)
register_env("ant_chase", ant_chase)
register_env("pro_ant_run", pro_ant_run)
register_env("humanoid_run", humanoid_run)
register_env("halfcheetah_run", halfcheetah_run)
