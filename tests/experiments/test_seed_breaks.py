"""benchmarks/seed_breaks.py: each seed's largest worsening between two evaluations, what PPO's
statistics did there against their base rate, an early window against the last evaluations, and
the rank of the final metric by a statistic; on small metrics.csv files written here."""

import csv
import json
import math

import pytest

from tests.experiments import load_benchmark

seed_breaks = load_benchmark("seed_breaks")

STEPS = [10e6, 20e6, 30e6, 40e6, 50e6]
# Seed 0 breaks between 20 and 30 M (MI 1.0 -> 0.4) and stays broken; seed 1 breaks between 30
# and 40 M (1.2 -> 0.9) and comes back (1.15 is nearer 1.2 than 0.9).
MI = {0: [0.9, 1.0, 0.4, 0.45, 0.5], 1: [1.0, 1.1, 1.2, 0.9, 1.15]}
# grad_norm rises at both breaks and at one of the six other steps (seed 0, 40 -> 50 M).
GRAD = {0: [1.0, 1.0, 3.0, 2.0, 2.5], 1: [2.0, 1.5, 1.0, 4.0, 3.0]}


def _write(path, columns, seeds=(0, 1), steps=STEPS):
  with open(path, "w", newline="") as f:
    writer = csv.DictWriter(f, fieldnames=["seed", "env_steps", *columns])
    writer.writeheader()
    for i, step in enumerate(steps):
      for seed in seeds:
        writer.writerow({"seed": seed, "env_steps": step,
                         **{k: v[seed][i] for k, v in columns.items()}})
  return str(path)


@pytest.fixture
def mi_csv(tmp_path):
  return _write(tmp_path / "row_metrics.csv", {"eval/mi": MI, "grad_norm": GRAD})


def test_each_seeds_break_is_its_largest_worsening_and_whether_it_came_back(mi_csv):
  _, rows = seed_breaks.read_rows(mi_csv)
  by_seed = seed_breaks.series(rows, "eval/mi")
  sign = seed_breaks.worse_direction("eval/mi")
  assert sign == -1  # a fall of the MI is the worse direction
  zero, one = (seed_breaks.seed_break(by_seed[s], "eval/mi", sign) for s in (0, 1))
  assert (zero["env_steps_before"], zero["env_steps"]) == (20e6, 30e6)
  assert (zero["before"], zero["after"], zero["final"]) == (1.0, 0.4, 0.5)
  assert zero["worsening"] == pytest.approx(0.6) and not zero["came_back"]
  assert (one["env_steps_before"], one["env_steps"]) == (30e6, 40e6)
  assert one["worsening"] == pytest.approx(0.3) and one["came_back"]
  assert zero["diagnostics"] == {"grad_norm": [1.0, 3.0]}  # only the columns the CSV has


def test_a_seed_whose_metric_never_worsened_has_no_break(tmp_path, capsys):
  mi = {0: [0.5, 0.6, 0.7], 1: [0.9, 0.4, 0.45]}
  grad = {0: [1.0, 2.0, 3.0], 1: [1.0, 2.0, 1.0]}
  path = _write(tmp_path / "metrics.csv", {"eval/mi": mi, "grad_norm": grad}, steps=STEPS[:3])
  _, rows = seed_breaks.read_rows(path)
  by_seed = seed_breaks.series(rows, "eval/mi")
  breaks = {s: seed_breaks.seed_break(r, "eval/mi", -1) for s, r in by_seed.items()}
  assert breaks[0] is None and breaks[1]["env_steps"] == 20e6
  # Seed 0's two steps count as steps elsewhere (grad_norm rose at both), seed 1's second too.
  shares = seed_breaks.rise_shares(by_seed, breaks)["grad_norm"]
  assert (shares["breaks"], shares["steps_elsewhere"]) == (1, 3)
  assert shares["elsewhere"] == pytest.approx(2 / 3)
  seed_breaks.main([path, "--metric", "eval/mi", "--plot", str(tmp_path / "b.png")])
  assert "| 0 | never worsened |" in capsys.readouterr().out


