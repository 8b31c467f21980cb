"""The long-occlusion benchmark: does the occluded object come back as itself, and are the events on time?

For every scenario of refimpl.experiments.occlusion and every tracker variant:

* **IDs**: ID switches over all objects of the scenario (refimpl.evaluation.evaluate, IoU >= 0.5).
* **target ids**: the distinct result ids matched to the occluded object's ground truth (per frame,
  the result box with the highest IoU >= 0.5 with it); it *keeps one identity* when that is
  exactly one id and the object is matched both before hide_frame and from reappear_frame on.
* **hide / unhide** (abduction only): the target's track is the result id matched to it in its last
  matched frame before hide_frame; hide is the offset (event time - hide_frame) of the
  ``hides_behind(track, _)`` event nearest to hide_frame, unhide that of the nearest
  ``unhides_from_behind(track, _)`` to reappear_frame; "-" when the track has no such event.
  An event counts as on time within TOLERANCE = 5 frames.
* **ended**: how the target's track left the hidden state: the first ``lost(track)`` after hiding
  as "lost +k" (k frames after hide_frame), or the unhide.
* **pass**: one identity and both events on time (for the baseline: one identity).

Variants: ``baseline`` (SORT, refimpl.tracking.baseline) and an abduction backend from
refimpl.solvers.BACKENDS, optionally with ``+hold`` (motion while hidden) and/or ``+oru``
(observation-centric re-update on resume), e.g. ``cpsat+hold+oru``, and ``+persist``
(lost_after_hidden = PERSIST_FRAMES: NOT the model, a stand-in for issue 12's reasoned
persistence, to see what the motion options do once a hidden track is not cut at 30 frames).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.geometry import iou_matrix
from ..evaluation.evaluate import evaluate_sequence
from ..knowledge.event_table import EVENT_TABLE
from ..solvers import BACKENDS, BASELINE, DEFAULT_BACKEND
from ..tracking.options import TrackerOptions
from ..tracking.pipeline import Setup, run_sequence
from .occlusion import Scenario, build_suite

TOLERANCE = 5
MOTION_OPTIONS = {"hold": "hold_hidden", "oru": "reupdate_on_resume"}
PERSIST_FRAMES = 1000
"""'+persist': lost_after_hidden raised to this (longer than any scenario): a stand-in for reasoned
persistence (issue 12, item 1), so that the motion options can be measured where hiding is not cut at 30."""

_HIDES = frozenset(e.name for e in EVENT_TABLE.values() if e.explains == "halt" and e.occluder is not None)
_UNHIDES = frozenset(e.name for e in EVENT_TABLE.values() if e.unhides)
_AFTER = frozenset(e.name for e in EVENT_TABLE.values() if e.explains in ("resume", "end"))
"""The events of the target track that can close its occlusion: a resume or an end."""


@dataclass(frozen=True)
class ScenarioResult:
    scenario: str
    kind: str
    length: int
    variant: str
    idsw: int
    mota: float
    idf1: float
    target_ids: tuple[int, ...]
    one_identity: bool
    hide_offset: int | None
    unhide_offset: int | None
    ended: str

    @property
    def on_time(self) -> bool:
        return (self.hide_offset is not None and abs(self.hide_offset) <= TOLERANCE
                and self.unhide_offset is not None and abs(self.unhide_offset) <= TOLERANCE)

    @property
    def passed(self) -> bool:
        return self.one_identity and (self.variant == BASELINE or self.on_time)


def parse_variant(variant: str) -> tuple[str, dict]:
    """'cpsat+hold+oru' -> ('cpsat', {'hold_hidden': True, 'reupdate_on_resume': True}); ValueError if unknown."""
    head, *opts = variant.split("+")
    if head == BASELINE and not opts:
        return head, {}
    if head not in BACKENDS:
        raise ValueError(f"unknown tracker {head!r} ({BASELINE} or one of {', '.join(BACKENDS)})")
    bad = [o for o in opts if o not in MOTION_OPTIONS and o != "persist"]
    if bad:
        raise ValueError(f"unknown option {bad[0]!r} (options: {', '.join(MOTION_OPTIONS)}, persist)")
    out: dict = {MOTION_OPTIONS[o]: True for o in opts if o in MOTION_OPTIONS}
    if "persist" in opts:
        out["constants"] = {"lost_after_hidden": PERSIST_FRAMES}
    return head, out


def target_matches(scenario: Scenario, rows: np.ndarray) -> list[tuple[int, int]]:
    """(frame, result id) for every frame in which a result box overlaps the target's gt box with IoU >= 0.5."""
    gt, t = scenario.ground_truth, scenario.truth
    sel = gt.ids == t.target_id
    out = []
    rows = np.asarray(rows, dtype=float).reshape(-1, 6)
    for f, box in zip(gt.frames[sel], gt.boxes[sel]):
        cand = rows[rows[:, 0] == f]
        if len(cand):
            iou = iou_matrix(box.reshape(1, 4), cand[:, 2:6])[0]
            k = int(np.argmax(iou))
            if iou[k] >= 0.5:
                out.append((int(f), int(cand[k, 1])))
    return out


