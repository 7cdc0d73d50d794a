#!/usr/bin/env bash
# Runs all of UMANS' example scenarios (../shared/umans-examples) in UMANS 1.x and in CrowdHealth and
# writes a comparison table (arrived fraction, mean arrival time, closest approach) per example.
# Builds UMANS (../shared/reference/umans/build-umans.sh, into /tmp/umans-ref) and the crowdhealth
# program when missing. Usage:
#   scripts/compare-umans.sh [OUTDIR]                  (default OUTDIR: build/compare-umans)
#   ONLY='Circle.*-ORCA' JOBS=2 TIMEOUT=600 scripts/compare-umans.sh out
#   CH_ARGS='--foo' ...                                 extra arguments for crowdhealth
# Writes OUTDIR/compare.md, OUTDIR/compare.csv and each run under OUTDIR/runs/<example>/{umans,crowdhealth}
# (their logs beside them: umans.log, crowdhealth.log).
# Definitions (the same for both programs, from the trajectories): docs/policies.md, "UMANS' examples".
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
out="${1:-$repo/build/compare-umans}"
umans_script="$repo/../shared/reference/umans/build-umans.sh"
umans="$(bash "$umans_script" | tail -n 1)"
ch="${CROWDHEALTH:-$repo/build/bin/crowdhealth}"
if [ ! -x "$ch" ]; then
  cmake -S "$repo" -B "$repo/build" -DCMAKE_BUILD_TYPE=Release > /dev/null
  cmake --build "$repo/build" -j2 --target crowdhealth_cli
fi
extra=()
for a in ${CH_ARGS:-}; do extra+=(--ch-arg="$a"); done
exec python3 "$repo/scripts/compare_umans.py" --examples "${EXAMPLES:-$repo/../shared/umans-examples}" \
  --umans "$umans" --crowdhealth "$ch" --out "$out" --jobs "${JOBS:-2}" --timeout "${TIMEOUT:-600}" \
  --only "${ONLY:-}" ${REUSE:+--reuse} "${extra[@]}"