def test_the_worse_direction_follows_the_metric_or_the_flag(mi_csv):
  assert seed_breaks.worse_direction("eval/lgr") == 1
  assert seed_breaks.worse_direction("eval/energy_distance_braxlines") == 1
  assert seed_breaks.worse_direction("eval/entropy") == -1
  assert seed_breaks.worse_direction("eval/conditional_entropy") == 1  # H(s|z): lower is better
  assert seed_breaks.worse_direction("eval/mi", "up") == 1
  _, rows = seed_breaks.read_rows(mi_csv)
  by_seed = seed_breaks.series(rows, "eval/mi")
  # Read as if a rise were worse, seed 1's break is its largest rise, 0.9 -> 1.15.
  rising = seed_breaks.seed_break(by_seed[1], "eval/mi", 1)
  assert (rising["before"], rising["after"]) == (0.9, 1.15)


def test_a_statistic_that_rises_at_every_break_is_set_against_its_base_rate(mi_csv):
  _, rows = seed_breaks.read_rows(mi_csv)
  by_seed = seed_breaks.series(rows, "eval/mi")
  breaks = {s: seed_breaks.seed_break(r, "eval/mi", -1) for s, r in by_seed.items()}
  shares = seed_breaks.rise_shares(by_seed, breaks)
  # 8 steps in all, 2 of them breaks; of the other 6 grad_norm rose at one (seed 0, 2.0 -> 2.5).
  # Two rises in two breaks at a base rate of 1/6: P = (1/6)^2 = 1/36 (two-sided: the other tail,
  # no rise, has P (5/6)^2 = 25/36, above 1/36, so it does not count).
  assert shares == {"grad_norm": {"at_breaks": 1.0, "breaks": 2, "elsewhere": pytest.approx(1 / 6),
                                  "steps_elsewhere": 6, "p": pytest.approx(1 / 36)}}


def test_the_early_window_against_the_last_evaluations_is_paired_over_seeds(tmp_path):
  # Three seeds; each seed's late mean minus its early mean is 1, 2 and 3.
  mi = {0: [1.0, 1.0, 0.0, 0.0], 1: [2.0, 2.0, 0.0, 0.0], 2: [3.0, 3.0, 0.0, 0.0]}
  path = _write(tmp_path / "metrics.csv", {"eval/mi": mi}, seeds=(0, 1, 2), steps=STEPS[:4])
  _, rows = seed_breaks.read_rows(path)
  by_seed = seed_breaks.series(rows, "eval/mi")
  w = seed_breaks.compare_windows(by_seed, "eval/mi", -1, (10e6, 20e6), last=2)
  assert w["window_per_seed"] == [1.0, 2.0, 3.0] and w["last_per_seed"] == [0.0, 0.0, 0.0]
  # differences -1, -2, -3: mean -2, sample std 1, t = -2 / (1 / sqrt(3)) = -3.464
  assert w["paired_t"] == pytest.approx(-2 * math.sqrt(3))
  assert w["seeds_worse"] == 3 and w["window_mean"] == pytest.approx(2.0)


def test_the_rank_reads_the_final_metric_from_eval_json_where_it_has_it(mi_csv, tmp_path):
  _, rows = seed_breaks.read_rows(mi_csv)
  by_seed = seed_breaks.series(rows, "eval/mi")
  name = str(tmp_path / "row")
  finals, source = seed_breaks.final_values(name, "eval/mi", by_seed)
  assert finals == [0.5, 1.15] and source == "the last evaluation"
  with open(tmp_path / "row_eval.json", "w") as f:
    json.dump({"per_seed": {"eval/mi": [0.7, 0.2]}}, f)
  finals, source = seed_breaks.final_values(name, "eval/mi", by_seed)
  assert finals == [0.7, 0.2] and source.endswith("row_eval.json")
  with open(tmp_path / "row_eval.json", "w") as f:  # the seeds it lists set the order
    json.dump({"seeds": [1, 0], "per_seed": {"eval/mi": [0.2, 0.7]}}, f)
  assert seed_breaks.final_values(name, "eval/mi", by_seed)[0] == [0.7, 0.2]
  # grad_norm over 10-30 M: seed 0 5/3, seed 1 1.5; the larger goes with the larger final MI
  ranked = seed_breaks.rank(by_seed, "grad_norm", (10e6, 30e6), finals)
  assert ranked["window_means"] == pytest.approx([5 / 3, 1.5])
  assert ranked["spearman"] == pytest.approx(1.0)


