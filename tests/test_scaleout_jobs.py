"""What a local cluster is given and how (issue 27, item 5: a cluster that pays for itself): jobs
pickled as packed arrays and unpacked to equal sequences, no events handed back unless asked,
tasks submitted longest first with their size as Dask's priority, workers forked from the
command's process."""

from __future__ import annotations

import pickle
import sys
from pathlib import Path

import numpy as np
import pytest

from refimpl import io
from refimpl.runs import scaleout
from refimpl.runs.scaleout import Plan, run_tasks
from refimpl.runs.tasks import PackedSequence, TrackJob, pack_sequence, track_job, unpack_sequence
from refimpl.tracking.pipeline import Setup, run_sequence

KITTI_0011 = "/work/shared/data/KITTI/tracking/training/det_02_pointrcnn/Car/0011.txt"


def _frame(number, boxes, scores, conf, types):
    return io.DetectionFrame(number, np.array(boxes, dtype=np.float64).reshape(-1, 4),
                             np.array(scores, dtype=np.float64), np.array(conf, dtype=np.int64), tuple(types))


def _sequence() -> io.DetectionSequence:
    """Three frames: two detections (a car and a van), none, one car."""
    return io.DetectionSequence("S", (
        _frame(5, [[1, 2, 3, 4], [5, 6, 7, 8]], [0.5, 0.25], [50, 25], ["car", "van"]),
        _frame(6, [], [], [], []),
        _frame(7, [[9, 10, 11, 12]], [0.75], [75], ["car"]),
    ), first_frame=5, image_size=(1242, 375), fps=10.0, dropped=((614, "zero area"),))


def _assert_same_sequence(a: io.DetectionSequence, b: io.DetectionSequence) -> None:
    """b (unpacked) equals a (the original) array by array, each array of b its own."""
    assert (a.name, a.first_frame, a.image_size, a.fps, a.dropped) == (b.name, b.first_frame, b.image_size, b.fps,
                                                                     b.dropped)
    assert len(a.frames) == len(b.frames)
    for f, g in zip(a.frames, b.frames):
        assert (f.frame, f.types) == (g.frame, g.types)
        for x, y in ((f.boxes, g.boxes), (f.scores, g.scores), (f.confidences, g.confidences)):
            assert (x.dtype, x.shape) == (y.dtype, y.shape) and x.tobytes() == y.tobytes()
            assert y.flags.c_contiguous and y.flags.writeable and y.base is None  # its own copy, as unpickled


def test_a_sequence_packs_into_stacked_arrays_and_back():
    seq = _sequence()
    packed = pack_sequence(seq)
    assert isinstance(packed, PackedSequence)
    # 2 + 0 + 1 detections stacked in frame order; types as indices into the sorted names
    assert packed.counts.tolist() == [2, 0, 1] and packed.numbers.tolist() == [5, 6, 7]
    assert packed.boxes.shape == (3, 4) and packed.boxes[:, 0].tolist() == [1, 5, 9]
    assert packed.type_names == ("car", "van") and packed.types.tolist() == [0, 1, 0]
    _assert_same_sequence(seq, unpack_sequence(packed))


def test_a_sequence_whose_frames_do_not_stack_pickles_as_it_is():
    seq = _sequence()
    odd = io.DetectionFrame(8, np.zeros((1, 4), dtype=np.float32), np.zeros(1), np.zeros(1, dtype=np.int64), ("car",))
    mixed = io.DetectionSequence("M", (*seq.frames, odd), 5, None, None)  # float32 boxes beside float64
    assert pack_sequence(mixed) is mixed
    assert unpack_sequence(mixed) is mixed
    empty = io.DetectionSequence("E", (), 1, None, None)
    assert pack_sequence(empty) is empty


def test_a_track_job_pickles_packed_and_unpickles_equal():
    job = TrackJob(_sequence(), Setup("cpsat", (("iou_thresh", 30000),)), check=True, events=True,
                   out_format="kitti", object_class="Car")
    data = pickle.dumps(job)
    assert b"PackedSequence" in data and b"DetectionFrame" not in data  # no frame object on the wire
    back = pickle.loads(data)
    assert (back.setup, back.check, back.scene, back.events, back.out_format, back.object_class) == \
        (job.setup, True, False, True, "kitti", "Car")
    _assert_same_sequence(job.seq, back.seq)


@pytest.mark.skipif(not Path(KITTI_0011).exists(), reason="KITTI data not here")
def test_a_kitti_file_packs_and_its_unpickled_job_tracks_to_the_same_rows():
    seq = io.read_kitti_detections(KITTI_0011, "Car")
    assert isinstance(pack_sequence(seq), PackedSequence)  # a real file's frames stack
    job = TrackJob(seq, Setup("cpsat"))
    back = pickle.loads(pickle.dumps(job))
    _assert_same_sequence(seq, back.seq)
    assert track_job(back).rows.tobytes() == track_job(job).rows.tobytes()
    assert track_job(job).text is None  # no out_format: rows only
    # with an out_format the task formats its rows: the text a one-sequence `track` would write
    out = track_job(TrackJob(seq, Setup("cpsat"), out_format="kitti", object_class="Car"))
    lines = out.text.splitlines()
    assert len(lines) == len(out.rows) and lines[0].split()[2] == "Car"  # frame id Car ...


