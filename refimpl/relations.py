"""Spatial relations between integer boxes (the paper's Sigma_st), as the model's preconditions use them.

Pure integer functions on (x, y, w, h) boxes, so that they give exactly what the ASP
encoding computes from box2d/5 facts.
"""

from __future__ import annotations

from .geometry import intersection_area
from .spec import Box


def overlapping_top(b1: Box, b2: Box, hide_overlap: int) -> bool:
    """position(overlapping_top, T1, T2): b2 covers more than hide_overlap % of b1 and is not behind it.

    "Not behind" is the ground-plane depth cue: b2's bottom edge is at or below b1's in the image.
    """
    return (
        100 * intersection_area(b1, b2) > hide_overlap * b1[2] * b1[3]
        and b2[1] + b2[3] >= b1[1] + b1[3]
    )


def near_border(b: Box, img_width: int, img_height: int, margin: int) -> bool:
    """The box is within margin px of (or beyond) a border of the field of view; 0 = size unknown."""
    x, y, w, h = b
    return (
        x <= margin
        or y <= margin
        or (img_width > 0 and x + w >= img_width - margin)
        or (img_height > 0 and y + h >= img_height - margin)
    )


def area(b: Box) -> int:
    return b[2] * b[3]
