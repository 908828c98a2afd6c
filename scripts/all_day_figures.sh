#!/bin/bash
# README "Measured figures", all day: a dry run of missions/all_day.yaml (09:00 to 17:00 of
# mission time), its peak memory sampled once a second against the round in events.jsonl, then
# rounds completed, visits projected per round, VmHWM at the end of the first and the last round
# and events.jsonl bytes per hour of mission time.
#   scripts/all_day_figures.sh [BUILD_DIR] [OUT_DIR]
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$here/build}
out=${2:-$(mktemp -d)/all_day}
samples=$out.samples
mission=${MISSION:-$here/missions/all_day.yaml}  # another mission with a schedule: MISSION=...
"$build/projtour" run "$mission" --dry-run --world "$here/missions/demo_world.yaml" \
  --seed 1 --out "$out" > "$out.stdout" &
pid=$!
: > "$samples"
while kill -0 $pid 2>/dev/null; do
  # The round of the latest event that names one, and the process's high-water mark so far.
  round=$(tail -n 200 "$out/events.jsonl" 2>/dev/null | grep -o '"round": [0-9]*' | tail -1 |
          awk '{print $2}' || true)
  hwm=$(awk '/VmHWM/ {print $2}' /proc/$pid/status 2>/dev/null || true)
  [ -n "$round" ] && [ -n "$hwm" ] && echo "$round $hwm" >> "$samples"
  sleep 1
done
wait $pid
python3 - "$out" "$samples" <<'PY'
import collections, json, sys
out, samples = sys.argv[1], sys.argv[2]
hwm = collections.defaultdict(int)
for line in open(samples):
    r, kb = map(int, line.split())
    hwm[r] = max(hwm[r], kb)
report = json.load(open(out + "/report.json"))
per_round = collections.Counter(t["round"] for t in report["targets"] if t["outcome"] == "projected")
rounds = max(t["round"] for t in report["targets"])
print("rounds completed:", rounds, "outcome:", report["outcome"])
print("projected per round:", [per_round[r] for r in range(1, rounds + 1)])
print("VmHWM at the end of round 1: %.1f MiB, of round %d: %.1f MiB" %
      (hwm[1] / 1024, rounds, hwm[rounds] / 1024))
by_hour = collections.Counter()
for line in open(out + "/events.jsonl", "rb"):
    by_hour[int(json.loads(line)["t"] // 3600)] += len(line)
hours = report["timing"]["mission_s"] / 3600
print("events.jsonl: %.0f KiB, %.1f KiB per hour of mission time on average" %
      (sum(by_hour.values()) / 1024, sum(by_hour.values()) / 1024 / hours))
for h in sorted(by_hour):
    print("  mission hour %d: %.1f KiB" % (h, by_hour[h] / 1024))
PY