def test_track_job_hands_events_back_only_when_asked():
    seq = io.load_detections(io.demo_sequence_paths())
    setup = Setup("cpsat")
    events = run_sequence(seq, setup).events
    assert len(events) > 0  # TUD-Campus has events (tracks start and end)
    assert track_job(TrackJob(seq, setup)).events == ()
    asked = track_job(TrackJob(seq, setup, events=True))
    assert asked.events == events
    assert asked.rows.tobytes() == track_job(TrackJob(seq, setup)).rows.tobytes()  # the rows either way


class _Future:
    def __init__(self, value):
        self.value, self.status = value, "finished"

    def done(self):
        return True

    def result(self, timeout=None):
        return self.value


class _FakeClient:
    """Records what is submitted (the item and its priority), in order; every future is done.
    A task reaches Dask as ``call_pickled(fn, pickled item, ...)``: the scheduler sees bytes."""

    def __init__(self):
        self.submitted = []

    def submit(self, call, fn, blob, *rest, pure=True, priority=0):
        assert pure is False and call is scaleout.call_pickled and isinstance(blob, bytes)
        self.submitted.append((pickle.loads(blob), priority))
        return _Future(call(fn, blob, *rest))


def _fake_cluster(monkeypatch) -> _FakeClient:
    client = _FakeClient()

    class Fake:
        def __init__(self, plan, tasks):
            pass

        def __enter__(self):
            return client

        def __exit__(self, *exc):
            return None
    monkeypatch.setattr(scaleout, "_client", Fake)
    return client


def _sized(item, tick):
    return item * 10


def test_tasks_counted_in_frames_are_submitted_longest_first_and_returned_in_input_order(monkeypatch):
    client = _fake_cluster(monkeypatch)
    sizes = [3, 8, 1, 8, 5]
    out = run_tasks(_sized, sizes, Plan(workers=2, serial_below=0), quiet=True, steps=lambda n: n)
    assert out == [30, 80, 10, 80, 50]  # input order
    # sizes descending, the two 8s in input order (items 1 and 3), each with its size as priority
    assert client.submitted == [(8, 8), (8, 8), (5, 5), (3, 3), (1, 1)]


def test_tasks_not_counted_in_frames_are_submitted_in_input_order(monkeypatch):
    client = _fake_cluster(monkeypatch)
    assert run_tasks(abs, [-3, 8, -1], Plan(workers=2), quiet=True) == [3, 8, 1]
    assert client.submitted == [(-3, 0), (8, 0), (-1, 0)]


def _call(item):
    return item()


def test_an_item_pickle_cannot_take_travels_by_cloudpickle(monkeypatch):
    # a lambda is not picklable by reference: the item goes as cloudpickle's bytes (Dask's own
    # fallback), which pickle.loads reads on the worker
    client = _fake_cluster(monkeypatch)
    with pytest.raises((pickle.PicklingError, AttributeError, TypeError)):
        pickle.dumps(lambda: 3)
    assert run_tasks(_call, [lambda: 3, lambda: 4], Plan(workers=2), quiet=True) == [3, 4]
    assert [item() for item, _ in client.submitted] == [3, 4]


def _imported(name):
    return name in sys.modules


@pytest.mark.skipif(scaleout.START_METHOD != "fork", reason="workers are forked on Linux only")
def test_local_workers_are_forked_from_this_process():
    # refimpl.experiments.shift_table is imported here and by nothing a task needs: a worker
    # has it only as a copy of this process (a spawned worker starts a fresh interpreter)
    import refimpl.experiments.shift_table  # noqa: F401
    pytest.importorskip("distributed")
    assert run_tasks(_imported, ["refimpl.experiments.shift_table"] * 2, Plan(workers=2), quiet=True) == [True,
                                                                                                          True]


def test_a_benchmark_job_pickles_its_detections_packed():
    from refimpl.experiments.benchmark_tasks import BenchmarkJob, RunRequest
    demo = io.demo_sequence_paths()
    dets, gt = io.load_detections(demo), io.load_ground_truth(demo)
    job = BenchmarkJob(demo.name, dets, gt, RunRequest("demo", (), "cpsat"))
    data = pickle.dumps(job)
    assert b"PackedSequence" in data and b"DetectionFrame" not in data
    back = pickle.loads(data)
    assert (back.name, back.request) == (job.name, job.request)
    _assert_same_sequence(dets, back.dets)
    assert back.gt.ids.tobytes() == gt.ids.tobytes() and back.gt.boxes.tobytes() == gt.boxes.tobytes()