def _nearest(times: list[int], truth: int) -> int | None:
    return min((t - truth for t in times), key=lambda d: (abs(d), d)) if times else None


def score(scenario: Scenario, variant: str, rows: np.ndarray, events=()) -> ScenarioResult:
    """The benchmark's numbers for one tracker run on one scenario (see the module docstring)."""
    t = scenario.truth
    metrics = evaluate_sequence(scenario.ground_truth, rows)
    matches = target_matches(scenario, rows)
    ids = tuple(sorted({i for _, i in matches}))
    before = [i for f, i in matches if f < t.hide_frame]
    one = len(ids) == 1 and bool(before) and any(f >= t.reappear_frame for f, _ in matches)
    hide = unhide = None
    ended = "-"
    if variant != BASELINE and before:
        trk = f"trk_{before[-1]}"
        mine = [e for e in events if e.event.args and e.event.args[0].name == trk]
        hide = _nearest([e.time for e in mine if e.event.name in _HIDES], t.hide_frame)
        unhide = _nearest([e.time for e in mine if e.event.name in _UNHIDES], t.reappear_frame)
        after = [e for e in mine if e.time >= t.hide_frame - TOLERANCE and e.event.name in _AFTER]
        if after:
            e = min(after, key=lambda e: e.time)
            ended = f"{e.event.name} {e.time - t.hide_frame:+d}"
    return ScenarioResult(scenario.name, scenario.kind, t.length, variant, int(metrics["idsw"]),
                          float(metrics["mota"]), float(metrics["idf1"]), ids, one, hide, unhide, ended)


def run_variant(scenario: Scenario, variant: str) -> ScenarioResult:
    head, options = parse_variant(variant)
    setup = Setup(head) if head == BASELINE else Setup(head, options=TrackerOptions.from_mapping(options))
    result = run_sequence(scenario.detections, setup)
    return score(scenario, variant, result.rows, result.events)


def run_suite(variants=(BASELINE, DEFAULT_BACKEND), seed: int = 0, step=None) -> list[ScenarioResult]:
    for v in variants:
        parse_variant(v)  # fail before any work
    out = []
    for scenario in build_suite(seed):
        for v in variants:
            out.append(run_variant(scenario, v))
        if step:
            step(scenario.name)
    return out


def _off(v: int | None) -> str:
    return "-" if v is None else f"{v:+d}"


def format_results(results: list[ScenarioResult]) -> str:
    """One markdown table per variant, with a summary line each."""
    lines = []
    variants = list(dict.fromkeys(r.variant for r in results))
    for v in variants:
        rs = [r for r in results if r.variant == v]
        lines += [f"### {v}", "",
                  "| scenario | L | passing | IDs | MOTA | IDF1 | target ids | one identity | hide | unhide | ended | pass |",
                  "|---|---:|---|---:|---:|---:|---|---|---:|---:|---|---|"]
        for r in rs:
            lines.append(f"| {r.scenario} | {r.length} | {r.kind} | {r.idsw} | {100 * r.mota:.1f} | {100 * r.idf1:.1f} | "
                         f"{','.join(map(str, r.target_ids)) or '-'} | {'yes' if r.one_identity else 'no'} | "
                         f"{_off(r.hide_offset)} | {_off(r.unhide_offset)} | {r.ended} | {'PASS' if r.passed else 'fail'} |")
        lines += ["", f"{v}: {sum(r.passed for r in rs)}/{len(rs)} scenarios pass, "
                      f"{sum(r.one_identity for r in rs)}/{len(rs)} keep one identity, "
                      f"{sum(r.idsw for r in rs)} ID switches in all.", ""]
    return "\n".join(lines)
