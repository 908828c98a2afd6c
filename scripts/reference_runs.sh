#!/usr/bin/env bash
# The runs a refactor must leave unchanged (issue 43, line 9): the demo tour in its world and in
# the busy world, seeds 1-5, and `projtour validate` over every YAML file git tracks.
#   scripts/reference_runs.sh OUT [YAML_LIST]     (from a tree built into build/)
# YAML_LIST: a file naming the YAML files to validate (default: git ls-files '*.yaml'), so that two
# trees are compared over the same list. Then: scripts/compare_runs.py OUT_BEFORE OUT_AFTER.
set -u
out=$1
list=${2:-}
mkdir -p "$out"
: > "$out/rcs.txt"
for w in demo busy; do
  world=missions/demo_world.yaml
  [ "$w" = busy ] && world=missions/demo_world_busy.yaml
  for s in 1 2 3 4 5; do
    rm -rf "$out/${w}_seed$s"
    build/projtour run missions/demo_tour.yaml --dry-run --world "$world" --seed "$s" \
      --out "$out/${w}_seed$s" --no-monitor --no-history \
      > "$out/${w}_seed$s.stdout" 2> "$out/${w}_seed$s.stderr"
    echo "$w $s rc=$?" >> "$out/rcs.txt"
  done
done
: > "$out/validate.txt"
{ if [ -n "$list" ]; then cat "$list"; else git ls-files '*.yaml'; fi; } | sort | while read -r f; do
  echo "== $f" >> "$out/validate.txt"
  build/projtour validate "$f" >> "$out/validate.txt" 2>&1
  echo "rc=$?" >> "$out/validate.txt"
done
