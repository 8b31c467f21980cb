"""`refimpl bench-peers`: every generated section of docs/peers.md in one run, on the datasets the
dataset registry names (refimpl.io.datasets), every peer whose package imports, the others named."""

from __future__ import annotations

import json

import numpy as np
import pytest

from refimpl.cli import benchmarks as cli_benchmarks, main
from refimpl.experiments import peers
from refimpl.experiments.peers import PEERS_BEGIN, PEERS_END
from refimpl.tracking.options import TrackerOptions
from refimpl.experiments.peers_report import TUNED_BEGIN, TUNED_END, procedure_clauses, tuned_on_report
from refimpl.experiments.shift_table import SHIFTS_BEGIN, SHIFTS_END
from refimpl.io import DetectionFrame, DetectionSequence, GroundTruth
from refimpl.io.datasets import (CATALOGUE, HELD_OUT_DATASETS, PEER_TABLE_DATASETS, ROLES, SHIFT_TABLE_DATASETS,
                                 TITLES, TUNING_DATASETS)
from refimpl.io.shifts import parse_shifts
from refimpl.tracking.presets import Preset, load_presets


def _toy(n: int = 8):
    """n frames, two boxes walking apart with falling scores, and their ground truth: a dataset that
    every tracker runs in milliseconds."""
    boxes = {t: np.array([[10.0 + 4 * t, 20.0, 40.0, 80.0], [300.0 - 4 * t, 50.0, 40.0, 80.0]]) for t in range(1, n + 1)}
    frames = tuple(DetectionFrame(t, boxes[t], np.array([0.9 - t / 100, 0.8 - t / 100]),
                                  np.array([90 - t, 80 - t], dtype=np.int64), ("pedestrian",) * 2)
                   for t in range(1, n + 1))
    seq = DetectionSequence("toy", frames, 1, (640, 480), 30.0)
    gt = GroundTruth("toy", np.repeat(np.arange(1, n + 1), 2), np.tile([1, 2], n),
                     np.vstack([boxes[t] for t in range(1, n + 1)]), np.ones(2 * n, dtype=bool),
                     np.zeros(2 * n, dtype=bool), np.zeros((0, 5)), 1, n)
    return [("toy", seq, gt)]


def _between(text: str, begin: str, end: str) -> str:
    assert text.count(begin) == 1 and text.count(end) == 1, (begin, end)
    return text.split(begin, 1)[1].split(end, 1)[0]


@pytest.fixture
def no_boxmot(monkeypatch):
    """Whatever this machine has: the boxmot package does not import, every other one does."""
    real = peers.load

    def load(module: str):
        if module == "boxmot":
            raise ImportError("No module named 'boxmot'")
        return real(module)
    monkeypatch.setattr(peers, "load", load)


def test_bench_peers_writes_the_three_sections_on_the_registry_s_datasets(tmp_path, monkeypatch, capsys, no_boxmot):
    pytest.importorskip("trackers")
    read = []

    def load_dataset(name, data_root, seed=0):
        read.append(name)
        return _toy()
    monkeypatch.setattr(cli_benchmarks, "load_dataset", load_dataset)
    monkeypatch.setattr(cli_benchmarks, "dataset_kind", lambda name, data_root: ("mot", "pedestrian"))
    doc = tmp_path / "peers.md"
    old = [f"{b}\nold {b}\n{e}" for b, e in ((TUNED_BEGIN, TUNED_END), (PEERS_BEGIN, PEERS_END),
                                             (SHIFTS_BEGIN, SHIFTS_END))]
    doc.write_text(f"# Peers\n\nprose one\n\n{old[0]}\n\nprose two\n\n{old[1]}\n\nprose three\n\n{old[2]}\n\nprose four\n",
                   encoding="utf-8")
    out_json = tmp_path / "peers.json"
    argv = ["bench-peers", "--out", str(doc), "--json", str(out_json), "--quiet", "--data", "/nonexistent"]
    monkeypatch.setattr("sys.argv", ["refimpl", *argv])  # the command each section names
    assert main(argv) == 0

    # what the command ran is the registry's two lists, in order: the peer tables, then the shifts
    assert read == [*PEER_TABLE_DATASETS, *SHIFT_TABLE_DATASETS]
    boxmot = [name for name, p in peers.PEERS.items() if p.package == "boxmot"]
    installed = [name for name in peers.PEERS if name not in boxmot]
    note = f"not run: {', '.join(boxmot)} (package not installed: boxmot)"
    err = capsys.readouterr().err
    assert err.splitlines() == [f"refimpl bench-peers: {note}"]

    text = doc.read_text(encoding="utf-8")
    assert "old " not in text  # every section replaced, the prose around them kept, in place
    assert [line for line in text.splitlines() if line.startswith("prose")] == ["prose one", "prose two", "prose three",
                                                                                "prose four"]
    assert text.index(TUNED_BEGIN) < text.index("prose two") < text.index(PEERS_BEGIN)
    peer_part = _between(text, PEERS_BEGIN, PEERS_END)
    shift_part = _between(text, SHIFTS_BEGIN, SHIFTS_END)
    tuned_part = _between(text, TUNED_BEGIN, TUNED_END)
    for part in (peer_part, shift_part):
        head = part.split("\n###")[0].split("\n## ")[0]
        assert f"Peers {note}." in head and f"`refimpl {' '.join(argv)}`" in head
    # a peer table per dataset of the registry, in its order, with the installed peers' rows
    titles = [line[4:] for line in peer_part.splitlines() if line.startswith("### ")]
    assert titles == [TITLES[n] for n in PEER_TABLE_DATASETS]
    assert peer_part.count("Per sequence (HOTA / IDF1 / IDs)") == len(PEER_TABLE_DATASETS)
    for name in installed:
        assert peer_part.count(f"\n| {name} (trackers ") == len(PEER_TABLE_DATASETS)  # a row per table
    assert not any(name in peer_part.split(note)[1] for name in boxmot)
    # a shift table per tuning set of the registry, a row per shift, a column per tracker
    titles = [line[3:].removesuffix(": shifts (HOTA / IDF1)") for line in shift_part.splitlines() if line.startswith("## ")]
    assert titles == [TITLES[n] for n in SHIFT_TABLE_DATASETS]
    for shift in parse_shifts("all"):
        assert shift_part.count(f"\n| {shift} | ") == len(SHIFT_TABLE_DATASETS)
    assert shift_part.count("| shift | refimpl baseline (SORT) | refimpl abduction (cpsat) | sort (") == len(SHIFT_TABLE_DATASETS)
    # what was tuned on what: a row per preset of model/presets.json, a row per dataset with its role
    for preset in load_presets().values():
        assert f"\n| {preset.name} | " in tuned_part
    for d in CATALOGUE.values():
        assert f"| `{d.name}` | **{d.role}**: {ROLES[d.role]}" in tuned_part
    report = json.loads(out_json.read_text(encoding="utf-8"))
    assert report["peers"] == installed and sorted(report["not_run"]) == sorted(boxmot)
    assert list(report["benchmarks"]) == list(PEER_TABLE_DATASETS) and list(report["shifts"]) == list(SHIFT_TABLE_DATASETS)


