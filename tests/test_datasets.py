"""The dataset catalogue (refimpl.io.datasets) is the one list of dataset names: it holds exactly
refimpl.io's benchmark files plus the simulated datasets refimpl.io.simulate can make."""

from __future__ import annotations

import pytest

from refimpl import io
from refimpl.cli import main
from refimpl.io.datasets import (CATALOGUE, DATASETS, HELD_OUT, HELD_OUT_DATASETS, SIMULATED, SIMULATED_SUFFIX,
                              TABLE6_DATASETS, dataset)
from refimpl.io.simulate import SIMULATED_BENCHMARKS


def test_the_catalogue_is_io_benchmarks_plus_the_simulated_ones():
    assert set(DATASETS) - set(SIMULATED) == set(io.BENCHMARKS)
    assert {n[: -len(SIMULATED_SUFFIX)] for n in SIMULATED} == set(SIMULATED_BENCHMARKS)
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
