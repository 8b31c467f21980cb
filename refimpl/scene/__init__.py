"""Scenes: a tracked sequence as data to reason about (queries, explanations, anticipation, situations).

A :class:`Scene` is the paper's explanation EXP = <H^events, MT> of one sequence, frozen and
JSON-serialisable: the motion tracks (observed boxes, halted spans with their Kalman-predicted
boxes, end), the abduced event log, and the fluent timelines obtained by replaying the events
with :class:`refimpl.knowledge.events.EventState` frame by frame.  On top of it this package answers:

* queries (``query(scene, "hidden_by trk_12")``; the forms are in :data:`QUERY_FORMS`);
* explanations: the event log as one English sentence per episode (:func:`explain`);
* anticipation of hidden entities (paper Section 4.1.2): ``anticipate(unhides_from_behind(T1,T2),T)``,
  ``interpolated_position(T1,T)`` and ``warning(hidden_entity_in_front(T1,T))`` (:func:`anticipate`),
  and its evaluation against the actual reappearances of real sequences
  (:func:`evaluate_anticipation`, ``python -m refimpl.scene anticipation-eval``);
* safety-critical situations of the paper's Table 5 that boxes support: HIDDEN_ENTITY and
  SUDDEN_STOP (:func:`situations`).

Time semantics (docs/model-spec.md section 2): an event that occurs at t sets its fluents from
t + 1 on, so ``holds_at(F, V, t)`` is the value after the events of the frames before t.  A
track hidden by ``hides_behind`` at 235 and resumed by ``unhides_from_behind`` at 268 is halted
(unobserved) at frames 235..267, and ``hidden_by`` is true at frames 236..268.

docs/reasoning.md is the user guide: query language, definitions, evaluation and examples.

One concern per module (each imports only the ones listed before it):

* :mod:`.model`        - SceneTrack, Scene, fluent timelines, make_scene, scene_from_result;
* :mod:`.files`        - the JSON file format: scene_to_json / scene_from_json, save_scene / load_scene;
* :mod:`.episodes`     - episodes and hiding episodes of the event log, and their English sentences;
* :mod:`.anticipation` - ReasoningConfig, the ego region, box predictors, anticipate;
* :mod:`.situations`   - HIDDEN_ENTITY and SUDDEN_STOP;
* :mod:`.queries`      - the relation registry, track summaries and the query language;
* :mod:`.scoring`      - the anticipation evaluation and ``python -m refimpl.scene anticipation-eval``.

Every public name is importable from ``refimpl.scene`` itself.
"""

from __future__ import annotations

from .model import (Box, Scene, SceneError, SceneTrack, fluent_timelines, frame_runs, make_scene,
                    scene_from_result, track_id)
from .files import (SCENE_FORMAT, SCENE_MAX_COORD, SCENE_MAX_IMAGE, SCENE_VERSION, load_scene, save_scene,
                    scene_from_json, scene_to_json)
from .episodes import (ENDINGS, Episode, HidingEpisode, episodes, explain, explain_episode, hiding_end,
                       hiding_episodes)
from .anticipation import (DEFAULT_CONFIG, Anticipation, EgoRegion, Predictor, ReasoningConfig, anticipate,
                           hidden_behind_at, kalman_predictor, no_anticipation_reason, reasoning_config,
                           velocity_predictor)
from .situations import Situation, hidden_entity_situations, situations, sudden_stop_situations
from .queries import (LIFETIME, MOVEMENT, MOVEMENT_WINDOW, QUERIES, QUERY_FORMS, RCC_SHORT_NAME, RELATION_NAMES,
                      SPATIAL,
                      Answer, frame_relations, holds_at, query, query_usage, related, track_summary)
from .scoring import (DURATION_BUCKETS, EpisodeOutcome, evaluate_anticipation, format_evaluation, main,
                      score_scene, summarise_outcomes)


__all__ = [
    "Box", "Scene", "SceneError", "SceneTrack", "fluent_timelines", "frame_runs", "make_scene", "scene_from_result",
    "track_id",
    "SCENE_FORMAT", "SCENE_MAX_COORD", "SCENE_MAX_IMAGE", "SCENE_VERSION", "load_scene", "save_scene",
    "scene_from_json", "scene_to_json",
    "ENDINGS", "Episode", "HidingEpisode", "episodes", "explain", "explain_episode", "hiding_end", "hiding_episodes",
    "DEFAULT_CONFIG", "Anticipation", "EgoRegion", "Predictor", "ReasoningConfig", "anticipate", "hidden_behind_at",
    "kalman_predictor", "no_anticipation_reason", "reasoning_config", "velocity_predictor",
    "Situation", "hidden_entity_situations", "situations", "sudden_stop_situations",
    "LIFETIME", "MOVEMENT", "MOVEMENT_WINDOW", "QUERIES", "QUERY_FORMS", "RCC_SHORT_NAME", "RELATION_NAMES", "SPATIAL",
    "Answer", "frame_relations", "holds_at", "query", "query_usage", "related", "track_summary",
    "DURATION_BUCKETS", "EpisodeOutcome", "evaluate_anticipation", "format_evaluation", "main", "score_scene",
    "summarise_outcomes",
]
