"""The dataset catalogue: every named dataset a command can run, in one registry.

Each entry says what the dataset is (a title for tables), whether its detections are public
files (``refimpl.io``'s benchmark catalogue: MOT15 with SORT's Faster R-CNN detections or the
official ACF ones, KITTI tracking train with PointRCNN detections and its val/train splits) or
SIMULATED from ground truth (``refimpl.io.simulate``: MOT17 train and MOT20-01, whose public
detections do not ship here; always labelled as such), whether it is HELD OUT (never tuned on:
KITTI Cyclist, MOT15 with ACF; labelled as such too), and how to load it as
``[(sequence name, DetectionSequence, GroundTruth)]``.
Each row also holds its role in the tuning rule (issue 39: tuned on, reported, held out; ``ROLES``)
and whether docs/peers.md's peer tables and shift tables run it: ``refimpl bench-peers`` reads both
lists here (``PEER_TABLE_DATASETS``, ``SHIFT_TABLE_DATASETS``) and prints the roles beside the presets.
The CLI's choices, the benchmarks, Table 6, the sweeps, the calibration and the peer comparison
all read it.  This is the one place a dataset name is spelled: a row holds where its files are
(``io.Benchmark``: layout, class, detection file, sequences, split; or ``simulate.SimulatedBenchmark``:
the ground truth to simulate from), and ``refimpl.io`` / ``refimpl.io.simulate`` read them.  Adding a
dataset is one ``Dataset`` row here.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

from .. import io
from . import KITTI, KITTI_TRAIN, MOT, MOT15_ACF, MOT15_SORT6, MOT15_TRAIN, Benchmark
from .simulate import MOT17, MOT20_01, SimulatedBenchmark, simulated_benchmark_sequences


HELD_OUT = "held out: never used for tuning"
"""What the title of a held-out dataset says (Dataset.held_out)."""

REPORTED, TUNING, MIXED, HELD_OUT_ROLE = "reported", "tuning", "tuning and reported", "held out"
ROLES: dict[str, str] = {
    REPORTED: "never tuned on: run to report",
    TUNING: "tuned and designed on, with its shifts (refimpl benchmark --shift)",
    MIXED: "a tuning split's sequences and reported ones together",
    HELD_OUT_ROLE: "never used for tuning or for designing a rule: run only to report, after the defaults were fixed",
}
"""A dataset's role in the tuning rule (issue 39, docs/peers.md "What was tuned on what") -> what it
means; docs/peers.md's peer tables list the datasets in this order of roles."""


@dataclass(frozen=True)
class Dataset:
    name: str
    title: str
    files: Benchmark | SimulatedBenchmark
    """Its public benchmark files (io.Benchmark), or the ground truth its detections are simulated
    from (simulate.SimulatedBenchmark)."""
    role: str
    """Its role in the tuning rule, a key of ROLES: tuned on, reported, both (a KITTI set of all 21
    sequences) or held out."""
    table6: bool = False
    """A row of the paper's Table 6 on our data (refimpl table6)."""
    throughput: bool = False
    """Timed by ``refimpl bench-scale --throughput`` and evaluated by default where a command needs one
    MOTChallenge and one KITTI benchmark (anticipation, real detectors)."""
    detectors: tuple[tuple[str, str | None, str], ...] = ()
    """Real detectors side by side (refimpl detectors): (key, file name beside the dataset's detection
    file or None for that file itself, label)."""
    peer_table: bool = False
    """Run beside the peers in docs/peers.md's peer tables (refimpl bench-peers)."""
    shift_table: bool = False
    """Run under every shift in docs/peers.md's shift tables (refimpl bench-peers): a tuning set,
    since the defaults are chosen by the worst case over its shifts."""
    tune_on: str | None = None
    """The dataset anything tuned for this one is tuned on instead (a KITTI benchmark holding val
    sequences); None where there is none."""

    def __post_init__(self) -> None:
        if self.role not in ROLES:
            raise ValueError(f"dataset {self.name}: role {self.role!r} is none of {', '.join(ROLES)}")
        if self.shift_table and self.role != TUNING:
            raise ValueError(f"dataset {self.name}: the shift tables are of tuning sets, not of a {self.role} one")

    @property
    def held_out(self) -> bool:
        """Never used for tuning or for designing a rule: run only to report (issue 25's rule; refimpl
        calibrate and refimpl sweep refuse it).  Its title says so."""
        return self.role == HELD_OUT_ROLE

    @property
    def simulated(self) -> bool:
        """Detections simulated from ground truth (refimpl.io.simulate), never public ones."""
        return isinstance(self.files, SimulatedBenchmark)


