"""The files of the public benchmarks: where a benchmark's sequences are under a data root
(:class:`Benchmark`, the files part of a row of refimpl.io.datasets.CATALOGUE, which names every
dataset), the KITTI val / train splits, reading a benchmark sequence, and the bundled demo
sequence."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from .detections import DetectionSequence
from .errors import InputFormatError
from .formats import MOT, get_format
from .formats.kitti import KITTI_TRAIN, KITTI_VAL_SEQMAP, kitti_val_sequences  # noqa: F401  (re-exported)
from .ground_truth import GroundTruth


@dataclass(frozen=True)
class BenchmarkSequence:
    """Where one benchmark sequence's detections and ground truth live, and how to read them."""

    name: str
    dets_path: Path
    gt_path: Path
    format: str
    object_class: str
    seqinfo_path: Path | None = None


MOT15_TRAIN = (
    "ADL-Rundle-6", "ADL-Rundle-8", "ETH-Bahnhof", "ETH-Pedcross2", "ETH-Sunnyday", "KITTI-13",
    "KITTI-17", "PETS09-S2L1", "TUD-Campus", "TUD-Stadtmitte", "Venice-2",
)
MOT15_SORT6 = ("TUD-Campus", "ETH-Sunnyday", "ETH-Pedcross2", "ADL-Rundle-8", "Venice-2", "KITTI-17")
MOT15_ACF = ("ETH-Sunnyday", "KITTI-13", "KITTI-17", "PETS09-S2L1", "TUD-Campus", "TUD-Stadtmitte", "Venice-2")
"""The MOT15 training sequences whose official (ACF) ``det/det.txt`` is on the data root: the files of
ADL-Rundle-6, ADL-Rundle-8, ETH-Bahnhof and ETH-Pedcross2 were not fetched (shared/data/PROVENANCE.md)."""


@dataclass(frozen=True)
class Benchmark:
    """Where a public benchmark's files are under the data root: the files part of a dataset row
    (refimpl.io.datasets.CATALOGUE names every dataset; this module reads the files)."""

    format: str
    """MOT: MOT15/train/<sequence>/{det/<detections>, gt/gt.txt, seqinfo.ini}; KITTI:
    KITTI/tracking/training/{det_02_pointrcnn/<detections>/<sequence>.txt, label_02/<sequence>.txt}."""
    object_class: str
    detections: str
    """MOT: the detection file's name in det/; KITTI: the class folder in det_02_pointrcnn/."""
    sequences: tuple[str, ...]
    split: str = "all"
    """KITTI: all the listed sequences, or those in the val seqmap (val) or not in it (train)."""


def benchmark_files(name: str, b: Benchmark, data_root: str | os.PathLike) -> list[BenchmarkSequence]:
    """The sequences of benchmark ``b`` (called ``name`` in messages) under data_root (layout of
    /work/shared/data: ``Benchmark.format``); every file must exist.  By name:
    refimpl.io.datasets.benchmark_sequences."""
    root = Path(data_root)
    if not root.is_dir():
        raise InputFormatError(f"data root for benchmark {name!r} not found", root)
    layout = get_format(b.format).benchmark_layout
    if layout is None:
        raise ValueError(f"benchmark {name!r}: format {b.format!r} has no benchmark layout on the data root")
    seqs = [BenchmarkSequence(f.name, f.dets_path, f.gt_path, b.format, b.object_class, f.seqinfo_path)
            for f in layout(root, b.detections, b.sequences, b.split)]
    for s in seqs:
        for p in (s.dets_path, s.gt_path, s.seqinfo_path):
            if p is not None and not p.is_file():
                raise InputFormatError(
                    f"missing file of benchmark {name!r} (sequence {s.name}); is {root} the benchmark "
                    f"data root (holding MOT15/ and KITTI/)?", p)
    return seqs


def load_detections(seq: BenchmarkSequence) -> DetectionSequence:
    """Read a benchmark sequence's detections (a KITTI sequence's frame count from its label file)."""
    fmt = get_format(seq.format)
    n = fmt.frames_from_gt(Path(seq.gt_path)) if fmt.frames_from_gt is not None else None
    return fmt.read_detections(seq.dets_path, object_class=seq.object_class, seqinfo=seq.seqinfo_path, num_frames=n)


def load_ground_truth(seq: BenchmarkSequence) -> GroundTruth:
    """Read a benchmark sequence's ground truth."""
    return get_format(seq.format).read_ground_truth(seq.gt_path, object_class=seq.object_class,
                                                     seqinfo=seq.seqinfo_path)


def _demo_in(base: Path) -> BenchmarkSequence | None:
    seq = base / "TUD-Campus"
    paths = (seq / "det" / "det.txt", seq / "gt" / "gt.txt", seq / "seqinfo.ini")
    if all(p.is_file() for p in paths):
        return BenchmarkSequence(name="TUD-Campus", dets_path=paths[0], gt_path=paths[1],
                                 format=MOT, object_class="pedestrian", seqinfo_path=paths[2])
    return None


def bundled_data_dirs() -> tuple[Path, Path]:
    """Where the bundled ``data/`` is: a checkout's, then an installed package's ``refimpl/data``
    (pyproject: package-dir refimpl.data)."""
    here = Path(__file__).resolve()
    return here.parents[2] / "data", here.parents[1] / "data"


def demo_sequence_paths() -> BenchmarkSequence:
    """The bundled TUD-Campus demo (MOT15 gt + SORT Faster R-CNN dets), from a checkout or an install."""
    for base in bundled_data_dirs():
        found = _demo_in(base / "demo")
        if found is not None:
            return found
    raise InputFormatError("bundled demo sequence not found (expected data/demo/TUD-Campus in "
                           "the checkout or the refimpl.data package)", bundled_data_dirs()[0] / "demo")


def shipped_examples() -> dict[str, Path]:
    """The frame problems the package ships (``data/examples/NAME.lp``: the paper's fully listed
    frames), by NAME, from a checkout or an install; ``refimpl solve --example NAME`` reads them."""
    for base in bundled_data_dirs():
        found = sorted((base / "examples").glob("*.lp"))
        if found:
            return {p.stem: p for p in found}
    return {}
    # an installed package holds data/ as refimpl/data/ (pyproject: package-dir refimpl.data)
    found = _demo_in(Path(__file__).resolve().parents[1] / "data" / "demo")
    if found is None:
        raise InputFormatError("bundled demo sequence not found (expected data/demo/TUD-Campus in "
                               "the checkout or the refimpl.data package)", checkout)
    return found