def test_an_lgr_not_scored_on_the_papers_goals_never_reads_as_a_break(tmp_path):
  # The LGR falls from 2.0 (blx's old goals, before 20 M) to 0.5 and then rises to 0.9 at 40 M
  # on the paper's goals; the switch of goals must not count as a change at all.
  lgr = {0: [2.0, 2.0, 0.5, 0.9, 0.8]}
  path = _write(tmp_path / "row_metrics.csv", {"eval/lgr": lgr}, seeds=(0,))
  segment = {"started": "t", "device": "cpu", "platform": "cpu", "device_count": 1,
             "versions": {}}
  with open(tmp_path / "row_provenance.json", "w") as f:
    json.dump({"segments": [{**segment, "from_env_steps": 0, "to_env_steps": 20e6},
                            {**segment, "from_env_steps": 20e6, "to_env_steps": 50e6,
                             "lgr_goals": "braxlines"}]}, f)
  _, rows = seed_breaks.read_rows(path)
  by_seed = seed_breaks.series(rows, "eval/lgr")
  assert [float(r["env_steps"]) for r in by_seed[0]] == [30e6, 40e6, 50e6]
  sign = seed_breaks.worse_direction("eval/lgr")
  lgr_break = seed_breaks.seed_break(by_seed[0], "eval/lgr", sign)
  assert (lgr_break["before"], lgr_break["after"]) == (0.5, 0.9)


def test_the_command_writes_the_tables_and_the_figure(mi_csv, tmp_path, capsys):
  out, png = tmp_path / "breaks.json", tmp_path / "breaks.png"
  seed_breaks.main([mi_csv, "--metric", "eval/mi", "--window", "10:20", "--last", "2",
                    "--rank", "grad_norm", "--out", str(out), "--plot", str(png)])
  printed = capsys.readouterr().out
  assert "| 0 | 20.0 to 30.0 | 1.000 | 0.400 | 0.500 | no |" in printed
  assert "| grad_norm | 100% of 2 | 17% of 6 | 0.028 |" in printed
  written = json.loads(out.read_text())
  assert written["worse"] == "down" and written["breaks"]["1"]["came_back"] is True
  assert written["windows"]["seeds_worse"] == 2  # means 0.95 and 1.05 fall to 0.475 and 1.025
  assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_against_another_run_pairs_the_seeds_both_have_over_the_window(mi_csv, tmp_path, capsys):
  # The other run holds its MI flat at 0.8 (seed 0) and 1.3 (seeds 1, 2) and has a grad_norm
  # column with no value in it; only seeds 0 and 1 are in both, and only the statistics both
  # logged are compared.
  other_mi = {0: [0.8] * 5, 1: [1.3] * 5, 2: [1.3] * 5}
  other = _write(tmp_path / "other_metrics.csv",
                 {"eval/mi": other_mi, "grad_norm": {s: [""] * 5 for s in (0, 1, 2)}},
                 seeds=(0, 1, 2))
  _, rows = seed_breaks.read_rows(mi_csv)
  _, other_rows = seed_breaks.read_rows(other)
  compared = seed_breaks.against(seed_breaks.series(rows, "eval/mi"),
                                 seed_breaks.series(other_rows, "eval/mi"), "eval/mi", -1,
                                 (20e6, 40e6))
  assert compared["seeds"] == [0, 1] and set(compared["rows"]) == {
      "eval/mi", "eval/mi, largest worsening"}
  means = compared["rows"]["eval/mi"]
  # 20-40 M: seed 0 (1.0, 0.4, 0.45), seed 1 (1.1, 1.2, 0.9); differences -11/60 and -14/60
  assert means["this"] == pytest.approx([37 / 60, 64 / 60])
  assert means["other"] == pytest.approx([0.8, 1.3])
  assert means["paired_t"] == pytest.approx(-25 / 3) and means["seeds_lower"] == 2
  worst = compared["rows"]["eval/mi, largest worsening"]
  assert worst["this"] == pytest.approx([0.6, 0.3]) and worst["other"] == [0.0, 0.0]
  out, png = tmp_path / "against.json", tmp_path / "against.png"
  seed_breaks.main([mi_csv, "--metric", "eval/mi", "--window", "20:40", "--against", other,
                    "--out", str(out), "--plot", str(png)])
  printed = capsys.readouterr().out
  assert "| eval/mi | 0.842 ± 0.225 | 1.050 ± 0.250 | -8.33, 0.076 |" in printed
  assert json.loads(out.read_text())["against"]["run"].endswith("other")
  assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_non_finite_value_is_no_evaluation(tmp_path):
  mi = {0: [0.9, float("nan"), 0.8, 0.85, 0.9], 1: [1.0, 1.1, 1.2, float("inf"), 1.15]}
  _, rows = seed_breaks.read_rows(_write(tmp_path / "metrics.csv", {"eval/mi": mi}))
  by_seed = seed_breaks.series(rows, "eval/mi")
  assert [float(r["env_steps"]) for r in by_seed[0]] == [10e6, 30e6, 40e6, 50e6]
  one = seed_breaks.seed_break(by_seed[1], "eval/mi", -1)  # 1.2 at 30 M, then 1.15 at 50 M
  assert (one["env_steps_before"], one["env_steps"], one["after"]) == (30e6, 50e6, 1.15)


