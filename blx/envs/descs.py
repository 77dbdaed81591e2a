"""The registered environments, written as descs (Braxlines' single-agent registry on MJX).

``ant``, ``humanoid`` and ``halfcheetah`` are the paper's stock Brax v1 envs on the Brax bodies
(``blx.envs.brax_bodies``), with Brax's control steps: ant 50 ms (5 ms x 10 substeps), humanoid
15 ms (3 ms x 5), half-cheetah 50 ms (3.125 ms x 16, Brax's own substep), and Brax's rewards (the
ant's small contact cost, -0.5e-3 sum clip(contact dv)^2, is left out). ``gym_ant``,
``gym_humanoid`` and ``gym_halfcheetah`` are the same tasks on the light MuJoCo/Gymnasium bodies.
The stock humanoid observes what Brax's did beyond the component's default: its shins' contacts and
its motors' applied actions (``HUMANOID_OBSERVERS``). The point mass steps at 50 ms x 2 (100 ms).
All use the MJX-friendly solver defaults of ``blx.envs.composer.GLOBAL_OPTIONS`` (one Newton
iteration) except the half-cheetah, ``ant_push`` and ``ant_chase``, which need four for a converged
solve (see ``CHEETAH_OPTIONS``, ``ant_push`` and ``ant_chase``).
"""

from __future__ import annotations

import math

from blx.envs.brax_bodies import ANT_OPTIONS, CHEETAH_OPTIONS, HUMANOID_OPTIONS
from blx.envs.registry import register_env

POINT_OPTIONS = dict(timestep=0.05, substeps=2)
# The paper's humanoid is Brax v0.0.6's stock env, whose observation holds the shins' contacts and
# the motors' applied actions besides the state (299 numbers): blx's 74 are the state's 45 and those
# two parts (Brax's further 165, functions of the state, are the observer "com", an option).
# Braxlines' composer humanoid, the component, observes the 45 alone, and so does blx's. The env
# observed the 45 alone before 2026-12-06; a run configured then names no observers in its desc and
# is rebuilt as it trained, and ``{"components.agent1.observers": ["root_z_joints"]}`` gives that
# observation to a new run.
HUMANOID_OBSERVERS = ("root_z_joints", "cfrc", "actuator")


def _run_goal(target=(4.0, 0.0)):
  """Braxlines' running task: r = 5 - ||v_xy - target||."""
  return dict(reward_type="root_goal", sdcomp="vel", indices=(0, 1), target_goal=target, offset=5.0)


def _plain(component: str, *, forward: float, healthy: float, control: float, options=None,
           observers=None):
  rewards = dict(forward=dict(reward_type="forward", scale=forward),
                 control=dict(reward_type="control", scale=-control))
  if healthy:
    rewards["healthy"] = dict(reward_type="constant", value=healthy)
  desc = dict(components=dict(agent1=dict(component=component, reward_fns=rewards)))
  if observers:
    desc["components"]["agent1"]["observers"] = list(observers)
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


# pro_ant_run's physics steps per 0.02 s control step. "original", the default: the original's 16
# of 1.25 ms. "blx": 4 substeps of the ant's 5 ms, a quarter of the physics, a third to a quarter
# of the cost per env step. At the original's step three legs learn markedly better (-1,713
# against -2,415 episode score at 23 M env steps, p < 0.001) and four legs learn more per env step
# (-1,136 against -1,562 at 21.8 M, p 0.008); blx's step reaches four legs' level in less wall
# time (371 s against 588 s) but levels off lower on three (benchmarks/RESULTS.md, sessions 27
# and 28).
PRO_ANT_STEPS = {"blx": dict(timestep=ANT_OPTIONS["timestep"], substeps=4),
                 "original": dict(timestep=0.00125, substeps=16)}


