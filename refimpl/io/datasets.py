"""The dataset catalogue: every named dataset a command can run, in one registry.

Each entry says what the dataset is (a title for tables), whether its detections are public
files (``refimpl.io``'s benchmark catalogue: MOT15 with SORT's Faster R-CNN detections or the
official ACF ones, KITTI tracking train with PointRCNN detections and its val/train splits) or
SIMULATED from ground truth (``refimpl.io.simulate``: MOT17 train and MOT20-01, whose public
detections do not ship here; always labelled as such), whether it is HELD OUT (never tuned on:
KITTI Cyclist, MOT15 with ACF; labelled as such too), and how to load it as
``[(sequence name, DetectionSequence, GroundTruth)]``.
The CLI's choices, the benchmarks, Table 6, the sweeps, the calibration and the peer comparison
all read it; adding a dataset is one ``Dataset`` row here (plus its files in ``refimpl.io``).
"""

from __future__ import annotations

from dataclasses import dataclass

from .. import io


HELD_OUT = "held out: never used for tuning"
"""What the title of a held-out dataset says (Dataset.held_out)."""


@dataclass(frozen=True)
class Dataset:
    name: str
    title: str
    simulated: bool = False
    """Detections simulated from ground truth (refimpl.io.simulate), never public ones."""
    table6: bool = False
    """A row of the paper's Table 6 on our data (refimpl table6)."""
    throughput: bool = False
    """Timed by ``refimpl bench-scale --throughput`` and evaluated by default where a command needs one
    MOTChallenge and one KITTI benchmark (anticipation, real detectors)."""
    detectors: tuple[tuple[str, str | None, str], ...] = ()
    """Real detectors side by side (refimpl detectors): (key, file name beside the dataset's detection
    file or None for that file itself, label)."""
    held_out: bool = False
    """Never used for tuning or for designing a rule: run only to report (issue 25's rule; refimpl
    calibrate and refimpl sweep refuse it).  Its title says so."""


_ROWS = (
    Dataset("mot15", "MOT15 train, 11 sequences (SORT's Faster R-CNN detections)", table6=True, throughput=True,
            detectors=(("acf", "det.txt", "ACF (official MOT15 public detections)"),
                       ("frcnn", "det_sort_frcnn.txt", "Faster R-CNN (SORT's detections)"))),
    Dataset("mot15-sort6", "MOT15 train, SORT's six sequences (SORT's Faster R-CNN detections)"),
    Dataset("kitti-car", "KITTI tracking train, Car, 21 sequences (PointRCNN detections)", table6=True,
            throughput=True, detectors=(("pointrcnn", None, "PointRCNN (AB3DMOT's detections)"),)),
    Dataset("kitti-ped", "KITTI tracking train, Pedestrian, 21 sequences (PointRCNN detections)", table6=True),
    Dataset("kitti-car-val", "KITTI tracking train, Car, the 11 val-split sequences (PointRCNN detections)"),
    Dataset("kitti-ped-val", "KITTI tracking train, Pedestrian, the 11 val-split sequences (PointRCNN detections)"),
    Dataset("kitti-car-train",
            "KITTI tracking train, Car, the 10 sequences outside the val split (PointRCNN detections)"),
    Dataset("kitti-ped-train",
            "KITTI tracking train, Pedestrian, the 10 sequences outside the val split (PointRCNN detections)"),
    Dataset("kitti-cyc", f"KITTI tracking train, Cyclist, 21 sequences (PointRCNN detections; {HELD_OUT})",
            held_out=True),
    Dataset("mot15-acf",
            f"MOT15 train, the 7 sequences with the official ACF detections (det/det.txt; {HELD_OUT})",
            held_out=True),
    Dataset("mot17-sim", "MOT17 train, 7 sequences (SIMULATED detections, seed 0)", simulated=True, table6=True),
    Dataset("mot20-01-sim", "MOT20-01 (SIMULATED detections, seed 0)", simulated=True, table6=True),
)

CATALOGUE: dict[str, Dataset] = {d.name: d for d in _ROWS}
"""dataset name -> Dataset."""

DATASETS = tuple(CATALOGUE)
SIMULATED = tuple(d.name for d in _ROWS if d.simulated)
TITLES = {d.name: d.title for d in _ROWS}
TABLE6_DATASETS = tuple(d.name for d in _ROWS if d.table6)
"""The datasets of the paper's Table 6 on our data (refimpl table6)."""
THROUGHPUT_DATASETS = tuple(d.name for d in _ROWS if d.throughput)
HELD_OUT_DATASETS = tuple(d.name for d in _ROWS if d.held_out)
"""The datasets run only to report, never tuned on (Dataset.held_out)."""
REAL_DETECTORS: dict[str, tuple[tuple[str, str | None, str], ...]] = {d.name: d.detectors for d in _ROWS if d.detectors}
"""dataset -> its real detectors side by side (Dataset.detectors)."""
SIMULATED_SUFFIX = "-sim"


def dataset(name: str) -> Dataset:
    """The catalogue entry of a dataset; ValueError naming the known ones otherwise."""
    try:
        return CATALOGUE[name]
    except KeyError:
        raise ValueError(f"unknown dataset {name!r} (choose from {', '.join(DATASETS)})") from None


def load_dataset(name: str, data_root: str, seed: int = 0):
    """[(sequence name, DetectionSequence, GroundTruth)] of a dataset."""
    if dataset(name).simulated:
        from .simulate import simulated_benchmark_sequences
        return simulated_benchmark_sequences(name[: -len(SIMULATED_SUFFIX)], data_root, seed=seed)
    return [(s.name, io.load_detections(s), io.load_ground_truth(s)) for s in io.benchmark_sequences(name, data_root)]


def dataset_kind(name: str, data_root: str) -> tuple[str, str]:
    """(format, object class) of a dataset: what selects its preset (refimpl.tracking.presets)."""
    if dataset(name).simulated:
        return io.MOT, "pedestrian"
    first = io.benchmark_sequences(name, data_root)[0]
    return first.format, first.object_class
