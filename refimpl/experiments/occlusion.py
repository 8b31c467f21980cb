"""The long-occlusion suite (issue 12, item 6): objects passing 30 to 150 frames behind larger moving occluders.

The paper's promise (Section 4.1.2, "Reasoning about Hidden Entities") is that an object which
goes behind another is kept in mind and comes back as itself.  Public benchmarks hold few clean
long occlusions, so refimpl generates its own, seeded, as MOTChallenge sequences:

* **Scene.**  A 1280x720 image at 25 fps.  The *target* (a pedestrian- or car-sized box) moves
  horizontally at constant velocity; a larger *occluder* (a bus, a truck: wider and taller) moves
  horizontally at its own constant velocity, nearer to the camera (its bottom edge is 30 px lower,
  the ground-plane depth cue of ``relations.overlapping_top``), and the target's box lies inside
  the occluder's vertical extent.  Both directions occur (the target moves left or right) and all
  three kinds of passing: opposite directions, the target overtaking a slower occluder, the
  occluder overtaking the target.  A few *unrelated* pedestrians walk in a band above and a band
  below (they may pass each other there; they never touch the target).
* **Occlusion, exact.**  Relative to the occluder the target moves at dv = |v_target - v_occluder|
  = W / L px per frame (W the occluder's width, L the scenario's occlusion length).  With the
  target inside the occluder's vertical extent and narrower than it, the covered share of the
  target's box is clip((W + w) / 2 - |x_target - x_occluder|, 0, w) / w (centre x), so it is
  covered by more than half exactly while |x_target - x_occluder| < W / 2.  The positions put that
  centre distance at W/2 - dv/2 at the hiding frame: exactly L consecutive frames, hide_frame ..
  hide_frame + L - 1, have the target more than half covered, and the reappearance frame is
  hide_frame + L.  The generator recomputes the cover from the written (rounded) ground-truth boxes
  and checks this; tests re-derive it independently.
* **Missed before hiding** (``missed_before``, one scenario): the detector also misses the target in
  the frames just before hide_frame, when it is still mostly visible, so the tracker halts it as
  missing before the occluder covers it; that exercises the re-explained ignore (docs/model.md 3.16).
* **Detections** come from ``refimpl.io.simulate.simulate_detections`` (the same simulated detector
  as MOT17-sim), fed only the objects covered by at most half (by any one box in front of it:
  bottom edge lower), each fully visible to it -- so an object is never detected while mostly
  covered (and no false positive is placed "near" it then), and is detected with probability
  ``p_max`` (0.98: a few misses) otherwise.  Centre jitter 3 % of the box size, size jitter 3 %, 0.3 false
  positives per frame (half near an object), scores Beta(6, 1.5).  The ground truth's visibility
  column is the real visible share (1 - cover).  Boxes are rounded to 2 decimals and scores to
  4 before anything is built, so the in-memory sequence is exactly what the written files read
  back as (``io.read_mot_detections`` / ``read_mot_ground_truth``); every object is a MOTChallenge
  pedestrian (class 1), since det files carry no class.
* **Truth recorded** per scenario (:class:`OcclusionTruth`): the target's and the occluder's
  ground-truth ids, hide_frame (first frame covered by more than half) and reappear_frame (the
  first frame after that covered by at most half).

Determinism: everything is drawn from ``numpy.random.default_rng([seed, index])`` per scenario
(``index`` its position in :data:`SCENARIOS`), in a fixed order: pre-roll length, target height
scale, unrelated objects, then the detector's own draws (``simulate``'s order).  The same seed
gives byte-identical files.  Approximation (documented): detections are full ("amodal") boxes
whenever detected; a partly covered object is not detected as its visible part only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..io import DetectionFrame, DetectionSequence, GroundTruth, write_text_atomic
from ..io.simulate import DetectorParams, simulate_detections

IMAGE_SIZE = (1280, 720)
FPS = 25
HIDDEN_COVER = 0.5
"""An object covered by more than this share of its box area is not detected (and counts as hidden)."""
DETECTOR = DetectorParams(p_max=0.98, v0=0.0, centre_sigma=0.03, size_sigma=0.03, fp_per_frame=0.3)
"""The simulated detector (refimpl.io.simulate): a few misses (2 %) and false positives (0.3 per frame)."""
OCCLUDER_BOTTOM = 560.0
TARGET_BOTTOM = 530.0  # 30 px higher than the occluder's bottom edge: farther from the camera
UPPER_BAND_BOTTOM = 300.0
LOWER_BAND_BOTTOM = 715.0
TARGET_ID, OCCLUDER_ID = 1, 2
"""Ground-truth ids of the occluded object and its occluder; unrelated objects are 3, 4, ..."""


@dataclass(frozen=True)
class ScenarioSpec:
    """One long occlusion: the target passes L frames behind a W-wide occluder.

    v_target is the target's signed speed (px/frame, > 0 to the right); rel_sign the direction in
    which the target moves relative to the occluder (+1: enters at the occluder's left edge).
    The occluder's velocity follows: v_target - rel_sign * W / L.
    """

    name: str
    length: int
    target_size: tuple[float, float]  # w, h
    occluder_size: tuple[float, float]  # W, H
    v_target: float
    rel_sign: int
    unrelated: int = 4
    missed_before: int = 0
    """The detector misses the target in this many frames just before hide_frame, while it is still
    covered by at most half: it goes missing before its occluder covers it (module docstring)."""

    @property
    def dv(self) -> float:
        return self.occluder_size[0] / self.length

    @property
    def v_occluder(self) -> float:
        return self.v_target - self.rel_sign * self.dv


def _kind(s: ScenarioSpec) -> str:
    if s.v_occluder * s.v_target < 0:
        return "opposite"
    if abs(s.v_occluder) < abs(s.v_target):
        return "target overtakes"
    return "occluder overtakes"


PED, PED_BIG, CAR, CAR_BIG = (36.0, 90.0), (48.0, 120.0), (90.0, 50.0), (110.0, 60.0)
SCENARIOS: tuple[ScenarioSpec, ...] = (
    ScenarioSpec("occl030-ped-right-opposite", 30, PED, (240.0, 160.0), 3.0, +1),
    ScenarioSpec("occl030-car-left-opposite", 30, CAR, (210.0, 130.0), -2.0, -1),
    ScenarioSpec("occl045-ped-right-overtakes", 45, PED_BIG, (270.0, 170.0), 7.0, +1),
    ScenarioSpec("occl060-ped-right-overtaken", 60, PED, (300.0, 160.0), 1.5, -1),
    ScenarioSpec("occl060-car-left-overtakes", 60, CAR_BIG, (240.0, 140.0), -5.0, -1),
    ScenarioSpec("occl090-ped-right-opposite", 90, PED, (360.0, 170.0), 2.0, +1),
    ScenarioSpec("occl090-ped-left-overtaken", 90, PED_BIG, (270.0, 180.0), -1.0, +1),
    ScenarioSpec("occl120-car-right-overtakes", 120, CAR, (360.0, 130.0), 4.0, +1),
    ScenarioSpec("occl120-ped-left-opposite", 120, PED, (300.0, 160.0), -1.5, -1),
    ScenarioSpec("occl150-ped-right-overtaken", 150, PED, (375.0, 160.0), 1.0, -1),
    ScenarioSpec("occl150-ped-left-overtakes", 150, PED_BIG, (300.0, 180.0), -3.0, -1),
    ScenarioSpec("occl150-car-right-overtakes", 150, CAR_BIG, (450.0, 140.0), 4.0, +1),
    # missed just before it hides: 8 px/frame relative speed, 36 px wide, so the cover grows by
    # 8/36 = 0.22 a frame: 0.61 at hide_frame, 0.39 and 0.17 the two frames before, none at
    # hide_frame - 3.  Missed from hide_frame - 3 on, the target is halted as missing_detections
    # (nothing covers it), and a frame later, still missed and now covered from the front, its
    # ignore must be re-explained as hides_behind (events.lp [explain_ignore], docs/model.md 3.16).
    ScenarioSpec("occl030-ped-right-missed", 30, PED, (240.0, 160.0), 3.0, +1, missed_before=3),
)
"""The suite: occlusions of 30, 45, 60, 90, 120 and 150 frames, both directions, three kinds of passing,
and one target the detector misses just before it hides (the re-explained ignore)."""


@dataclass(frozen=True)
class OcclusionTruth:
    """What a scenario claims: the target hides at hide_frame and is back at reappear_frame."""

    target_id: int
    occluder_id: int
    hide_frame: int
    reappear_frame: int

    @property
    def length(self) -> int:
        return self.reappear_frame - self.hide_frame


@dataclass(frozen=True)
class Scenario:
    name: str
    kind: str
    detections: DetectionSequence
    ground_truth: GroundTruth
    truth: OcclusionTruth


def cover_fraction(back: np.ndarray, front: np.ndarray) -> np.ndarray:
    """Share of each back box's area (xywh rows) inside the matching front box's (row-wise)."""
    b, f = np.asarray(back, float).reshape(-1, 4), np.asarray(front, float).reshape(-1, 4)
    iw = np.minimum(b[:, 0] + b[:, 2], f[:, 0] + f[:, 2]) - np.maximum(b[:, 0], f[:, 0])
    ih = np.minimum(b[:, 1] + b[:, 3], f[:, 1] + f[:, 3]) - np.maximum(b[:, 1], f[:, 1])
    return np.clip(iw, 0, None) * np.clip(ih, 0, None) / (b[:, 2] * b[:, 3])


def _mover(x_centre_at: float, frame_at: int, v: float, size: tuple[float, float], bottom: float,
           frames: np.ndarray) -> np.ndarray:
    """xywh boxes (rounded to 2 decimals) of a box moving at v px/frame, centred at x_centre_at at frame_at."""
    w, h = size
    cx = x_centre_at + v * (frames - frame_at)
    return np.round(np.column_stack([cx - w / 2, np.full(len(frames), bottom - h),
                                     np.full(len(frames), w), np.full(len(frames), h)]), 2)


def build_scenario(spec: ScenarioSpec, seed: int = 0, index: int | None = None) -> Scenario:
    """The sequence of one scenario (see the module docstring); index defaults to its place in SCENARIOS."""
    if index is None:
        index = next((i for i, s in enumerate(SCENARIOS) if s.name == spec.name), 0)
    rng = np.random.default_rng([int(seed), int(index)])
    width, height = IMAGE_SIZE
    pre = 30 + int(rng.integers(0, 21))  # frames seen before hiding: 30..50
    (w, h), (W, H) = (spec.target_size[0], spec.target_size[1] * (1.0 + 0.1 * rng.random())), spec.occluder_size
    if not (w < W and TARGET_BOTTOM - h >= OCCLUDER_BOTTOM - H and spec.length >= 1):
        raise ValueError(f"{spec.name}: the target must be narrower than the occluder and inside its height")
    post = 40
    hide = pre + 1
    reappear = hide + spec.length
    n = pre + spec.length + post
    frames = np.arange(1, n + 1)
    # the target is at the image centre halfway through the occlusion; at the hiding frame its
    # centre lies W/2 - dv/2 from the occluder's (on the side it comes from)
    mid = hide + (spec.length - 1) / 2.0
    target = _mover(width / 2.0, mid, spec.v_target, (w, h), TARGET_BOTTOM, frames)
    if target[0, 0] < 0 or target[-1, 0] < 0 or max(target[0, 0], target[-1, 0]) + w > width:
        raise ValueError(f"{spec.name}: the target leaves the image")
    xt_hide = width / 2.0 + spec.v_target * (hide - mid)
    xo_hide = xt_hide + spec.rel_sign * (W / 2.0 - spec.dv / 2.0)
    occluder = _mover(xo_hide, hide, spec.v_occluder, (W, H), OCCLUDER_BOTTOM, frames)
    boxes = [target, occluder]
    for k in range(spec.unrelated):
        band = UPPER_BAND_BOTTOM if k % 2 == 0 else LOWER_BAND_BOTTOM
        scale = 0.8 if band == UPPER_BAND_BOTTOM else 1.5
        size = (36.0 * scale * math.exp(0.1 * rng.standard_normal()), 90.0 * scale * math.exp(0.1 * rng.standard_normal()))
        v = float(rng.choice([-1.0, 1.0]) * rng.uniform(0.5, 4.0))
        boxes.append(_mover(float(rng.uniform(0.0, width)), 1, v, size, band, frames))
    gt_frames, gt_ids, gt_boxes = [], [], []
    for i, b in enumerate(boxes):
        inside = (b[:, 0] + b[:, 2] > 0) & (b[:, 0] < width)  # at least partly in the image
        gt_frames.append(frames[inside])
        gt_ids.append(np.full(int(inside.sum()), i + 1))
        gt_boxes.append(b[inside])
    g_frames, g_ids, g_boxes = np.concatenate(gt_frames), np.concatenate(gt_ids), np.concatenate(gt_boxes)
    order = np.lexsort((g_ids, g_frames))
    g_frames, g_ids, g_boxes = g_frames[order], g_ids[order], g_boxes[order]
    visibility = np.round(1.0 - _max_cover(g_frames, g_boxes), 4)
    truth = _truth(g_frames, g_ids, g_boxes, spec)
    if (truth.hide_frame, truth.reappear_frame) != (hide, reappear):
        raise AssertionError(f"{spec.name}: built hide {hide}..{reappear}, boxes give "
                             f"{truth.hide_frame}..{truth.reappear_frame}")  # the construction is wrong
    ones = np.ones(len(g_frames), dtype=bool)
    gt = GroundTruth(spec.name, g_frames, g_ids, g_boxes, ones, ~ones, np.zeros((0, 5)), 1, n, visibility)
    # the detector's sources: only objects covered by at most half (so no false positive is
    # placed "near" a hidden object either), each detected with probability p_max
    seen = visibility >= 1.0 - HIDDEN_COVER
    seen &= ~((g_ids == TARGET_ID) & (g_frames >= hide - spec.missed_before) & (g_frames < hide))
    detectable = GroundTruth(spec.name, g_frames, g_ids, g_boxes, seen, ~ones, np.zeros((0, 5)), 1, n,
                             np.ones(len(g_frames)))
    sim = simulate_detections(detectable, seed=int(rng.integers(2**31)), params=DETECTOR,
                              image_size=IMAGE_SIZE, fps=float(FPS), name=spec.name)
    return Scenario(spec.name, _kind(spec), _rounded(sim, spec.name), gt, truth)


def _max_cover(frames: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """Per row: the largest share of its box covered by one box of the same frame standing in front of it."""
    out = np.zeros(len(frames))
    for f in np.unique(frames):
        idx = np.flatnonzero(frames == f)
        for a in idx:
            for b in idx:
                if a != b and boxes[b, 1] + boxes[b, 3] > boxes[a, 1] + boxes[a, 3]:
                    out[a] = max(out[a], float(cover_fraction(boxes[a], boxes[b])[0]))
    return out


def _truth(frames: np.ndarray, ids: np.ndarray, boxes: np.ndarray, spec: ScenarioSpec) -> OcclusionTruth:
    t, o = ids == TARGET_ID, ids == OCCLUDER_ID
    common = np.intersect1d(frames[t], frames[o])
    cover = cover_fraction(boxes[t][np.isin(frames[t], common)], boxes[o][np.isin(frames[o], common)])
    hidden = common[cover > HIDDEN_COVER]
    if len(hidden) == 0 or hidden[-1] - hidden[0] + 1 != len(hidden):
        raise AssertionError(f"{spec.name}: the target is not hidden in one contiguous span")
    return OcclusionTruth(TARGET_ID, OCCLUDER_ID, int(hidden[0]), int(hidden[-1]) + 1)


def _rounded(seq: DetectionSequence, name: str) -> DetectionSequence:
    """Boxes to 2 decimals, scores to 4 and confidences from them as io reads them: what the files hold."""
    frames = []
    for fr in seq.frames:
        scores = np.round(np.asarray(fr.scores, float), 4)
        conf = np.floor(100.0 * scores + 0.5).astype(np.int64)
        frames.append(DetectionFrame(fr.frame, np.round(np.asarray(fr.boxes, float).reshape(-1, 4), 2),
                                     scores, conf, fr.types))
    return DetectionSequence(name, tuple(frames), seq.first_frame, seq.image_size, seq.fps)


def build_suite(seed: int = 0) -> list[Scenario]:
    """Every scenario of SCENARIOS with this seed, in order."""
    return [build_scenario(s, seed, i) for i, s in enumerate(SCENARIOS)]


def _f(v: float) -> str:
    return f"{round(float(v), 2) + 0.0:.2f}"


def write_scenario(scenario: Scenario, folder: str | Path) -> Path:
    """Write <folder>/<name>/{seqinfo.ini, det/det.txt, gt/gt.txt, occlusion.ini}; returns the sequence folder."""
    root = Path(folder) / scenario.name
    d, g, t = scenario.detections, scenario.ground_truth, scenario.truth
    write_text_atomic(root / "seqinfo.ini", (
        f"[Sequence]\nname={scenario.name}\nimDir=img1\nframeRate={FPS}\nseqLength={g.num_frames}\n"
        f"imWidth={IMAGE_SIZE[0]}\nimHeight={IMAGE_SIZE[1]}\nimExt=.jpg\n"))
    det_lines = [f"{fr.frame},-1,{_f(b[0])},{_f(b[1])},{_f(b[2])},{_f(b[3])},{s:.4f},-1,-1,-1\n"
                 for fr in d.frames for b, s in zip(np.asarray(fr.boxes).reshape(-1, 4), fr.scores)]
    write_text_atomic(root / "det" / "det.txt", "".join(det_lines))
    gt_lines = [f"{int(f)},{int(i)},{_f(b[0])},{_f(b[1])},{_f(b[2])},{_f(b[3])},1,1,{v:.4f}\n"
                for f, i, b, v in zip(g.frames, g.ids, g.boxes, g.visibility)]
    write_text_atomic(root / "gt" / "gt.txt", "".join(gt_lines))
    write_text_atomic(root / "occlusion.ini", (
        f"[Occlusion]\nkind={scenario.kind}\ntarget_id={t.target_id}\noccluder_id={t.occluder_id}\n"
        f"hide_frame={t.hide_frame}\nreappear_frame={t.reappear_frame}\nlength={t.length}\n"
        f"hidden_cover={HIDDEN_COVER}\n"))
    return root


def write_suite(folder: str | Path, seed: int = 0) -> list[Path]:
    """Write every scenario of the suite under folder (MOTChallenge layout); returns the sequence folders."""
    return [write_scenario(s, folder) for s in build_suite(seed)]
