"""Scoring tracked results: CLEAR MOT and IDF1 (motmetrics), HOTA (TrackEval), folders of results, the two eval devkits."""