def pro_ant_run(num_legs: int = 4, step: str = "original"):
  """Braxlines' ``pro_ant_run``: ``ant_run``'s goal (r = 5 - ||v_xy - (4, 0)||) on a pro_ant of
  ``num_legs`` legs (the paper's morphology sweep: 2, 3, 4, 8, 10), at the original's 0.02 s
  control step.

  ``step`` names the physics step in it (``PRO_ANT_STEPS``): ``"original"`` (the default) is the
  original's 16 substeps of 1.25 ms; ``"blx"`` (a deviation, an option for speed) is 4 of the ant's
  5 ms, a third to a quarter of the cost per env step. At blx's step three legs level off far below
  the original's, and four legs need 2.4 times the env steps for the same score, in about two
  thirds of the wall time (RESULTS, sessions 27 and 28).

  The default of 4 legs is later Braxlines' (``create_pro_ant_run``); at the paper's commit the
  registered env had 10. The sweep names its leg count, so the default does not change it."""
  if not isinstance(step, str) or step not in PRO_ANT_STEPS:
    raise ValueError(f"pro_ant_run: step={step!r} is not a physics step; valid: 'original' (16 "
                     "substeps of 1.25 ms, the default) or 'blx' (4 of 5 ms)")
  return dict(components=dict(agent1=dict(component="pro_ant",
                                          component_params=dict(num_legs=num_legs),
                                          reward_fns=dict(goal=_run_goal()))),
              global_options=dict(ANT_OPTIONS, **PRO_ANT_STEPS[step]))


# Braxlines' octopus_run steps 0.02 s per control step as 16 substeps; blx keeps both (at 5 ms x 4
# the octopus, which touches the floor with one arm, moves several times faster under the same
# random actions: the thin contact is sensitive to the step).
OCTOPUS_OPTIONS = dict(PRO_ANT_STEPS["original"])


def octopus_run(all_collide: bool = False):
  """Braxlines' ``octopus_run``: ``ant_run``'s goal (r = 5 - ||v_xy - (4, 0)||) on the octopus
  (``blx.envs.brax_bodies.octopus``; ``all_collide`` as there), at the original's 0.02 s control
  step of 16 substeps."""
  return dict(components=dict(agent1=dict(component="octopus",
                                          component_params=dict(all_collide=all_collide),
                                          reward_fns=dict(goal=_run_goal()))),
              global_options=dict(OCTOPUS_OPTIONS))


def ant_on_ball():
  """A four-legged pro_ant standing on a free ball of radius 3 (mass 27, Braxlines' singleton
  density), rewarded for running at (3, 0) m/s (r = 4 - ||v_xy - (3, 0)||); the height rule is
  lifted by the ball's 6 m (``z_offset``), so the episode ends when the ant falls off.

  The original stepped 0.02 s per control step in 16 substeps (1.25 ms); blx keeps the 0.02 s
  control step in 4 substeps of 5 ms, the ant's own substep (``ANT_OPTIONS``), with four Newton
  iterations for the ant-on-ball contacts.
  """
  goal = dict(reward_type="root_goal", sdcomp="vel", indices=(0, 1), target_goal=(3.0, 0.0),
              offset=4.0)
  return dict(
      global_options=dict(ANT_OPTIONS, **PRO_ANT_STEPS["blx"], iterations=4),
      components=dict(
          agent1=dict(component="pro_ant", component_params=dict(num_legs=4),
                      pos=(0.0, 0.0, 6.0), term_params=dict(z_offset=6.0),
                      reward_fns=dict(goal=goal)),
          ball=dict(component="singleton", component_params=dict(size=3.0)),
      ),
  )


def humanoid_run():
  return dict(components=dict(agent1=dict(component="humanoid", reward_fns=dict(goal=_run_goal()))),
              global_options=dict(HUMANOID_OPTIONS))


def halfcheetah_run():
  return dict(components=dict(agent1=dict(component="halfcheetah",
                                          reward_fns=dict(goal=_run_goal()))),
              global_options=dict(CHEETAH_OPTIONS))


