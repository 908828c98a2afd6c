#!/usr/bin/env bash
# Long days (issue 8, item 4): dry runs of generated 50- and 200-target missions on the campus
# map under /usr/bin/time -v. Prints, per run, the exit status, targets projected, peak resident
# set size, wall and mission time and report size; while a run goes, its peak RSS is sampled
# after every 25 finished targets, so the 200-target run also shows the peak after 50 targets of
# the same mission (which separates growth per visit from what a bigger mission costs to load).
#
#   tests/long_day/run_long_day.sh [BUILD_DIR] [COUNTS...]     (default: build 50 200)
#   OUT=/tmp/long-day tests/long_day/run_long_day.sh build-survival 50 200
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
build="$(cd "${1:-$repo/build}" && pwd)"
shift || true
counts=("$@")
[ ${#counts[@]} -gt 0 ] || counts=(50 200)
out="${OUT:-${TMPDIR:-/tmp}/projtour-long-day}"
mkdir -p "$out"
[ -x /usr/bin/time ] || { echo "needs /usr/bin/time (apt-get install time)" >&2; exit 2; }
[ -x "$build/projtour" ] || { echo "no projtour in $build" >&2; exit 2; }

# Targets that repeat a pose are one object visited again (the simulated world shares it), as a
# real long day would be: the default model error (1 mm) is on, the seeded target offsets stay
# off, since an offset drawn per visit would make every revisit a different object.
cat >"$out/world.yaml" <<'WORLD'
seed: 1
WORLD

visits_done() {
  grep -c '"event": "exit", "state": "tour/visit",' "$1" 2>/dev/null || true
}

summary=()
for n in "${counts[@]}"; do
  mission="$out/long_$n.yaml"
  run="$out/run_$n"
  python3 "$here/make_long_mission.py" --targets "$n" --out "$mission"
  rm -rf "$run"
  echo "== $n targets: $mission -> $run" >&2
  /usr/bin/time -v -o "$out/time_$n.txt" "$build/projtour" run "$mission" --dry-run \
    --world "$out/world.yaml" --out "$run" --plugin-path "$build/plugins" --no-history \
    >"$out/stdout_$n.txt" 2>"$out/stderr_$n.txt" &
  timer=$!
  : >"$out/samples_$n.txt"
  next_mark=25
  while kill -0 "$timer" 2>/dev/null; do
    child=$(pgrep -P "$timer" || true)
    if [ -n "$child" ] && [ -r "/proc/$child/status" ]; then
      done_now=$(visits_done "$run/events.jsonl")
      hwm=$(sed -n 's/^VmHWM:[[:space:]]*\([0-9]*\) kB/\1/p' "/proc/$child/status" 2>/dev/null || true)
      if [ -n "$hwm" ] && [ "${done_now:-0}" -ge "$next_mark" ]; then
        echo "$done_now $hwm" >>"$out/samples_$n.txt"
        next_mark=$((next_mark + 25))
      fi
    fi
    sleep 0.2
  done
  status=0
  wait "$timer" || status=$?
  rss_kb=$(sed -n 's/^[[:space:]]*Maximum resident set size (kbytes): //p' "$out/time_$n.txt")
  wall=$(sed -n 's/^[[:space:]]*Elapsed (wall clock) time (h:mm:ss or m:ss): //p' "$out/time_$n.txt")
  report_b=$(stat -c %s "$run/report.json" 2>/dev/null || echo 0)
  read -r projected mission_s < <(python3 - "$run/report.json" <<'PY'
import json, sys
try:
    r = json.load(open(sys.argv[1]))
except Exception:
    print("0 0"); sys.exit()
print(sum(t["outcome"] == "projected" for t in r["targets"]), r["timing"]["mission_s"])
PY
)
  printf '%4d targets: exit %d, %d projected, peak RSS %d kB, wall %s, mission %.0f s, report %d B\n' \
    "$n" "$status" "$projected" "$rss_kb" "$wall" "$mission_s" "$report_b"
  printf '      peak RSS after N targets done (N kB): %s\n' \
    "$(tr '\n' ';' <"$out/samples_$n.txt" | sed 's/;$//; s/;/; /g')"
  summary+=("$n $rss_kb $report_b")
done

if [ ${#summary[@]} -ge 2 ]; then
  read -r n1 rss1 rep1 <<<"${summary[0]}"
  read -r n2 rss2 rep2 <<<"${summary[-1]}"
  awk -v n1="$n1" -v n2="$n2" -v r1="$rss1" -v r2="$rss2" -v p1="$rep1" -v p2="$rep2" 'BEGIN {
    printf "peak RSS grew %+d kB from %d to %d targets (%.1f kB per target); report.json grew %+.1f kB (%.2f kB per target)\n",
      r2 - r1, n1, n2, (r2 - r1) / (n2 - n1), (p2 - p1) / 1024, (p2 - p1) / 1024 / (n2 - n1) }'
fi