@pytest.mark.parametrize("argv, message", [
    (["--metric", "eval/lgr"], "'eval/lgr' is not in the metrics.csv; it has eval/mi"),
    (["--metric", "eval/mi", "--window", "60:70"], "no evaluation holds 'eval/mi' between 60"),
    (["--metric", "eval/mi", "--window", "10:20", "--last", "9"], "--last 9: a seed has 5"),
    (["--metric", "eval/mi", "--rank", "grad_norm"], "--rank needs --window"),
    (["--metric", "eval/mi", "--window", "10:20", "--rank", "loss/kl"],
     "--rank 'loss/kl' is not in the metrics.csv"),
    (["--metric", "eval/mi", "--window", "ten:20"], "give A:B in millions of env steps"),
    (["--metric", "eval/mi", "--window", "30:20"], "A must not exceed B"),
    (["--metric", "eval/mi", "--against", "x_metrics.csv"], "--against needs --window"),
])
def test_bad_input_is_named(mi_csv, argv, message, capsys):
  with pytest.raises(SystemExit) as raised:
    seed_breaks.main([mi_csv, *argv])
  assert raised.value.code == 2 and message in capsys.readouterr().err


def test_a_file_that_is_not_a_metrics_csv_and_a_seed_with_one_evaluation_are_named(tmp_path):
  with pytest.raises(ValueError, match="give a run's metrics.csv"):
    seed_breaks.read_rows(str(tmp_path / "eval.json"))
  path = _write(tmp_path / "metrics.csv", {"eval/mi": {0: [1.0]}}, seeds=(0,), steps=STEPS[:1])
  _, rows = seed_breaks.read_rows(path)
  with pytest.raises(ValueError, match="seed 0 has 1 evaluation"):
    seed_breaks.series(rows, "eval/mi")
  _, two = seed_breaks.read_rows(_write(tmp_path / "two_metrics.csv", {"eval/mi": MI}))
  lone = seed_breaks.series(two, "eval/mi")
  with pytest.raises(ValueError, match=r"share seeds \[0\]; a paired test needs two"):
    seed_breaks.against(lone, {0: lone[0]}, "eval/mi", -1, (10e6, 50e6))
  with pytest.raises(ValueError, match="has 1 evaluation.s. of 'eval/mi' between 50 and 60"):
    seed_breaks.window_worst(lone[0], "eval/mi", -1, (50e6, 60e6))
