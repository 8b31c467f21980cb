"""The camera a sequence was taken with, seen by the model: its frame rate and image size turn the
model's durations and pixel constants into this sequence's frames and pixels (refimpl decision,
docs/model.md 3.22), so a 5 fps camera and a 30 fps one, or half the resolution, mean the same to
the model."""

from __future__ import annotations

import math
import warnings
from typing import Mapping

import numpy as np

from ..core.constants import default_constants
from .options import NOISE_FACTOR_MAX, REACH_MAX

HIDDEN_MAX_SECONDS = 10.0
"""The safety bound on any halt (model constant lost_after_hidden_max), in seconds of the sequence's
frame rate (docs/model.md 3.14); without a frame rate the model's default in frames applies."""

DURATIONS = ("lost_after_missing", "lost_after_hidden", "noise_max_age", "claim_after", "likelihood_halving")
"""The model constants that are durations in frames: a preset's are converted from the frame rate
it was tuned at to the sequence's (:func:`frames_at`, docs/model.md 3.22), as are the tracker
options of FRAME_OPTIONS."""
FRAME_OPTIONS = ("backfill_gap", "fill_hidden", "bridge_gap", "peak_wait")
"""The tracker options that are durations in frames, converted as DURATIONS are."""


def frames_at(frames: int, fps: float, tuned_fps: float) -> int:
    """A duration of ``frames`` frames at ``tuned_fps`` frames per second, in frames at ``fps``:
    rounded half up, at least 1 (0 stays 0: an option switched off)."""
    if frames <= 0:
        return int(frames)
    return max(1, int(math.floor(frames * float(fps) / float(tuned_fps) + 0.5)))


def velocity_noise_at(noise: float, fps: float, tuned_fps: float, exponent: float = 2) -> float:
    """The Kalman filter's velocity process noise (the tracker option velocity_noise, a variance
    per frame tuned at ``tuned_fps``) at ``fps``: times (tuned_fps / fps) ** ``exponent`` (the
    tracker option velocity_exponent; docs/model.md 3.22, "Motion"), at most the option's largest
    value NOISE_FACTOR_MAX (kitti/car's 10 at 10 fps is 1e9 at 0.1 fps with exponent 4)."""
    return min(float(noise) * (float(tuned_fps) / float(fps)) ** float(exponent), NOISE_FACTOR_MAX)


def factor_at(factor: float, fps: float, tuned_fps: float) -> float:
    """A change by at most ``factor`` per frame at ``tuned_fps`` (the tracker option size_change),
    per frame at ``fps``: the same change per second, factor ** (tuned_fps / fps), at most the
    option's largest value NOISE_FACTOR_MAX (a bound no box meets; 1.25 at 10 fps is 4.9e9 at
    0.1 fps); 0 stays 0: the option switched off."""
    if factor <= 0:
        return float(factor)
    return min(float(factor) ** (float(tuned_fps) / float(fps)), NOISE_FACTOR_MAX)


RATE_OPTIONS = {"velocity_noise": lambda o, fps, tuned: velocity_noise_at(o.velocity_noise, fps, tuned, o.velocity_exponent),
                "size_change": lambda o, fps, tuned: factor_at(o.size_change, fps, tuned),
                "new_speed": lambda o, fps, tuned: min(o.new_speed * float(tuned) / float(fps), REACH_MAX)}
"""The tracker options that are per frame but no duration, each with its value at the sequence's
frame rate from the options tuned at the preset's, applied unless the user gave the option: the
process noise of the Kalman filter's velocities (:func:`velocity_noise_at`, by the power
velocity_exponent of the ratio of frame intervals), the bound on an unobserved track's change
of size (:func:`factor_at`) and the speed a track seen once may have (new_speed, box sizes per
frame: the same per second, at most REACH_MAX)."""


def sequence_constants(constants: Mapping[str, int] | None, image_size: tuple[int, int] | None,
                       fps: float | None, tuned_fps: float | None = None,
                       in_frames: tuple[str, ...] = ()) -> dict[str, int]:
    """The constants a sequence is tracked with: the given ones, then what the sequence says of
    itself where they do not (image size: the field-of-view border, and the pixel constants scaled
    to the image, :func:`image_relative`; frame rate: the safety bound on halts, HIDDEN_MAX_SECONDS).
    Every pixel constant (PIXEL_CONSTANTS, given in the image's pixels) is returned in the model's
    working pixels (:func:`sequence_scale`).
    With ``tuned_fps`` (a preset's frame rate) and the sequence's ``fps``, every duration of
    DURATIONS not named in ``in_frames`` (given by the user, in frames) is converted by
    :func:`frames_at`."""
    merged = dict(constants or {})
    if fps and tuned_fps and fps != tuned_fps:
        defaults = default_constants()
        for name in DURATIONS:
            if name not in in_frames:
                merged[name] = frames_at(int(merged.get(name, defaults[name])), fps, tuned_fps)
    if image_size is not None:
        merged.setdefault("img_width", int(image_size[0]))
        merged.setdefault("img_height", int(image_size[1]))
    scale = sequence_scale(constants, image_size)
    if scale != 1.0:  # pixels given (the image's size, a pixel constant) in working pixels
        for name, power in PIXEL_CONSTANTS.items():
            if merged.get(name, 0) > 0:
                merged[name] = int(round(merged[name] * scale ** power))
    if merged.get("img_width", 0) > 0 and merged.get("img_height", 0) > 0:  # also given as constants
        for name, value in image_relative((merged["img_width"], merged["img_height"])).items():
            merged.setdefault(name, value)
    if fps:
        merged.setdefault("lost_after_hidden_max", max(1, int(round(HIDDEN_MAX_SECONDS * fps))))
    return merged


