"""The user's path is the measured path, on real sequences.

For each sequence, ``refimpl track`` on the one file (streamed to its results file) must write the
bytes of ``refimpl track`` on many files with ``--out-dir --pool-scores no`` (tasks, each file read
alone), and ``refimpl track --out-dir`` over a benchmark's files (their scores calibrated together,
docs/model.md 3.19) the bytes of ``refimpl benchmark --results-dir`` (the code every published
table comes from); each with the defaults a user gets (the cpsat backend, the preset of the format
and class, the evidence rule for scores).  The sequences are the eight on which single-input ``track`` once
crashed with a duplicate (frame, id) row (issue 24: backfill and the streaming writer disagreed on
which frames were already written).  ``tests/tools/check_user_path.py`` runs the same check on all 53
shared sequences (MOT15 11, KITTI Car 21, KITTI Pedestrian 21).

``benchmark`` runs on a data root whose KITTI val split is the four KITTI sequences here
(conftest's ``data_root_with_val``): ``kitti-car-val`` and ``kitti-ped-val`` then hold every KITTI
sequence of the test, 0009 too, and no other (the shared split's 22 sequence runs took two thirds
of the test's time and were compared with nothing).
"""

from __future__ import annotations

import pytest

from refimpl.cli import main
from refimpl.io.datasets import benchmark_sequences

CASES = {
    # name -> (track arguments, detection files relative to the data root, sequences, the smallest
    # benchmark holding them: its results are compared too; None: not in it, --out-dir only)
    "kitti-car": (["--format", "kitti", "--class", "Car"],
                  "KITTI/tracking/training/det_02_pointrcnn/Car/{}.txt", ("0001", "0008", "0009"), "kitti-car-val"),
    "kitti-ped": (["--format", "kitti", "--class", "Pedestrian"],
                  "KITTI/tracking/training/det_02_pointrcnn/Pedestrian/{}.txt", ("0013",), "kitti-ped-val"),
    "mot15": (["--format", "mot"], "MOT15/train/{}/det/det_sort_frcnn.txt",
              ("ADL-Rundle-6", "ADL-Rundle-8", "ETH-Pedcross2", "ETH-Sunnyday"), "mot15-sort6"),
}


KITTI_VAL = ("0001", "0008", "0009", "0013")  # the KITTI sequences of CASES


@pytest.fixture(scope="module")
def benchmarked(data_root_with_val, tmp_path_factory):
    """benchmark --results-dir over the smallest benchmarks holding the sequences (one run, as a user
    would; MOT15 ADL-Rundle-6 is not one of SORT's six, so it is checked against --out-dir only here;
    tests/tools/check_user_path.py runs all 53)."""
    out = tmp_path_factory.mktemp("benchmark")
    assert main(["benchmark", *(c[3] for c in CASES.values()), "--data", str(data_root_with_val(*KITTI_VAL)),
                 "--quiet", "--results-dir", str(out)]) == 0
    assert sorted(p.stem for p in (out / "kitti-car-val").glob("*.txt")) == list(KITTI_VAL)
    return out


@pytest.mark.parametrize("name", list(CASES))
def test_single_input_track_writes_the_bytes_of_out_dir_reading_each_file_alone(name, shared_data, tmp_path,
                                                                                capsys):
    args, pattern, seqs, _ = CASES[name]
    files = [str(shared_data / pattern.format(s)) for s in seqs]
    assert main(["track", "--dets", *files, *args, "--out-dir", str(tmp_path / "many"), "--pool-scores", "no",
                 "--quiet"]) == 0
    for seq, path in zip(seqs, files):
        single = tmp_path / f"one-{seq}.txt"
        assert main(["track", "--dets", path, *args, "--out", str(single), "--quiet"]) == 0
        written = single.read_bytes()
        assert written, f"{name}/{seq}: no rows"
        assert written == (tmp_path / "many" / f"{seq}.txt").read_bytes(), f"{name}/{seq}: --out-dir differs"
    capsys.readouterr()


@pytest.mark.parametrize("name", list(CASES))
def test_track_over_a_benchmarks_files_writes_the_bytes_of_benchmark(name, data_root_with_val, benchmarked,
                                                                      tmp_path, capsys):
    # one run over the benchmark's files, their scores calibrated together (docs/model.md 3.19), as
    # benchmark reads them
    args, _, seqs, bench = CASES[name]
    root = data_root_with_val(*KITTI_VAL)
    files = [str(s.dets_path) for s in benchmark_sequences(bench, str(root))]
    assert main(["track", "--dets", *files, *args, "--out-dir", str(tmp_path / "run"), "--quiet"]) == 0
    scored = sorted((benchmarked / bench).glob("*.txt"))
    assert len(scored) == len(files) >= 4
    for path in scored:
        written = (tmp_path / "run" / path.name).read_bytes()
        assert written == path.read_bytes(), f"{name}/{path.stem}: benchmark differs"
    assert any(path.read_bytes() for path in scored)
    capsys.readouterr()
