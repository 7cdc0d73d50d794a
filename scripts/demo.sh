#!/usr/bin/env bash
# Builds CrowdHealth (via setup.sh) and runs one demo scenario into out/demo, then shows the
# first rows of metrics.csv and summary.json.
# Usage: scripts/demo.sh [SCENARIO.xml]
#   default: the paper's SPH doorway base case (Examples/doorway/base-case.xml, ~400 agents) when
#   present, else an official UMANS Social Forces example from ../shared (beside the repository).
set -euo pipefail
cd "$(dirname "$0")/.."

DOORWAY="Examples/doorway/base-case.xml"
UMANS_EXAMPLE="../shared/umans-examples/25to25-90Degrees-SocialForces.xml"
OUT="out/demo"

if [ "$#" -ge 1 ]; then
  SCENARIO="$1"
elif [ -f "$DOORWAY" ]; then
  SCENARIO="$DOORWAY"
elif [ -d ../shared/umans-examples ]; then
  SCENARIO="$UMANS_EXAMPLE"
else
  echo "demo: error: neither $DOORWAY nor ../shared/umans-examples was found" >&2
  echo "      (../shared is expected beside the repository, at $(cd .. && pwd)/shared);" >&2
  echo "      pass a scenario instead: scripts/demo.sh path/to/scenario.xml" >&2
  exit 2
fi
if [ ! -f "$SCENARIO" ]; then
  echo "demo: error: scenario '$SCENARIO' not found" >&2
  exit 2
fi

scripts/setup.sh

echo
echo "demo: running $SCENARIO -> $OUT"
build/bin/crowdhealth -i "$SCENARIO" -o "$OUT" --trajectories both

echo
echo "== $OUT/metrics.csv (first rows)"
head -n 6 "$OUT/metrics.csv"
echo
echo "== $OUT/summary.json"
cat "$OUT/summary.json"
echo
echo "demo: all outputs are in $OUT ($(ls "$OUT" | wc -l) files)"
