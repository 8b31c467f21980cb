"""Object classes as a detector names them, and the type each one is tracked as.

The model compares types only for equality (a track takes detections of its own type, model.md
3.2), so any class can be tracked: the three types the readers and presets know
(``OBJECT_TYPES``: pedestrian, car, cyclist) keep their names, COCO's ``person`` and ``bicycle``
are the model's pedestrian and cyclist, and every other class is a type of its own, its name
spelled as a symbol the solvers read (``traffic light`` -> ``traffic_light``).  A class id a
detector's map does not name is the type ``class_<id>``: tracked on its own, never together
with another class.

``COCO_NAMES`` is the one list of COCO's 80 detection classes in the order of their contiguous
ids 0..79 (what YOLO-family detectors, supervision and BoxMOT number them by).
"""

from __future__ import annotations

import re
from typing import Mapping

from ..core.spec import is_symbol
from .lines import OBJECT_TYPES

COCO_NAMES = (
    "person", "bicycle", "car", "motorcycle", "airplane", "bus", "train", "truck", "boat", "traffic light",
    "fire hydrant", "stop sign", "parking meter", "bench", "bird", "cat", "dog", "horse", "sheep", "cow",
    "elephant", "bear", "zebra", "giraffe", "backpack", "umbrella", "handbag", "tie", "suitcase", "frisbee",
    "skis", "snowboard", "sports ball", "kite", "baseball bat", "baseball glove", "skateboard", "surfboard",
    "tennis racket", "bottle", "wine glass", "cup", "fork", "knife", "spoon", "bowl", "banana", "apple",
    "sandwich", "orange", "broccoli", "carrot", "hot dog", "pizza", "donut", "cake", "chair", "couch",
    "potted plant", "bed", "dining table", "toilet", "tv", "laptop", "mouse", "remote", "keyboard", "cell phone",
    "microwave", "oven", "toaster", "sink", "refrigerator", "book", "clock", "vase", "scissors", "teddy bear",
    "hair drier", "toothbrush",
)
"""COCO's 80 detection classes, index = contiguous class id."""

MODEL_TYPE_OF = {"person": "pedestrian", "bicycle": "cyclist"}
"""Class names whose objects the model's own types (OBJECT_TYPES) stand for."""


def class_type(name: object) -> str:
    """The type a class of this name is tracked as (module doc), in any case: ValueError (one
    sentence) for a name with no letter or digit."""
    key = re.sub(r"[^a-z0-9_]+", "_", str(name).strip().lower()).strip("_")
    key = MODEL_TYPE_OF.get(key, key)
    if not key:
        raise ValueError(f"class name {name!r} has no letter or digit to name a type by")
    if key in OBJECT_TYPES or is_symbol(key):
        return key
    return f"class_{key}"  # starts with a digit, or the keyword 'not'


def class_id_type(class_id: int, class_types: Mapping[int, str]) -> str:
    """The type of a detector's integer class id: its entry of ``class_types``, else ``class_<id>``."""
    found = class_types.get(class_id)
    return found if found is not None else f"class_{class_id}"


COCO_CLASS_TYPES = {i: class_type(name) for i, name in enumerate(COCO_NAMES)}
"""COCO class id -> type: 0 pedestrian, 1 cyclist, 2 car, 5 bus, 9 traffic_light, ..."""