PIXEL_CONSTANTS = {"img_width": 1, "img_height": 1, "border_margin": 1, "size_threshold": 2}
"""The model constants in pixels (a length) or pixels squared (an area): the power of
:func:`working_scale` that turns the value given in the image's pixels into working pixels."""

WORKING_WIDTH = 1920
"""The model reasons in working pixels: the image's, doubled or halved until its width is more than
half of this and at most this (:func:`working_scale`, docs/model.md 3.22)."""


def working_scale(width: int) -> float:
    """The factor from an image's pixels to the model's working pixels: a power of two (so scaling is
    exact in floating point) that brings ``width`` into (WORKING_WIDTH / 2, WORKING_WIDTH]; 1 for an
    unknown width (0).  A camera of half the resolution gets twice the factor: the same working boxes."""
    if width <= 0:
        return 1.0
    scale = 1.0
    while width * scale <= WORKING_WIDTH / 2:
        scale *= 2.0
    while width * scale > WORKING_WIDTH:
        scale /= 2.0
    return scale


def sequence_scale(constants: Mapping[str, int] | None, image_size: tuple[int, int] | None) -> float:
    """:func:`working_scale` of a sequence's image width: the constant img_width if given, else its
    image size's (1 where neither is known)."""
    width = (constants or {}).get("img_width") or (image_size[0] if image_size is not None else 0)
    return working_scale(int(width))


REFERENCE_IMAGE = (1920, 1080)
"""The image size at which model/constants.lp gives its pixel constants (docs/model.md 3.22)."""


def image_relative(image_size: tuple[int, int]) -> dict[str, int]:
    """The model's pixel constants for an image of this size (refimpl decision, docs/model.md 3.22):
    ``size_threshold`` (an area, px^2) times W H / (1920 x 1080) and ``border_margin`` (a length,
    px) times the square root of that, each rounded to the nearest integer; a camera of half the
    resolution then sees the same boxes as too small and the same tracks as near the border."""
    defaults = default_constants()
    area = float(image_size[0]) * float(image_size[1]) / (REFERENCE_IMAGE[0] * REFERENCE_IMAGE[1])
    return {"size_threshold": int(round(defaults["size_threshold"] * area)),
            "border_margin": int(round(defaults["border_margin"] * math.sqrt(area)))}


def image_in_use(constants: Mapping[str, int] | None, image_size: tuple[int, int] | None) -> tuple[int, int] | None:
    """The image (width, height) in the image's pixels the field of view is tested against: the
    constants img_width and img_height where both are given (as :func:`sequence_constants` takes
    them), else the sequence's image size; None where neither is known."""
    given = constants or {}
    if given.get("img_width", 0) > 0 and given.get("img_height", 0) > 0:
        return int(given["img_width"]), int(given["img_height"])
    return None if image_size is None else (int(image_size[0]), int(image_size[1]))


def warn_if_outside(frame: int, boxes: np.ndarray, image: tuple[int, int], stacklevel: int = 3) -> bool:
    """One warning, and True, when a detection box (x, y, w, h) of this frame is centred outside the
    ``image`` (width, height); False otherwise.  No detection of the benchmark sets' files
    (refimpl.io.datasets: 211,704 detections, each with its own image size) is centred outside its
    image, so one that is says the image size is not the detections' (a wrong --img-size or
    seqinfo.ini, width and height swapped, another resolution): the field of view would end inside
    the scene and cut the tracks there short, silently."""
    b = np.asarray(boxes, dtype=float).reshape(-1, 4)
    centre = b[:, :2] + 0.5 * b[:, 2:]
    if centre.min() >= 0 and not (centre > image).any():  # every frame of a run: the fewest array operations
        return False
    outside = ((centre < 0) | (centre > image)).any(axis=1)
    k = int(np.argmax(outside))
    warnings.warn(f"frame {frame}: {int(outside.sum())} detection(s) centred outside the {image[0]} x {image[1]} "
                  f"image the sequence was given (--img-size, seqinfo.ini or img_size), the first at "
                  f"({centre[k, 0]:.0f}, {centre[k, 1]:.0f}): the field of view ends inside the scene and tracks there are cut short; "
                  "is it the detections' image size? (said once)", UserWarning, stacklevel=stacklevel)
    return True
