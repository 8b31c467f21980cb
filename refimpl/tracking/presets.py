"""Presets: the model constants and tracker options calibrated per (input format, object class),
chosen automatically.

``refimpl track --format kitti --class Car`` (and ``refimpl benchmark kitti-car...``) runs the
abduction tracker with the preset of (kitti, car): its constants on top of model/constants.lp and
its tracker options (refimpl.tracking.options.TrackerOptions, e.g. which box is written); ``--const
NAME=VALUE`` and the tracker option flags (``--written-box``, ...; refimpl.tracking.options) override them.  A (format, class) without a preset, or
``--no-preset``, runs with the model's defaults and the tracker's default options.

The presets live in model/presets.json, written by ``refimpl calibrate ... --write-presets``
(refimpl.experiments.calibrate.write_preset; this module reads them and writes no files), each with where it was tuned and how, so the file says what was tuned on
what.  The procedure, search space and tables are in docs/peers.md.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Mapping, Sequence

from ..core.constants import default_constants, model_dir
from .options import TrackerOptions

PRESETS_FILE = "presets.json"
DEFAULT_KEY = "default"
"""The preset a (format, class) without its own runs with: chosen for robustness across every
tuning set at once (refimpl calibrate --robust), not one set's optimum."""


@dataclass(frozen=True)
class Preset:
    """Calibrated constants for one (format, object class) and their provenance."""

    format: str
    object_class: str
    constants: Mapping[str, int]
    tuned_on: str
    """The benchmark (sequences) the constants were chosen on, e.g. kitti-car-train."""
    procedure: str
    tracker: TrackerOptions = TrackerOptions()
    """The tracker options of the preset (the "tracker" entry; defaults where it is absent)."""
    fps: float | None = None
    """The frame rate its durations were tuned at (the "fps" entry): the constants and options in
    frames (refimpl.tracking.camera.DURATIONS, ``fill_hidden``) mean that many frames at this frame
    rate and are converted to a sequence's own (docs/model.md 3.22).  None: frames as written."""
    startable: float | None = None
    """The share of the tuning set's detections whose confidence passes the preset's
    conf_thresh_new_track (may start a track): what its thresholds were fitted on; a file far from
    it gets a warning (:func:`score_warning`)."""

    @property
    def name(self) -> str:
        """Its key in the presets file: ``format/class``, or ``default`` for the robust default."""
        return DEFAULT_KEY if (self.format, self.object_class) == ("*", "*") else preset_key(self.format,
                                                                                              self.object_class)


def preset_key(fmt: str, object_class: str) -> str:
    return f"{fmt.lower()}/{object_class.lower()}"


def presets_path() -> Path:
    return model_dir() / PRESETS_FILE


def _parse(data: Mapping, source: Path) -> dict[str, Preset]:
    known = default_constants()
    out = {}
    for key, entry in data.items():
        fmt, _, cls = ("*", "/", "*") if key == DEFAULT_KEY else key.partition("/")
        consts = {str(k): int(v) for k, v in entry["constants"].items()}
        unknown = sorted(set(consts) - set(known))
        if unknown or not cls:
            raise ValueError(f"{source}: preset {key!r}: unknown constants {unknown} or key not FORMAT/CLASS")
        options = TrackerOptions.from_mapping(entry.get("tracker", {}), f"{source}: preset {key!r}")
        share, fps = entry.get("startable"), entry.get("fps")
        if fps is not None and not (isinstance(fps, (int, float)) and not isinstance(fps, bool) and fps > 0):
            raise ValueError(f"{source}: preset {key!r}: fps must be a number above 0, got {fps!r}")
        out[key] = Preset(fmt, cls, consts, str(entry.get("tuned_on", "")), str(entry.get("procedure", "")),
                          options, None if fps is None else float(fps), None if share is None else float(share))
    return out


@lru_cache(maxsize=4)
def _load(path: str, mtime: float) -> dict[str, Preset]:
    p = Path(path)
    return _parse(json.loads(p.read_text(encoding="utf-8")), p)


def load_presets(path: str | Path | None = None) -> dict[str, Preset]:
    """Every preset in the presets file (none if the file is absent)."""
    p = Path(path) if path is not None else presets_path()
    if not p.is_file():
        return {}
    return _load(str(p), p.stat().st_mtime)


