"""The robust default preset (issue 25): chosen by the best mean rank over every tuning set, and
what a (format, class) without a preset of its own runs with."""

from __future__ import annotations

import json

from refimpl.experiments.calibrate import choose_robust
from refimpl.tracking.pipeline import setup_for
from refimpl.tracking.presets import load_presets, resolve_preset


def test_the_best_mean_rank_wins_not_one_sets_optimum():
    # a is best on set 1 only (ranks 1, 3, 3: mean 2.33); b is second everywhere (2, 1, 2: 1.67);
    # c wins set 3 (3, 2, 1: 2.0): b is the robust choice although it tops only set 2
    choice = choose_robust(["s1", "s2", "s3"], ["a", "b", "c"],
                           [[0.80, 0.30, 0.30], [0.70, 0.50, 0.40], [0.60, 0.40, 0.50]])
    assert choice.ranks() == [[1, 3, 3], [2, 1, 2], [3, 2, 1]]
    assert choice.candidates[choice.chosen] == "b"


def test_a_tie_in_mean_rank_goes_to_the_better_worst_case():
    # x ranks (1, 2), y ranks (2, 1): both 1.5; x's worst HOTA is 0.30, y's 0.45 -> y
    choice = choose_robust(["s1", "s2"], ["x", "y"], [[0.60, 0.30], [0.50, 0.45]])
    assert choice.candidates[choice.chosen] == "y"


def test_a_format_and_class_without_a_preset_runs_the_default(tmp_path):
    path = tmp_path / "presets.json"
    path.write_text(json.dumps({
        "default": {"constants": {"conf_thresh_new_track": 70}, "tracker": {"backfill": True},
                    "tuned_on": "a+b", "procedure": "test"},
        "kitti/car": {"constants": {"conf_thresh_new_track": 90}, "tuned_on": "a", "procedure": "test"}}))
    assert resolve_preset("kitti", "car", path).constants == {"conf_thresh_new_track": 90}
    fallback = resolve_preset("kitti", "cyclist", path)
    assert fallback.name == "default" and fallback.constants == {"conf_thresh_new_track": 70}
    assert load_presets(path)["default"].tracker.backfill is True


def test_the_shipped_presets_name_what_a_cyclist_file_gets():
    presets = load_presets()
    setup = setup_for("kitti", "cyclist")
    assert setup.preset == ("default" if "default" in presets else "none")