def test_a_peer_asked_for_by_name_whose_package_is_missing_is_one_line(capsys, no_boxmot):
    assert main(["bench-peers", "--peers", "sort,boxmot-ocsort", "--out", "-", "--data", "/nonexistent"]) == 2
    err = capsys.readouterr().err
    assert "the boxmot peers need the 'boxmot' package" in err and err.count("\n") == 1


def test_the_registry_holds_the_tuning_rule_and_the_presets_were_tuned_on_tuning_sets():
    # issue 39's tuning rule, as docs/peers.md "What was tuned on what" says it
    assert HELD_OUT_DATASETS == ("kitti-cyc", "mot15-acf")
    assert {CATALOGUE[n].role for n in ("kitti-car-val", "kitti-ped-val")} == {"reported"}
    assert {"kitti-car-train", "kitti-ped-train", "mot15", "mot17-sim", "mot20-01-sim"} <= set(TUNING_DATASETS)
    assert set(SHIFT_TABLE_DATASETS) == {"kitti-car-train", "kitti-ped-train", "mot15"}
    assert set(SHIFT_TABLE_DATASETS) <= set(TUNING_DATASETS)
    # the peer tables run the reported sets first and the held-out ones last
    assert PEER_TABLE_DATASETS[:2] == ("kitti-car-val", "kitti-ped-val") and PEER_TABLE_DATASETS[-2:] == HELD_OUT_DATASETS
    for preset in load_presets().values():
        assert set(preset.tuned_on.split("+")) <= set(TUNING_DATASETS), preset.name


def test_the_procedure_is_split_at_top_level_semicolons_and_a_non_tuning_set_is_flagged():
    assert procedure_clauses("a (b; c); d;e") == ("a (b; c)", "d", "e")
    shared = "score rule evidence; thresholds 50/30/30 (by the worst case; shifts)"
    presets = {"kitti/car": Preset("kitti", "car", {"lost_after_missing": 20, "iou_thresh": 30000}, "kitti-car-val",
                                   f"{shared}; grid of 4 points", TrackerOptions(backfill_gap=5), fps=10.0),
               "mot/pedestrian": Preset("mot", "pedestrian", {}, "mot15+mot17-sim", shared)}
    text = tuned_on_report(presets, "refimpl bench-peers")
    assert "| kitti/car | `kitti-car-val` (**reported**, not a tuning set) | 10 | grid of 4 points |" in text
    assert "| mot/pedestrian | `mot15`, `mot17-sim` | - | the shared steps below |" in text
    assert f"Every preset: {shared}." in text
    # what each holds: its constants sorted by name, the options that differ from TrackerOptions()'s
    assert "| kitti/car | iou_thresh 30000, lost_after_missing 20 | backfill_gap 5 |" in text
    assert "| mot/pedestrian | - | - |" in text