def ant_push(goal_scale: float = 1.0):
  """An ant pushes a ball (radius 0.5) to a target velocity of 5 m/s in x and y, staying near it.

  ``goal_scale`` weighs the ball's velocity term against the ant-to-ball term (the paper's Ant Push
  sweep: 0.2, 0.5, 1).

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
                                              target_goal=5.0, offset=5.0, scale=goal_scale))),
      ),
      edges=dict(agent1__cap1=dict(
          extra_observers=[dict(observer_type="root_vec", indices=(0, 1))],
          reward_fns=dict(dist=dict(reward_type="root_dist", offset=5.0)))),
  )


def ant_chase(goal_scale: float = 1.0):
  """agent1 chases agent2, which runs at 4 m/s; the episode ends when agent1 is within 1 m.

  ``goal_scale`` weighs agent2's running term against the chase term (the original's composer
  sweep: 0.2, 0.5, 1).

  Four Newton iterations: with one, the two-ant constraint solve is not converged and float32 MJX
  and float64 MuJoCo part by 2.6 cm in three random steps; with four they agree to 3e-7.
  """
  return dict(
      global_options=dict(ANT_OPTIONS, iterations=4),
      components=dict(
          agent1=dict(component="ant"),
          agent2=dict(component="ant", pos=(0.0, 2.0, 0.0),
                      reward_fns=dict(goal=dict(_run_goal(), scale=goal_scale))),
      ),
      edges=dict(agent1__agent2=dict(
          extra_observers=[dict(observer_type="root_vec", indices=(0, 1))],
          reward_fns=dict(dist=dict(reward_type="root_dist", offset=5.0, min_dist=1.0)))),
  )


# --------------------------------------------------------------------------------------------------
# Multi-agent scenes (Braxlines' ``follow``, ``chase`` and ``sumo``): agents ``agent0`` ..
# ``agent<n-1>`` on a circle of radius ``init_r``, every pair observing its xy root offset.

# ``agent_collide`` (every scene): which colliders of two agents meet, as the original's edge
# ``collide_type``: "full" (the original's default: every collider pair, 25 for two ants), "root"
# (the two roots only) or "none" (agents pass through each other). Fewer pairs make the physics
# cheaper (two ants on the CPU: 4.9 ms per 64-world step with "full", 3.2 ms with "none"); "full"
# is the original. A sumo without contacts cannot push.
AGENT_COLLIDE = {"full": "full", "root": "root", "none": None}
MAX_DIST = 20.0   # the original's distance at which a chase or follow episode ends
MIN_DIST = 0.5    # ... and the distance at which a predator catches the prey
MAX_AGENTS = 10   # agent0 .. agent9 sort as they are numbered

# Solver settings per main body: bodies in contact with each other need converged solves (see
# ``ant_chase``); the point has no colliders. The original's scenes set no step, so every agent
# took the Composer's default 0.05 s (10 substeps): blx's ant and pro_ant step the same 0.05 s
# (10 x 5 ms); its humanoid and halfcheetah keep their own bodies' steps (the original's
# multi-agent sweeps use only ants).
_SCENE_OPTIONS = {"ant": dict(ANT_OPTIONS, iterations=4),
                  "pro_ant": dict(ANT_OPTIONS, iterations=4),
                  "humanoid": dict(HUMANOID_OPTIONS, iterations=4),
                  "halfcheetah": dict(CHEETAH_OPTIONS), "point": dict(POINT_OPTIONS)}


def _agents(where: str, main_agent: str, other_agent: str, num_agents: int, main_agent_params,
            other_agent_params, init_r: float, agent_collide: str = "full") -> dict:
  if isinstance(num_agents, bool) or not isinstance(num_agents, int) or not (
      2 <= num_agents <= MAX_AGENTS):
    raise ValueError(f"{where}: num_agents must be an int in 2..{MAX_AGENTS}, got {num_agents!r}")
  if not isinstance(init_r, (int, float)) or isinstance(init_r, bool) or not (
      math.isfinite(init_r) and init_r > 0):
    raise ValueError(f"{where}: init_r must be a positive number, got {init_r!r}")
  if agent_collide not in AGENT_COLLIDE:
    raise ValueError(f"{where}: agent_collide={agent_collide!r}; valid values are "
                     f"{list(AGENT_COLLIDE)}")
  components, edges = {}, {}
  for i in range(num_agents):
    angle = 2.0 * math.pi * i / num_agents
    comp = dict(component=main_agent if i == 0 else other_agent,
                pos=(init_r * math.cos(angle), init_r * math.sin(angle), 0.0))
    params = main_agent_params if i == 0 else other_agent_params
    if params:
      comp["component_params"] = dict(params)
    components[f"agent{i}"] = comp
    for j in range(i):
      edges[f"agent{j}__agent{i}"] = dict(
          collide_type=AGENT_COLLIDE[agent_collide],
          extra_observers=[dict(observer_type="root_vec", indices=(0, 1))])
  desc = dict(components=components, edges=edges,
              agent_groups={a: dict(reward_names=()) for a in components})
  if main_agent in _SCENE_OPTIONS:
    desc["global_options"] = dict(_SCENE_OPTIONS[main_agent])
  return desc


def _claim(desc: dict, agent: str, *terms: str) -> None:
  desc["agent_groups"][agent]["reward_names"] += terms


def follow(leader_vel: float = 3.0, num_agents: int = 2, main_agent: str = "ant",
           other_agent: str = "ant", main_agent_params: dict | None = None,
           other_agent_params: dict | None = None, init_r: float = 2.0,
           agent_collide: str = "full"):
  """agent0 leads, running at (leader_vel, 0) m/s (r = leader_vel + 2 - ||v_xy - target||); every
  other agent follows it (r = 21 - ||p - p_leader||; the episode ends beyond 20 m)."""
  desc = _agents("follow", main_agent, other_agent, num_agents, main_agent_params,
                 other_agent_params, init_r, agent_collide)
  desc["components"]["agent0"]["reward_fns"] = dict(goal=dict(
      reward_type="root_goal", sdcomp="vel", indices=(0, 1), target_goal=(leader_vel, 0.0),
      offset=leader_vel + 2.0))
  _claim(desc, "agent0", "agent0/goal")
  for i in range(1, num_agents):
    edge = f"agent0__agent{i}"
    desc["edges"][edge]["reward_fns"] = dict(dist=dict(
        reward_type="root_dist", max_dist=MAX_DIST, offset=MAX_DIST + 1.0))
    _claim(desc, f"agent{i}", f"{edge}/dist")
  return desc


def chase(num_agents: int = 2, main_agent: str = "ant", other_agent: str = "ant",
          main_agent_params: dict | None = None, other_agent_params: dict | None = None,
          init_r: float = 2.0, agent_collide: str = "full"):
  """agent0 is the prey, the others are predators. A predator earns 21 - distance and a 20,000
  bonus for a catch (within 0.5 m, which ends the episode); the prey earns its distance from each
  predator and 20,000 for getting 20 m away (which ends it too). Every agent also earns its planar
  speed."""
  desc = _agents("chase", main_agent, other_agent, num_agents, main_agent_params,
                 other_agent_params, init_r, agent_collide)
  for i in range(1, num_agents):
    edge = f"agent0__agent{i}"
    desc["edges"][edge]["reward_fns"] = dict(
        chase=dict(reward_type="root_dist", offset=MAX_DIST + 1.0, min_dist=MIN_DIST,
                   done_bonus=1000.0 * MAX_DIST),
        escape=dict(reward_type="root_dist", scale=-1.0, max_dist=MAX_DIST,
                    done_bonus=1000.0 * MAX_DIST))
    _claim(desc, f"agent{i}", f"{edge}/chase")
    _claim(desc, "agent0", f"{edge}/escape")
  for agent, comp in desc["components"].items():
    comp["reward_fns"] = dict(run=dict(reward_type="norm", sdcomp="vel", indices=(0, 1),
                                       scale=-1.0))
    _claim(desc, agent, f"{agent}/run")
  return desc


def _ring(radius: float, segments: int = 20) -> dict:
  """The sumo ring: ``segments`` thin capsules on the floor along a circle, frozen and without
  contacts (drawn only)."""
  side = 2.0 * radius * math.tan(math.pi / segments)
  ring = {}
  for i in range(segments):
    angle = 2.0 * math.pi * i / segments
    half = (angle + math.pi / 2) / 2  # the capsule lies along x: turn it to the circle's tangent
    ring[f"ring{i}"] = dict(
        component="singleton",
        component_params=dict(size=(radius / 40.0, side), collider_type="capsule", no_obs=True),
        pos=(radius * math.cos(angle), radius * math.sin(angle), 0.0),
        quat=(math.cos(half), 0.0, 0.0, math.sin(half)), frozen=True, collide=False)
  return ring


def sumo(centering_scale: float = 1.0, control_scale: float = 0.1, draw_scale: float = 0.0,
         knocking_scale: float = 1.0, opp_scale: float = 1.0, ring_size: float = 3.0,
         win_bonus: float = 1.0, num_agents: int = 2, main_agent: str = "ant",
         other_agent: str = "ant", main_agent_params: dict | None = None,
         other_agent_params: dict | None = None, init_r: float = 2.0,
         agent_collide: str = "full"):
  """agent0 (the yokozuna) against the others (komusubis) in a ring of radius ``ring_size``.

  For each pair: pushing the opponent out pays ``win_bonus`` and ends the episode (before that,
  -knocking_scale * exp(-||p_xy(opponent)||)); leaving the ring costs ``win_bonus`` (before that,
  centering_scale * exp(-||p_xy(self)||)); moving against the opponent's velocity pays
  opp_scale * max(0, -v_self . v_opp / ||v_opp||). Every agent pays control_scale * ||a|| and
  draw_scale per step.
  """
  if not isinstance(ring_size, (int, float)) or isinstance(ring_size, bool) or not (
      math.isfinite(ring_size) and ring_size > 0):
    raise ValueError(f"sumo: ring_size must be a positive number, got {ring_size!r}")
  desc = _agents("sumo", main_agent, other_agent, num_agents, main_agent_params,
                 other_agent_params, init_r, agent_collide)

  def out_of_ring(of, scale, bonus):
    return dict(reward_type="exp_norm", of=of, sdcomp="pos", indices=(0, 1), max_dist=ring_size,
                done_bonus=bonus, scale=scale)

  for i in range(1, num_agents):
    edge, komu = f"agent0__agent{i}", f"agent{i}"
    desc["edges"][edge]["reward_fns"] = dict(
        komu_win_bonus=out_of_ring("agent0", -knocking_scale, win_bonus),
        komu_lose_penalty=out_of_ring(komu, centering_scale, -win_bonus),
        yoko_win_bonus=out_of_ring(komu, -knocking_scale, win_bonus),
        yoko_lose_penalty=out_of_ring("agent0", centering_scale, -win_bonus),
        komu_move_to_yoko=dict(reward_type="direction", of=komu, scale=opp_scale),
        yoko_move_to_komu=dict(reward_type="direction", of="agent0", scale=opp_scale))
    _claim(desc, komu, *(f"{edge}/komu_{t}" for t in ("win_bonus", "lose_penalty", "move_to_yoko")))
    _claim(desc, "agent0",
           *(f"{edge}/yoko_{t}" for t in ("win_bonus", "lose_penalty", "move_to_komu")))
  for agent, comp in desc["components"].items():
    comp["reward_fns"] = dict(control_penalty=dict(reward_type="control", scale=control_scale),
                              draw_penalty=dict(reward_type="constant", value=-draw_scale))
    _claim(desc, agent, f"{agent}/control_penalty", f"{agent}/draw_penalty")
  desc["components"].update(_ring(float(ring_size)))
  return desc


register_env("point", point, episode_length=50)
register_env("point_goal", point_goal, episode_length=50)
register_env("ant", lambda: _plain("ant", forward=1.0, healthy=1.0, control=0.5,
                                   options=ANT_OPTIONS))
register_env("humanoid", lambda: _plain("humanoid", forward=1.25, healthy=5.0, control=0.01,
                                        options=HUMANOID_OPTIONS, observers=HUMANOID_OBSERVERS))
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
register_env("ant_on_ball", ant_on_ball)
register_env("octopus_run", octopus_run)
register_env("humanoid_run", humanoid_run)
register_env("halfcheetah_run", halfcheetah_run)
register_env("follow", follow)
register_env("chase", chase)
register_env("sumo", sumo)
