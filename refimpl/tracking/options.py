"""The tracker's own options: one table, read by the tracker, the presets, the CLI, the API and
the calibration.

A tracker option is a choice of the tracking loop that a preset may carry beside the model
constants; none of them changes a rule of the model (the same frame problems are solved by the
same rules; what changes is the motion model that builds them, the value of a constant the problem
carries, learned_gate's iou_thresh, or which rows are written).  Each
option is one row of TRACKER_OPTIONS (name, command-line flag, parser, help) and one field of
TrackerOptions (its default, the tracker's behaviour without a preset); adding an option is one
row, one field and the code that reads it.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from typing import Callable, Mapping

from .likelihood import GAP_SPEEDS, MATCHED_IOU, SHIFT_SUPPORT


class WrittenBox(str, Enum):
    """Which box a track writes for a frame in which it was observed (a tracker option, not a
    rule of the model: the abduced hypothesis and the identities are the same either way)."""

    FILTERED = "filtered"
    """The Kalman state after the update with the detection (SORT's output; the default)."""
    DETECTION = "detection"
    """The detection's box itself (what ByteTrack and OC-SORT write)."""
    AUTO = "auto"
    """Learned online, per coordinate (centre x, centre y, width, height): whichever of the two the
    sequence so far shows closer to the midpoint of the track's detections one frame before and
    after (refimpl.tracking.written_box)."""

    @classmethod
    def parse(cls, value: "str | WrittenBox") -> "WrittenBox":
        """A WrittenBox from itself or its name; ValueError naming the choices otherwise."""
        try:
            return cls(value)
        except ValueError:
            raise ValueError(f"written_box must be one of {', '.join(w.value for w in cls)}, "
                             f"got {value!r}") from None


DEFAULT_WRITTEN_BOX = WrittenBox.FILTERED

_TRUE, _FALSE = ("yes", "true", "1", "on"), ("no", "false", "0", "off")


NOISE_FACTOR_MAX = 1e6
"""The largest factor on the Kalman filter's process noise: far beyond any use (the presets hold
1..100), and small enough that the filter's covariance stays finite (``--velocity-noise 1e308``
made it inf, the state NaN, and the run a traceback)."""
REACH_MAX = 100
"""The largest new_speed, in box sizes per frame: a bound no object meets."""
EXPONENT_MAX = 6
"""The largest velocity_exponent: beyond any physical model of motion (4: a steady acceleration)."""


def _number(value: object) -> float | None:
    """A real number from itself or its text (the command line, a --grid value or presets.json);
    None for anything else (a bool is no number here)."""
    v = value
    if isinstance(v, str):
        try:
            v = float(v)
        except ValueError:
            return None
    return None if isinstance(v, bool) or not isinstance(v, (int, float)) else float(v)


def _positive(name: str) -> Callable[[object], float]:
    def parse(value: object) -> float:
        v = _number(value)
        if v is None or not (0 < v <= NOISE_FACTOR_MAX):
            raise ValueError(f"{name} must be a positive number up to {NOISE_FACTOR_MAX:g}, got {value!r}")
        return v
    return parse


def _between(name: str, high: float, what: str = "a number") -> Callable[[object], float]:
    """A number 0..high (velocity_exponent: a power; new_speed: box sizes a frame)."""
    def parse(value: object) -> float:
        v = _number(value)
        if v is None or not (0 <= v <= high):
            raise ValueError(f"{name} must be {what} 0..{high:g}, got {value!r}")
        return v
    return parse


def _switch(name: str) -> Callable[[object], bool]:
    def parse(value: object) -> bool:
        if isinstance(value, bool):
            return value
        text = str(value).strip().lower()
        if text in _TRUE:
            return True
        if text in _FALSE:
            return False
        raise ValueError(f"{name} must be yes or no, got {value!r}")
    return parse


def _factor(name: str) -> Callable[[object], float]:
    def parse(value: object) -> float:
        v = _number(value)
        if v is None or not (v == 0 or 1 < v <= NOISE_FACTOR_MAX):
            raise ValueError(f"{name} must be 0 (off) or a factor above 1 up to {NOISE_FACTOR_MAX:g}, got {value!r}")
        return v
    return parse


def _frames(name: str) -> Callable[[object], int]:
    def parse(value: object) -> int:
        v = value
        if isinstance(v, str):
            try:
                v = int(v.strip())
            except ValueError:
                pass
        if isinstance(v, float) and v.is_integer():
            v = int(v)
        if isinstance(v, bool) or not isinstance(v, int) or v < 0:
            raise ValueError(f"{name} must be a number of frames >= 0, got {value!r}")
        return v
    return parse


def _confidence(name: str) -> Callable[[object], int]:
    def parse(value: object) -> int:
        try:
            v = _frames(name)(value)
        except ValueError:
            v = None
        if v is None or v > 100:
            raise ValueError(f"{name} must be a confidence 0..100, got {value!r}")
        return v
    return parse


@dataclass(frozen=True)
class TrackerOption:
    """One tracker option: how it is named, parsed, written and explained."""

    name: str
    parse: Callable[[object], object]
    """Its value from itself or its text (command line, --grid, presets.json); ValueError otherwise."""
    choices: tuple[str, ...] | None
    """The command line's choices, or None for a number."""
    help: str

    @property
    def flag(self) -> str:
        return "--" + self.name.replace("_", "-")

    @staticmethod
    def text(value: object) -> object:
        """The value as presets.json and the tables write it."""
        if isinstance(value, Enum):
            return value.value
        return value


TRACKER_OPTIONS: tuple[TrackerOption, ...] = (
    TrackerOption("written_box", WrittenBox.parse, tuple(w.value for w in WrittenBox),
                  "the box written for an observed frame: the detection's own box, the Kalman state after "
                  "the update (SORT's output), or auto: per coordinate, whichever the sequence so far shows "
                  "closer to the midpoint of the detections one frame before and after"),
    TrackerOption("velocity_noise", _positive("velocity_noise"), None,
                  "the factor on the process noise of the Kalman filter's velocities (1: SORT's filter)"),
    TrackerOption("velocity_exponent", _between("velocity_exponent", EXPONENT_MAX), None,
                  "at a frame rate other than the preset's, velocity_noise times (preset's fps / sequence's fps) "
                  "to this power: 2 the same change of speed per frame, 3 a random change of speed per second "
                  "(white-noise acceleration), 4 a steady acceleration (an approaching car's image speed grows "
                  "steadily; 0: per frame whatever the rate)"),
    TrackerOption("area_noise", _positive("area_noise"), None,
                  "the factor on the process noise of the Kalman filter's box area (1: SORT's filter; large: "
                  "the filtered size follows the detections)"),
    TrackerOption("size_change", _factor("size_change"), None,
                  "across a frame after one without an update, a track's predicted area grows or shrinks by "
                  "at most this factor (per frame at the preset's frame rate, the same change per second at "
                  "any other): a hidden object keeps roughly its size (0: unbounded, SORT's filter)"),
    TrackerOption("size_gate", _factor("size_gate"), None,
                  "a track is not matched to a detection whose area differs from the track's last observed "
                  "area by more than this factor times size_change (1 without it) per frame since then: "
                  "an object's apparent size changes gradually (0: no such gate, as the paper)"),
    TrackerOption("backfill", _switch("backfill"), ("yes", "no"),
                  "when a track is confirmed (min_hits consecutive updates), also write the earlier frames "
                  "of that streak, a new track's first frame included (results final min_hits frames late)"),
    TrackerOption("backfill_gap", _frames("backfill_gap"), None,
                  "with backfill, a confirmation also writes the track's earlier frames across gaps of at most "
                  "this many unobserved frames, the gaps interpolated: the object was there before its streak "
                  "(0: the streak's consecutive frames only)"),
    TrackerOption("fill_hidden", _frames("fill_hidden"), None,
                  "write the interpolated boxes of a confirmed track's occlusion episode of at most this many "
                  "frames (halted by hides_behind, resumed by unhides_from_behind); 0: never (results final "
                  "that many frames late)"),
    TrackerOption("bridge_gap", _frames("bridge_gap"), None,
                  "a confirmed track resumed after at most this many unobserved frames, by a detection of "
                  "confidence >= bridge_conf, stays confirmed and writes the frames between, interpolated: the "
                  "object was there, missed (results final that many frames late)"),
    TrackerOption("bridge_conf", _confidence("bridge_conf"), None,
                  "the confidence (0..100) a resuming detection needs to bridge a gap (bridge_gap)"),
    TrackerOption("write_evidence", _confidence("write_evidence"), None,
                  "a track is first written once the mean confidence (0..100) of the detections it has taken "
                  "is at least this, besides min_hits (0: min_hits alone, as SORT)"),
    TrackerOption("write_peak", _confidence("write_peak"), None,
                  "a track is written while its best detection ranks at least this (0..100) among the scores "
                  "seen so far (the rank rule, with RANK_PRIOR scores taken to lie below them), judged anew "
                  "every frame, besides write_evidence (0: never asked)"),
    TrackerOption("peak_wait", _frames("peak_wait"), None,
                  "a track that write_peak holds back is written all the same, from then on, once it has been "
                  "observed this many frames in a row: an object followed that long is there, whatever its "
                  "scores' rank (0: held until its peak)"),
    TrackerOption("scene_velocity", _switch("scene_velocity"), ("yes", "no"),
                  "a new track starts with the median velocity of the tracks observed in the previous frame "
                  "(the image motion that a turning camera gives every object) instead of zero; until it is "
                  "seen again it is matched by the better of that prediction and rest"),
    TrackerOption("uncertain_speed", _switch("uncertain_speed"), ("yes", "no"),
                  "a halted track is matched by the best overlap of its predicted box and of that box moved "
                  f"{', '.join(f'{f:g}' for f in GAP_SPEEDS[:-1])} and {GAP_SPEEDS[-1]:g} times as far as the "
                  "filter predicts since its last observation (an unseen object's speed is known only "
                  "roughly) instead of the prediction alone"),
    TrackerOption("new_speed", _between("new_speed", REACH_MAX, "a number of box sizes"), None,
                  "a track started in the frame before has not shown its speed: it is also matched, at half "
                  "the overlap, to a detection of about its size (areas within size_change) by its box moved "
                  "towards it by at most this many box sizes (square root of its area) a frame (at the "
                  "preset's frame rate, the same speed per second at any other): a car crossing the view "
                  "moves further than its width between frames (0: off)"),
    TrackerOption("scene_shift", _switch("scene_shift"), ("yes", "no"),
                  "when most tracks seen in the previous frame overlap no detection and one image shift of "
                  f"their predictions makes at least {SHIFT_SUPPORT} of them, and {SHIFT_SUPPORT} more than without "
                  f"it, overlap one (IoU >= {MATCHED_IOU:g}), every track that overlaps no detection is also "
                  "matched at its prediction moved by that shift (a turning camera moves every object alike)"),
    TrackerOption("learned_gate", _confidence("learned_gate"), None,
                  "the gate iou_thresh learned from the sequence's own matches: this percent (0..100) of the "
                  "median matching likelihood of the assignments so far, at most the constant and at least two "
                  "thirds of it (a detector whose boxes wander is gated less tightly than a precise one; 0: the "
                  "constant, as the paper)"),
    TrackerOption("wander_noise", _confidence("wander_noise"), None,
                  "while the learned gate is below the constant (the sequence's matches show a detector whose "
                  "boxes wander), the Kalman filter takes a detection's centre to wander by this percent (0..100) "
                  "of the box's width and height instead of SORT's 1 px (0: SORT's filter)"),
    TrackerOption("hold_hidden", _switch("hold_hidden"), ("yes", "no"),
                  "a halted track's prediction keeps its size and a bounded constant velocity "
                  "(BoxKalman.predict(hold=True)) instead of the free Kalman prediction"),
    TrackerOption("reupdate_on_resume", _switch("reupdate_on_resume"), ("yes", "no"),
                  "a resumed track's filter is re-run over the gap along the interpolated box "
                  "(observation-centric re-update, the idea of OC-SORT's ORU) instead of one plain update"),
)
"""Every tracker option, in the order of the command line's help and of the tables."""


@dataclass(frozen=True)
class TrackerOptions:
    """The values of the tracker options (TRACKER_OPTIONS); the defaults are the tracker's
    behaviour without a preset."""

    written_box: WrittenBox = DEFAULT_WRITTEN_BOX
    velocity_noise: float = 1.0
    velocity_exponent: float = 2.0
    area_noise: float = 1.0
    size_change: float = 0.0
    size_gate: float = 0.0
    backfill: bool = False
    backfill_gap: int = 0
    fill_hidden: int = 0
    bridge_gap: int = 2
    bridge_conf: int = 90
    write_evidence: int = 0
    write_peak: int = 0
    peak_wait: int = 0
    scene_velocity: bool = False
    uncertain_speed: bool = False
    new_speed: float = 0.0
    scene_shift: bool = False
    learned_gate: int = 0
    wander_noise: int = 0
    hold_hidden: bool = False
    reupdate_on_resume: bool = False

    def __post_init__(self) -> None:
        for option in TRACKER_OPTIONS:
            object.__setattr__(self, option.name, option.parse(getattr(self, option.name)))

    @classmethod
    def from_mapping(cls, values: Mapping[str, object], where: str = "tracker options") -> "TrackerOptions":
        """From {name: value} (a preset's "tracker" entry); ValueError naming the known options."""
        known = cls.names()
        unknown = sorted(set(values) - set(known))
        if unknown:
            raise ValueError(f"{where}: unknown tracker option(s) {', '.join(unknown)} (known: {', '.join(known)})")
        try:
            return cls(**{str(k): v for k, v in values.items()})
        except ValueError as exc:
            raise ValueError(f"{where}: {exc}") from None

    @staticmethod
    def names() -> tuple[str, ...]:
        return tuple(o.name for o in TRACKER_OPTIONS)

    def as_dict(self) -> dict[str, object]:
        """{name: value} of every option, values as written in model/presets.json."""
        return {o.name: o.text(getattr(self, o.name)) for o in TRACKER_OPTIONS}

    def changed(self) -> dict[str, object]:
        """The options that differ from the defaults (what a preset changes)."""
        default = TrackerOptions().as_dict()
        return {k: v for k, v in self.as_dict().items() if default[k] != v}


def option_flags(*before: str) -> str:
    """Flags for a message, the tracker options' last: option_flags("--const") ==
    '--const, --written-box, --velocity-noise, --area-noise, --backfill, --fill-hidden,
    --scene-velocity, --hold-hidden and --reupdate-on-resume'."""
    flags = [*before, *(o.flag for o in TRACKER_OPTIONS)]
    return ", ".join(flags[:-1]) + " and " + flags[-1]
