#!/bin/bash
# Does a change alter what refimpl writes?  Tracks every MOT15 sequence (SORT's Faster R-CNN
# detections) and every KITTI tracking training sequence (Car, Pedestrian and Cyclist, PointRCNN)
# with the baseline and the default abduction backend, at two commits, through the command line,
# and MOT15's 7 ACF detection files too, and compares every results file and event log byte for
# byte: the 81 shared sequences with detections.  KITTI_CLASSES="Cyclist" MOT15=no (or KITTI_CLASSES="") narrows a run.
#
#   tests/tools/compare_outputs.sh BASE [HEAD] [DATA]     (HEAD defaults to the working tree's HEAD,
#                                                    DATA to ../shared/data)
# Prints one line per differing file and a summary; exits 1 if any file differs.  Each commit is
# checked out into a temporary git worktree; takes about 10 minutes per commit on 2 cores.
set -euo pipefail
BASE=${1:?usage: tests/tools/compare_outputs.sh BASE [HEAD] [DATA]}
HEAD=${2:-HEAD}
REPO=$(git rev-parse --show-toplevel)
DATA=$(cd "${3:-$REPO/../shared/data}" && pwd)
WORK=$(mktemp -d)
trap 'for d in "$WORK"/tree-*; do git -C "$REPO" worktree remove --force "$d" 2>/dev/null || true; done; rm -rf "$WORK"' EXIT

track_all() {  # TREE OUT
  local tree=$1 out=$2 n f c b ev
  mkdir -p "$out"
  [ "${MOT15:-yes}" = no ] || for s in "$DATA"/MOT15/train/*/; do
    n=$(basename "$s")
    for b in baseline cpsat; do
      ev=(); [ "$b" != baseline ] && ev=(--events "$out/$n.$b.lp")
      (cd "$tree" && python -m refimpl track --dets "$s/det/det_sort_frcnn.txt" --backend "$b" \
        --out "$out/$n.$b.txt" "${ev[@]}" --quiet 2>/dev/null)
      [ -f "$s/det/det.txt" ] || continue  # MOT15's ACF detections (7 of the 11 sequences)
      ev=(); [ "$b" != baseline ] && ev=(--events "$out/$n-acf.$b.lp")
      (cd "$tree" && python -m refimpl track --dets "$s/det/det.txt" --backend "$b" \
        --out "$out/$n-acf.$b.txt" "${ev[@]}" --quiet 2>/dev/null)
    done
  done
  for c in ${KITTI_CLASSES-Car Pedestrian Cyclist}; do
    for f in "$DATA"/KITTI/tracking/training/det_02_pointrcnn/$c/*.txt; do
      n=$(basename "$f" .txt)
      for b in baseline cpsat; do
        ev=(); [ "$b" != baseline ] && ev=(--events "$out/$c-$n.$b.lp")
        (cd "$tree" && python -m refimpl track --dets "$f" --format kitti --class "$c" --backend "$b" \
          --out "$out/$c-$n.$b.txt" "${ev[@]}" --quiet 2>/dev/null)
      done
    done
  done
}

for rev in "$BASE" "$HEAD"; do
  sha=$(git -C "$REPO" rev-parse --short "$rev")
  git -C "$REPO" worktree add -q --detach "$WORK/tree-$sha" "$rev"
  echo "tracking at $sha ..." >&2
  track_all "$WORK/tree-$sha" "$WORK/out-$sha"
done
a=$WORK/out-$(git -C "$REPO" rev-parse --short "$BASE"); b=$WORK/out-$(git -C "$REPO" rev-parse --short "$HEAD")
differ=0; total=0
for f in "$a"/*; do
  total=$((total + 1))
  if ! cmp -s "$f" "$b/$(basename "$f")"; then echo "differs: $(basename "$f")"; differ=$((differ + 1)); fi
done
[ "$(ls "$a" | wc -l)" = "$(ls "$b" | wc -l)" ] || { echo "the two runs wrote different sets of files"; differ=$((differ + 1)); }
echo "$total files compared ($BASE vs $HEAD): $differ differ"
[ "$differ" = 0 ]
