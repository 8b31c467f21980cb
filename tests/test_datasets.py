"""The dataset catalogue (refimpl.io.datasets) is the one list of dataset names: each row holds its
public benchmark files (read by refimpl.io) or the ground truth refimpl.io.simulate draws from, and
neither refimpl.io nor refimpl.io.simulate spells a dataset name."""

from __future__ import annotations

import pytest

from pathlib import Path

from refimpl import io

from refimpl.io import simulate
from refimpl.cli import main
from refimpl.io.datasets import (BENCHMARKS, CATALOGUE, DATASETS, HELD_OUT, HELD_OUT_DATASETS, SIMULATED,
                              TABLE6_DATASETS, dataset, load_dataset, tuning_split)

REPO = Path(__file__).resolve().parent.parent


def test_the_catalogue_is_the_public_benchmarks_plus_the_simulated_ones():
    assert BENCHMARKS + SIMULATED == DATASETS  # public rows first, in catalogue order
    assert all(isinstance(CATALOGUE[n].files, io.Benchmark) for n in BENCHMARKS)
    assert all(isinstance(CATALOGUE[n].files, simulate.SimulatedBenchmark) for n in SIMULATED)
    assert CATALOGUE["mot17-sim"].files is simulate.MOT17 and CATALOGUE["mot20-01-sim"].files is simulate.MOT20_01
    assert set(TABLE6_DATASETS) <= set(DATASETS)
    # a simulated dataset says so in its title, wherever a table prints it
    assert all(("SIMULATED" in CATALOGUE[n].title) == CATALOGUE[n].simulated for n in DATASETS)
    # and so does a held-out one (issue 25: KITTI Cyclist and MOT15 with ACF are never tuned on)
    assert HELD_OUT == "held out: never used for tuning"
    assert all((HELD_OUT in CATALOGUE[n].title) == CATALOGUE[n].held_out for n in DATASETS)
    assert HELD_OUT_DATASETS == ("kitti-cyc", "mot15-acf")
    assert not set(HELD_OUT_DATASETS) & set(TABLE6_DATASETS)


@pytest.mark.parametrize("name, command", [
    ("kitti-cyc", "calibrate --benchmark kitti-car-train kitti-cyc"), ("mot15-acf", "calibrate --benchmark mot15-acf"),
    ("kitti-cyc", "sweep --benchmark kitti-cyc --grid conf_thresh_new_track=40,60"),
    ("mot15-acf", "sweep --benchmark mot15-acf --grid iou_thresh=20000")])
def test_calibrate_and_sweep_refuse_a_held_out_dataset_in_one_line(name, command, capsys):
    # refused before any data is read (the data root does not exist) or any tracking starts
    assert main([*command.split(), "--data", "/nonexistent"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith(f"{name} is held out: never used for tuning (run it only to report: refimpl benchmark {name})")
    assert "\n" not in err


def test_an_unknown_dataset_names_the_known_ones():
    with pytest.raises(ValueError, match="unknown dataset 'bogus' .*mot15"):
        dataset("bogus")


def test_no_module_but_the_catalogue_spells_a_dataset_name():
    # refimpl.io's catalogue and refimpl.io.simulate hold files and sequences, never a dataset name:
    # a quoted name of the catalogue (or its simulated stem, 'mot17') appears in datasets.py only
    for module in ("io/catalogue.py", "io/simulate.py"):
        text = (REPO / "refimpl" / module).read_text(encoding="utf-8")
        stems = {n.removesuffix("-sim") for n in DATASETS}
        spelled = sorted(n for n in stems if f'"{n}"' in text or f"'{n}'" in text)
        assert not spelled, f"{module} spells {spelled}"


def test_tuning_split_and_simulated_loading_go_by_the_row(tmp_path):
    # the KITTI benchmarks holding val sequences are tuned on their -train split; others on themselves
    assert tuning_split("kitti-car-val") == tuning_split("kitti-car") == "kitti-car-train"
    assert tuning_split("kitti-cyc") is None and tuning_split("mot15-acf") is None and tuning_split("nope") is None
    with pytest.raises(ValueError, match="unknown dataset 'mot16-sim'"):
        load_dataset("mot16-sim", str(tmp_path))
    # a simulated dataset reads its ground truth from the folders of its row: none under tmp_path
    with pytest.raises(io.InputFormatError, match="ground truth of MOT17-02"):
        load_dataset("mot17-sim", str(tmp_path))