def preset_named(name: str, path: str | Path | None = None) -> Preset:
    """The preset stored under this name (``kitti/car``, ``default``); ValueError naming the known ones."""
    presets = load_presets(path)
    key = name.lower()
    if key not in presets:
        raise ValueError(f"unknown preset {name!r} (known: {', '.join(sorted(presets)) or 'none'})")
    return presets[key]


def resolve_preset(fmt: str, object_class: str, path: str | Path | None = None) -> Preset | None:
    """The preset a (format, class) runs with: its own, else the robust default, else none."""
    presets = load_presets(path)
    return presets.get(preset_key(fmt, object_class), presets.get(DEFAULT_KEY))


def merge_constants(preset: Preset | None, overrides: Mapping[str, int] | None = None) -> dict[str, int]:
    """The preset's constants (none without one), then overrides; ValueError for an unknown name."""
    known = default_constants()
    for name in overrides or {}:
        if name not in known:
            raise ValueError(f"unknown constant {name!r} (known: {', '.join(sorted(known))})")
    merged = dict(preset.constants) if preset else {}
    merged.update({k: int(v) for k, v in (overrides or {}).items()})
    return merged


def merge_options(preset: Preset | None, overrides: Mapping[str, object] | None = None) -> TrackerOptions:
    """The preset's tracker options (the defaults without one), then overrides {name: value}."""
    values: dict[str, object] = dict((preset.tracker if preset else TrackerOptions()).as_dict())
    values.update(overrides or {})
    return TrackerOptions.from_mapping(values)


def preset_entry(preset: Preset) -> dict[str, object]:
    """The preset as its entry of the presets file (what :func:`load_presets` reads back); the
    file itself is written by the calibration (refimpl.experiments.calibrate.write_preset): this module
    writes no files."""
    return {"constants": dict(sorted(preset.constants.items())), "tracker": preset.tracker.as_dict(),
            "tuned_on": preset.tuned_on, "procedure": preset.procedure,
            **({"fps": preset.fps} if preset.fps is not None else {}),
            **({"startable": round(preset.startable, 4)} if preset.startable is not None else {})}


STARTABLE_FACTOR = 4.0
"""A file is far from its preset's tuning set when the share of its detections that may start a
track is more than this many times smaller or larger."""


def startable_share(sequences, constants: Mapping[str, int]) -> float:
    """The share of detections whose confidence exceeds conf_thresh_new_track (the preset's, else
    model/constants.lp's) over DetectionSequences; NaN without detections."""
    need = dict(default_constants(), **dict(constants))["conf_thresh_new_track"]
    passed = total = 0
    for seq in sequences:
        for fr in seq.frames:
            passed += int((fr.confidences > need).sum())
            total += len(fr.confidences)
    return passed / total if total else float("nan")


def score_warning(preset: Preset | None, seq, constants: Mapping[str, int], run: Sequence = ()) -> str | None:
    """One line when the share of a sequence's detections that may start a track is far
    (STARTABLE_FACTOR) from the preset's tuning set: its scores are likely on another scale.  ``run``:
    the files of a run calibrated together (docs/model.md 3.19), whose share is tested as one (a
    file of weak detections among strong ones is what the pooled rule is for)."""
    seqs = list(run) or [seq]
    if preset is None or preset.startable is None or not sum(s.num_detections for s in seqs):
        return None
    share = startable_share(seqs, constants)
    low, high = preset.startable / STARTABLE_FACTOR, min(1.0, preset.startable * STARTABLE_FACTOR)
    if low <= share <= high and not (share == 0.0 < preset.startable):
        return None
    need = dict(default_constants(), **dict(constants))["conf_thresh_new_track"]
    name = f"the run's {len(seqs)} files, calibrated together," if run else seq.name + ":"
    whose = "their" if run else "its"
    return (f"{name} {100 * share:.1f} % of {whose} detections pass conf_thresh_new_track {need}, against "
            f"{100 * preset.startable:.1f} % on {preset.tuned_on}, where preset {preset.name} was fitted: its scores "
            f"may be on another scale (--scores auto, the default, reads any scale by the evidence rule; "
            f"--scores says how they were read)")