_ROWS = (
    Dataset("mot15", "MOT15 train, 11 sequences (SORT's Faster R-CNN detections)",
            Benchmark(MOT, "pedestrian", "det_sort_frcnn.txt", MOT15_TRAIN), TUNING, table6=True, throughput=True,
            peer_table=True, shift_table=True,
            detectors=(("acf", "det.txt", "ACF (official MOT15 public detections)"),
                       ("frcnn", "det_sort_frcnn.txt", "Faster R-CNN (SORT's detections)"))),
    Dataset("mot15-sort6", "MOT15 train, SORT's six sequences (SORT's Faster R-CNN detections)",
            Benchmark(MOT, "pedestrian", "det_sort_frcnn.txt", MOT15_SORT6), TUNING),
    Dataset("kitti-car", "KITTI tracking train, Car, 21 sequences (PointRCNN detections)",
            Benchmark(KITTI, "car", "Car", KITTI_TRAIN), MIXED, table6=True, throughput=True,
            detectors=(("pointrcnn", None, "PointRCNN (AB3DMOT's detections)"),), tune_on="kitti-car-train",
            peer_table=True),
    Dataset("kitti-ped", "KITTI tracking train, Pedestrian, 21 sequences (PointRCNN detections)",
            Benchmark(KITTI, "pedestrian", "Pedestrian", KITTI_TRAIN), MIXED, table6=True, tune_on="kitti-ped-train"),
    Dataset("kitti-car-val", "KITTI tracking train, Car, the 11 val-split sequences (PointRCNN detections)",
            Benchmark(KITTI, "car", "Car", KITTI_TRAIN, "val"), REPORTED, tune_on="kitti-car-train", peer_table=True),
    Dataset("kitti-ped-val", "KITTI tracking train, Pedestrian, the 11 val-split sequences (PointRCNN detections)",
            Benchmark(KITTI, "pedestrian", "Pedestrian", KITTI_TRAIN, "val"), REPORTED, tune_on="kitti-ped-train",
            peer_table=True),
    Dataset("kitti-car-train",
            "KITTI tracking train, Car, the 10 sequences outside the val split (PointRCNN detections)",
            Benchmark(KITTI, "car", "Car", KITTI_TRAIN, "train"), TUNING, tune_on="kitti-car-train", shift_table=True),
    Dataset("kitti-ped-train",
            "KITTI tracking train, Pedestrian, the 10 sequences outside the val split (PointRCNN detections)",
            Benchmark(KITTI, "pedestrian", "Pedestrian", KITTI_TRAIN, "train"), TUNING, tune_on="kitti-ped-train",
            shift_table=True),
    Dataset("kitti-cyc", f"KITTI tracking train, Cyclist, 21 sequences (PointRCNN detections; {HELD_OUT})",
            Benchmark(KITTI, "cyclist", "Cyclist", KITTI_TRAIN), HELD_OUT_ROLE, peer_table=True),
    Dataset("mot15-acf",
            f"MOT15 train, the 7 sequences with the official ACF detections (det/det.txt; {HELD_OUT})",
            Benchmark(MOT, "pedestrian", "det.txt", MOT15_ACF), HELD_OUT_ROLE, peer_table=True),
    Dataset("mot17-sim", "MOT17 train, 7 sequences (SIMULATED detections, seed 0)", MOT17, TUNING, table6=True,
            peer_table=True),
    Dataset("mot20-01-sim", "MOT20-01 (SIMULATED detections, seed 0)", MOT20_01, TUNING, table6=True,
            peer_table=True),
)

CATALOGUE: dict[str, Dataset] = {d.name: d for d in _ROWS}
"""dataset name -> Dataset."""

