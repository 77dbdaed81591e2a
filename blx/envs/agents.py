"""Agent groups: which reward terms and which actuators belong to which agent of a scene.

A multi-agent desc has a top-level ``agent_groups`` dict, one entry per agent::

    agent_groups=dict(
        agent0=dict(reward_agents=("agent0",)),                 # every term of component agent0
        agent1=dict(reward_names=("agent0__agent1/dist",)),     # one edge term
    )

Keys of an agent's entry (all optional):

* ``reward_names``: reward terms by their full name, ``<component>/<term>`` or ``<a>__<b>/<term>``
  (``env.reward_terms`` lists them).
* ``reward_agents``: components whose own terms (``<component>/<term>``) the agent claims; edge
  terms are claimed by name.
* ``action_agents``: components whose actuators the agent drives; default: the component with the
  agent's name.

Every reward term is claimed by exactly one agent and every actuator is driven by exactly one agent;
anything else is rejected with the terms or components named. Agents are ordered by name
(``env.agent_names``); the env's reward is a vector in that order.
"""

from __future__ import annotations

import dataclasses
from typing import Any, Mapping, Sequence

import numpy as np

from blx.options import check_names

__all__ = ["AgentGroups", "AGENT_KEYS", "check_agent_groups", "resolve_agent_groups"]

AGENT_KEYS = ("reward_names", "reward_agents", "action_agents")


@dataclasses.dataclass(frozen=True, eq=False)
class AgentGroups:
  """The resolved agent groups of an env.

  Attributes:
    names: agent names, sorted; reward vectors follow this order.
    term_agent: for each reward term (in ``env.reward_terms`` order), the index of its agent.
    action_indices: for each agent, the indices of its actuators in the full action vector.
  """

  names: tuple[str, ...]
  term_agent: np.ndarray
  action_indices: dict[str, np.ndarray]


def _names(where: str, value: Any) -> tuple[str, ...]:
  if isinstance(value, str) or not isinstance(value, (tuple, list)) or not all(
      isinstance(v, str) for v in value):
    raise ValueError(f"{where}: expected a list of names, e.g. ['agent0'], got {value!r}")
  return tuple(value)


def check_agent_groups(groups: Any) -> None:
  """Checks the shape of a desc's ``agent_groups`` (names are resolved when the env is built)."""
  if not isinstance(groups, Mapping) or not groups:
    raise ValueError("desc.agent_groups: expected a non-empty dict of {agent name: group}, e.g. "
                     "{'agent0': {'reward_agents': ['agent0']}}, got " + repr(groups))
  for name, group in groups.items():
    if not isinstance(name, str) or not name or "/" in name:
      raise ValueError(f"desc.agent_groups: invalid agent name {name!r}; names are non-empty "
                       "strings without '/'")
    where = f"agent_groups.{name}"
    if not isinstance(group, Mapping):
      raise ValueError(f"{where}: expected a dict with keys {list(AGENT_KEYS)}, got {group!r}")
    check_names(where, group, AGENT_KEYS, "key")
    for key in AGENT_KEYS:
      if key in group:
        _names(f"{where}.{key}", group[key])


def resolve_agent_groups(groups: Mapping[str, Any], terms: Sequence[str],
                         actuated: Mapping[str, np.ndarray]) -> AgentGroups:
  """Resolves ``groups`` against the env's reward ``terms`` and its components, given as
  ``actuated = {component: indices of its actuators in the action vector}`` (every component,
  empty indices for one without motors)."""
  check_agent_groups(groups)
  names = tuple(sorted(groups))
  owner: dict[str, list[str]] = {t: [] for t in terms}
  driver: dict[str, list[str]] = {c: [] for c in actuated}
  for agent in names:
    group, where = groups[agent], f"agent_groups.{agent}"
    claimed = list(_names(f"{where}.reward_names", group.get("reward_names", ())))
    check_names(f"{where}.reward_names", claimed, terms, "reward term")
    components = _names(f"{where}.reward_agents", group.get("reward_agents", ()))
    check_names(f"{where}.reward_agents", components, actuated, "component")
    claimed += [t for t in terms if t.split("/", 1)[0] in components]
    for term in dict.fromkeys(claimed):
      owner[term].append(agent)
    if "action_agents" in group:
      drives = _names(f"{where}.action_agents", group["action_agents"])
      check_names(f"{where}.action_agents", drives, actuated, "component")
    elif agent in actuated:
      drives = (agent,)
    else:
      raise ValueError(f"{where}: no component is named {agent!r}, so give 'action_agents', the "
                       f"components this agent drives; components are {sorted(actuated)}")
    idle = [c for c in drives if not len(actuated[c])]
    if idle:
      raise ValueError(f"{where}.action_agents: {idle} have no actuators; actuated components are "
                       f"{sorted(c for c, idx in actuated.items() if len(idx))}")
    for comp in drives:
      driver[comp].append(agent)
  unclaimed = [t for t, who in owner.items() if not who]
  if unclaimed:
    raise ValueError(f"agent_groups: reward terms {unclaimed} are claimed by no agent; every term "
                     "belongs to exactly one agent (claim it in 'reward_names' or, for a "
                     "component's own terms, 'reward_agents')")
  shared = {t: who for t, who in owner.items() if len(who) > 1}
  if shared:
    raise ValueError(f"agent_groups: reward terms claimed by several agents: {shared}; every term "
                     "belongs to exactly one agent")
  undriven = [c for c, who in driver.items() if not who and len(actuated[c])]
  if undriven:
    raise ValueError(f"agent_groups: the actuators of {undriven} are driven by no agent; give them "
                     "to one in 'action_agents'")
  doubled = {c: who for c, who in driver.items() if len(who) > 1}
  if doubled:
    raise ValueError(f"agent_groups: components driven by several agents: {doubled}; each "
                     "component's actuators belong to one agent")
  term_agent = np.asarray([names.index(owner[t][0]) for t in terms], np.int32)
  action_indices = {
      agent: np.sort(np.concatenate([actuated[c] for c, who in driver.items() if who == [agent]]
                                    + [np.zeros(0, np.int32)])).astype(np.int32)
      for agent in names}
  return AgentGroups(names, term_agent, action_indices)
