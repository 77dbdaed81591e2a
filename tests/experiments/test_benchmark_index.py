"""benchmarks/README.md, the index of the benchmark scripts: it names every script, and its
commands name scripts, studies, sweep specs and options that exist (read from the scripts' source,
so that a renamed option or a new script without a row fails here)."""

import os
import re
import shlex

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")
BENCHMARKS = os.path.join(ROOT, "benchmarks")
SCRIPT = re.compile(r"^benchmarks/([a-z_]+\.(?:py|sh))$")


def _read(path: str) -> str:
  with open(path) as f:
    return f.read()


def _commands(text: str) -> list[list[str]]:
  """Every inline code span of the index that runs a script or ``blx``, split as a shell would."""
  spans = re.findall(r"`([^`]+)`", text)
  return [shlex.split(s.replace("\\|", "|")) for s in spans
          if re.search(r"\b(?:python3?|bash|blx) ", s)]


def _invocations(words: list[str]) -> list[tuple[str, list[str]]]:
  """(script, its arguments) for each ``benchmarks/X.py`` or ``.sh`` in one command; a script's
  arguments run to the next script (``device_call.sh`` runs another command after its own)."""
  found = [(SCRIPT.match(w).group(1), i) for i, w in enumerate(words) if SCRIPT.match(w)]
  ends = [i for _, i in found[1:]] + [len(words)]
  return [(name, words[i + 1:end]) for (name, i), end in zip(found, ends)]


def problems(text: str, benchmarks: str = BENCHMARKS) -> list[str]:
  """What is wrong with the index ``text`` of the scripts in ``benchmarks``: a script it has no
  row for, a command's script that does not exist, an option its script does not take (an
  analysis takes ``common.py``'s shared ones too), a study ``ablations.py`` lacks, or a sweep
  spec that does not exist."""
  found = []
  scripts = sorted(n for n in os.listdir(benchmarks) if n.endswith((".py", ".sh")))
  found += [f"no row for {n}" for n in scripts if f"`{n}`" not in text]
  commands = _commands(text)
  studies = []
  for name, args in (inv for words in commands for inv in _invocations(words)):
    path = os.path.join(benchmarks, name)
    if not os.path.exists(path):
      found.append(f"benchmarks/{name} does not exist")
      continue
    if not name.endswith(".py"):
      continue
    source = _read(path)
    if "add_analysis_arguments" in source:
      source += _read(os.path.join(benchmarks, "common.py"))
    found += [f"{name} takes no {a}" for a in args if a.startswith("--") and f'"{a}"' not in source]
    if name == "ablations.py" and args and not args[0].startswith("-"):
      studies.append(args[0])
  listed = re.search(r"`--list` names them: (.*?)\)", text)
  studies += re.findall(r"`([a-z_]+)`", listed.group(1)) if listed else []
  source = _read(os.path.join(benchmarks, "ablations.py"))
  found += [f"ablations.py has no study {s}" for s in studies
            if not re.search(rf'^\s+"{s}": Study\(', source, re.M)]
  specs = [words[2] for words in commands if words[:2] == ["blx", "sweep"] and len(words) > 2]
  found += [f"{s} does not exist" for s in specs
            if not os.path.exists(os.path.join(benchmarks, "..", s))]
  return found


def test_the_index_names_every_script_and_its_commands_hold():
  text = _read(os.path.join(BENCHMARKS, "README.md"))
  assert problems(text) == []
  # The index is read as what it is, not as empty by a broken pattern: a command for every row.
  invocations = [inv for words in _commands(text) for inv in _invocations(words)]
  assert len(invocations) >= 35
  assert len(re.search(r"`--list` names them: (.*?)\)", text).group(1).split(",")) >= 7


def test_a_renamed_option_a_missing_script_an_unknown_study_and_a_lost_spec_are_each_named():
  text = _read(os.path.join(BENCHMARKS, "README.md"))
  doctored = (text.replace("--labels DIAYN,DIAYN_FULL", "--label DIAYN,DIAYN_FULL")
              .replace("`feature_dims.py`", "`feature_dim.py`")
              .replace("benchmarks/seed_paths.py RUN_A", "benchmarks/seed_path.py RUN_A")
              .replace("`sn_cdiayn`", "`sn_gcrl`")
              .replace("sweeps/pro_ant_legs.json", "sweeps/pro_ant_leg.json"))
  assert problems(doctored) == [
      "no row for feature_dims.py",
      "feature_dims.py takes no --label",
      "benchmarks/seed_path.py does not exist",
      "ablations.py has no study sn_gcrl",
      "benchmarks/sweeps/pro_ant_leg.json does not exist",
  ]


def test_an_analysis_takes_the_shared_options_and_a_command_is_split_per_script():
  # --deterministic comes from common.add_analysis_arguments for posture.py, not for peer.py.
  text = ("`posture.py` `python benchmarks/posture.py RUN --deterministic --episodes 4`\n"
          "`python benchmarks/peer.py --deterministic`")
  assert [p for p in problems(text) if "takes no" in p] == ["peer.py takes no --deterministic"]
  line = "bash benchmarks/device_call.sh N runs/N 540 python3 benchmarks/ablations.py legs --arm 8"
  assert _invocations(shlex.split(line)) == [
      ("device_call.sh", ["N", "runs/N", "540", "python3"]),
      ("ablations.py", ["legs", "--arm", "8"])]