DATASETS = tuple(CATALOGUE)
BENCHMARKS = tuple(d.name for d in _ROWS if not d.simulated)
"""The datasets with public benchmark files (io.Benchmark)."""
SIMULATED = tuple(d.name for d in _ROWS if d.simulated)
TITLES = {d.name: d.title for d in _ROWS}
TABLE6_DATASETS = tuple(d.name for d in _ROWS if d.table6)
"""The datasets of the paper's Table 6 on our data (refimpl table6)."""
THROUGHPUT_DATASETS = tuple(d.name for d in _ROWS if d.throughput)
HELD_OUT_DATASETS = tuple(d.name for d in _ROWS if d.held_out)
"""The datasets run only to report, never tuned on (Dataset.held_out)."""
TUNING_DATASETS = tuple(d.name for d in _ROWS if d.role == TUNING)
"""The datasets tuned and designed on (issue 39's tuning rule)."""
PEER_TABLE_DATASETS = tuple(d.name for role in ROLES for d in _ROWS if d.peer_table and d.role == role)
"""The datasets of docs/peers.md's peer tables, by role (reported, tuning, both, held out), then in
catalogue order: what ``refimpl bench-peers`` runs beside the peers."""
SHIFT_TABLE_DATASETS = tuple(d.name for d in _ROWS if d.shift_table)
"""The tuning sets of docs/peers.md's shift tables: what ``refimpl bench-peers`` runs under every shift."""
REAL_DETECTORS: dict[str, tuple[tuple[str, str | None, str], ...]] = {d.name: d.detectors for d in _ROWS if d.detectors}
"""dataset -> its real detectors side by side (Dataset.detectors)."""


def dataset(name: str) -> Dataset:
    """The catalogue entry of a dataset; ValueError naming the known ones otherwise."""
    try:
        return CATALOGUE[name]
    except KeyError:
        raise ValueError(f"unknown dataset {name!r} (choose from {', '.join(DATASETS)})") from None


def benchmark_sequences(name: str, data_root: str | os.PathLike) -> list[io.BenchmarkSequence]:
    """The sequences of a dataset with public files under data_root (layout of /work/shared/data).

    ``mot15`` (11 MOT15 train sequences, SORT Faster R-CNN dets), ``mot15-sort6`` (the six
    sequences of the SORT paper's comparison), ``mot15-acf`` (the 7 MOT15 train sequences with the
    official ACF ``det/det.txt``), ``kitti-car`` / ``kitti-ped`` / ``kitti-cyc`` (KITTI tracking
    train 0000-0020, PointRCNN dets, label_02 ground truth), ``kitti-car-val`` / ``kitti-ped-val``
    (the sequences listed in ``KITTI/tracking/training/evaluate_tracking.seqmap.val``: 11) and
    ``kitti-car-train`` / ``kitti-ped-train`` (the other training sequences: 10), the split that
    anything tuned is tuned on.  Every file must exist (io.benchmark_files).
    """
    key = name.strip().lower()
    entry = CATALOGUE.get(key)
    if entry is None or entry.simulated:
        raise ValueError(f"unknown benchmark {name!r} (known: {', '.join(BENCHMARKS)})")
    return io.benchmark_files(key, entry.files, data_root)


def tuning_split(name: str) -> str | None:
    """The dataset to tune on instead of a KITTI benchmark holding val sequences
    (``kitti-car`` / ``kitti-car-val`` -> ``kitti-car-train``); None for any other dataset."""
    entry = CATALOGUE.get(name.strip().lower())
    return entry.tune_on if entry is not None else None


def load_dataset(name: str, data_root: str, seed: int = 0):
    """[(sequence name, DetectionSequence, GroundTruth)] of a dataset, its files' scores calibrated
    together, as one ``refimpl track`` of them all reads them (``calibrated_together``)."""
    entry = dataset(name)
    if entry.simulated:
        return calibrated_together(simulated_benchmark_sequences(entry.files, data_root, seed=seed, name=name))
    return calibrated_together([(s.name, io.load_detections(s), io.load_ground_truth(s))
                                for s in benchmark_sequences(name, data_root)])


def calibrated_together(loaded):
    """A loaded dataset, every sequence's confidences read by the default score rule from its own
    frames and the other sequences' (refimpl.io.detections.calibrated_together)."""
    seqs = io.calibrated_together([d for _, d, _ in loaded], io.resolve_rule(io.DEFAULT_SCORE_RULE))
    return [(n, d, g) for (n, _, g), d in zip(loaded, seqs)]


def dataset_kind(name: str, data_root: str) -> tuple[str, str]:
    """(format, object class) of a dataset: what selects its preset (refimpl.tracking.presets)."""
    entry = dataset(name)
    if entry.simulated:
        return io.MOT, "pedestrian"
    first = benchmark_sequences(name, data_root)[0]
    return first.format, first.object_class
