"""The registry of peer trackers (``refimpl benchmark --peers``): one ``Peer`` row per tracker, the
optional package it comes from (``PACKAGES``) and what it runs with beyond its constructor's
defaults.  Running and scoring them is refimpl.experiments.peers, the lab bench; the command line
reads only this table (its ``--peers`` help), so building its parser imports neither the scorers
nor the lab bench.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Mapping


@dataclass(frozen=True)
class Package:
    """An optional package peers come from."""

    module: str
    requirement: str
    extra: str
    note: str = ""


PACKAGES = {
    "trackers": Package("trackers", "trackers==2.6.1", "peers"),
    "boxmot": Package("boxmot", "boxmot==25.0.0", "peers-boxmot",
                      "; it brings torch: install a CPU torch and its torchvision first (docs/peers.md), "
                      "or pip takes a CUDA build of several GB"),
}


@dataclass(frozen=True)
class Peer:
    """One peer tracker: where it comes from and what it runs with beyond its constructor defaults."""

    name: str
    """As on the command line (``--peers``)."""
    package: str
    """A key of PACKAGES."""
    class_name: str
    settings: Mapping[str, object] = field(default_factory=dict)
    """Set beyond the constructor defaults (BoxMOT: no ReID, no camera-motion compensation)."""
    frame_rate: bool = True
    """The constructor takes the sequence's frame rate (``frame_rate``)."""
    image_size: bool = False
    """The constructor takes the image's size (``frame_width``, ``frame_height``; BoxMOT's SFSORT,
    which otherwise reads it off the image, and a detection file has none)."""
    shown: tuple[str, ...] = ()
    """The parameters listed under a comparison table (the ones that shape the result)."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "settings", MappingProxyType(dict(self.settings)))  # read-only


_TRACKERS_SHOWN = ("lost_track_buffer", "frame_rate", "track_activation_threshold", "minimum_consecutive_frames",
                   "minimum_iou_threshold", "high_conf_det_threshold", "direction_consistency_weight", "delta_t",
                   "state_estimator_class")
_SORT_FAMILY = ("det_thresh", "max_age", "min_hits", "iou_threshold")
"""BoxMOT's base-tracker parameters that its OC-SORT, HybridSORT and BoostTrack read."""
_NO_REID = {"use_embeddings": False}

_ROWS = (
    Peer("sort", "trackers", "SORTTracker", shown=_TRACKERS_SHOWN),
    Peer("bytetrack", "trackers", "ByteTrackTracker", shown=_TRACKERS_SHOWN),
    Peer("ocsort", "trackers", "OCSORTTracker", shown=_TRACKERS_SHOWN),
    Peer("boxmot-bytetrack", "boxmot", "ByteTrack",
         shown=("min_conf", "track_thresh", "match_thresh", "track_buffer", "frame_rate")),
    Peer("boxmot-ocsort", "boxmot", "OcSort", frame_rate=False,
         shown=(*_SORT_FAMILY, "min_conf", "delta_t", "inertia", "use_byte", "asso_func")),
    Peer("boxmot-botsort", "boxmot", "BotSort", {**_NO_REID, "use_cmc": False},
         shown=("track_high_thresh", "track_low_thresh", "new_track_thresh", "track_buffer", "match_thresh",
                "proximity_thresh", "frame_rate", "fuse_first_associate", "use_embeddings", "use_cmc")),
    Peer("boxmot-hybridsort", "boxmot", "HybridSort", {**_NO_REID, "cmc_method": None}, frame_rate=False,
         shown=(*_SORT_FAMILY, "low_thresh", "track_thresh", "delta_t", "inertia", "use_byte", "TCM_first_step",
                "TCM_byte_step", "use_embeddings", "cmc_method")),
    Peer("boxmot-boosttrack", "boxmot", "BoostTrack", {**_NO_REID, "use_cmc": False}, frame_rate=False,
         shown=(*_SORT_FAMILY, "min_box_area", "aspect_ratio_thresh", "lambda_iou", "lambda_mhd", "lambda_shape",
                "use_dlo_boost", "use_duo_boost", "dlo_boost_coef", "use_embeddings", "use_cmc")),
    Peer("boxmot-deepocsort", "boxmot", "DeepOcSort", {**_NO_REID, "cmc_off": True}, frame_rate=False,
         shown=(*_SORT_FAMILY, "delta_t", "inertia", "w_association_emb", "aw_off", "aw_param", "use_embeddings",
                "cmc_off")),
    Peer("boxmot-sfsort", "boxmot", "SFSORT", frame_rate=False, image_size=True,
         shown=("high_th", "match_th_first", "new_track_th", "low_th", "match_th_second", "dynamic_tuning",
                "marginal_timeout", "central_timeout")),
    Peer("boxmot-occluboost", "boxmot", "OccluBoost", {**_NO_REID, "use_cmc": False}, frame_rate=False,
         shown=(*_SORT_FAMILY, "new_track_thresh", "track_low_thresh", "confirm_hits", "instant_confirm_thresh",
                "tentative_max_age", "recovery_iou_thresh", "recovery_max_age", "use_second_pass", "use_embeddings",
                "use_cmc")),
)
PEERS: dict[str, Peer] = {p.name: p for p in _ROWS}
"""Peer name (as on the command line) -> Peer; ``--peers all`` runs every one."""
