"""Scoring tracked results: CLEAR MOT and IDF1 (motmetrics), HOTA (TrackEval), folders of results, the two eval devkits."""

REFIMPL, TRACKEVAL = "refimpl", "trackeval"
DEVKITS = (REFIMPL, TRACKEVAL)
"""The devkits of ``refimpl eval --devkit`` (refimpl.evaluation.devkits), the first the default;
here so that the command line's parser reads the names without importing the scorers."""
