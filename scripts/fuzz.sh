#!/usr/bin/env bash
# Fuzzes the scenario loader and the readers of run folders with libFuzzer (clang), under
# AddressSanitizer and UndefinedBehaviorSanitizer. docs/development.md explains it.
#
#   scripts/fuzz.sh [SECONDS] [TARGET]    SECONDS per target (default 60); TARGET: loader or
#                                         readers (default: both, one after the other)
#
# Installs clang, libFuzzer and clang's OpenMP when missing; builds build-fuzz/; seeds each corpus
# (fuzz-corpus/TARGET/, kept between runs) with every scenario of Examples/, Tests/data/ and
# ../shared/umans-examples/ (the files a scenario names appended after "--FILE--" lines) or with
# the outputs of a short run; writes the dictionary from the registry. A crash, a sanitizer
# report, a hang (> 10 s per input) or an allocation over 2 GiB saves the reproducer to
# fuzz-artifacts/TARGET/, copies it into Tests/fuzz/regressions/TARGET/ (replayed by
# fuzz_regressions_test) and makes the script exit 1.
set -euo pipefail
cd "$(dirname "$0")/.."

SECONDS_PER_TARGET="${1:-60}"
TARGETS=(loader readers)
if [ "$#" -ge 2 ]; then
  case "$2" in
    loader|readers) TARGETS=("$2") ;;
    *) echo "fuzz.sh: error: unknown target '$2' (loader, readers)" >&2; exit 2 ;;
  esac
fi
if ! [[ "$SECONDS_PER_TARGET" =~ ^[0-9]+$ ]] || [ "$SECONDS_PER_TARGET" -lt 1 ]; then
  echo "fuzz.sh: error: SECONDS must be a whole number of seconds, got '$SECONDS_PER_TARGET'" >&2
  exit 2
fi

# The project's own packages plus clang, libFuzzer and clang's OpenMP (setup.sh installs them).
EXTRA_PACKAGES="clang libfuzzer-14-dev libomp-14-dev python3" SETUP_ONLY_PACKAGES=1 scripts/setup.sh

JOBS="${JOBS:-$(nproc)}"
CC=clang CXX=clang++ cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCROWDHEALTH_FUZZ=ON > build-fuzz.log
cmake --build build-fuzz -j "$JOBS" >> build-fuzz.log || { tail -30 build-fuzz.log; exit 1; }
rm -f build-fuzz.log

mkdir -p fuzz-corpus fuzz-artifacts
build-fuzz/bin/fuzz_dictionary > fuzz-corpus/loader.dict

# Seeds. Loader: each scenario, with the files it names appended as inc1.xml … (file= rewritten;
# a .dxf or .wkt file keeps its extension: the harness writes every named file under all three).
python3 - "$PWD" <<'PY'
import os, re, sys, glob, hashlib
root = sys.argv[1]
out = os.path.join(root, "fuzz-corpus", "loader")
os.makedirs(out, exist_ok=True)
files = []
for pattern in ("Examples/**/*.xml", "Tests/data/**/*.xml", "../shared/umans-examples/**/*.xml"):
    files += glob.glob(os.path.join(root, pattern), recursive=True)
for path in sorted(set(files)):
    try:
        text = open(path, encoding="utf-8", errors="replace").read()
    except OSError:
        continue
    parts = [text]
    def include(m):
        name = m.group(2)
        target = os.path.normpath(os.path.join(os.path.dirname(path), name))
        if len(parts) >= 4 or not os.path.isfile(target):
            return m.group(0)
        parts.append(open(target, encoding="utf-8", errors="replace").read())
        ext = os.path.splitext(name)[1].lower()  # .dxf and .wkt keep their reader
        return '%sfile="inc%d%s"' % (m.group(1), len(parts) - 1, ext if ext in (".dxf", ".wkt") else ".xml")
    parts[0] = re.sub(r'(\s)file="([^"]*)"', include, text)
    data = "\n--FILE--\n".join(parts).encode()
    if len(data) > 200000:
        continue
    open(os.path.join(out, hashlib.sha1(data).hexdigest()), "wb").write(data)
PY
# Readers: the outputs of a short run (binary and text trajectories, UMANS csv, run folder files).
if [ ! -d fuzz-corpus/readers ] || [ -z "$(ls -A fuzz-corpus/readers 2>/dev/null)" ]; then
  mkdir -p fuzz-corpus/readers
  tmp="$(mktemp -d)"
  scripts/setup.sh > /dev/null
  build/bin/crowdhealth -i Tests/data/cli/doorway-small.xml -o "$tmp/run" --end-time 3 -q \
    --trajectories txt,bin,umans > /dev/null
  python3 - "$tmp/run" fuzz-corpus/readers <<'PY'
import os, sys, glob
run, out = sys.argv[1], sys.argv[2]
def read(name):
    p = os.path.join(run, name)
    return open(p, "rb").read() if os.path.exists(p) else b""
umans = sorted(glob.glob(os.path.join(run, "output_*.csv")))
first = open(umans[0], "rb").read() if umans else b""
parts = [read("trajectories.bin"), read("trajectories.txt"), first, read("metrics.csv"),
         read("summary.json"), read("health.csv"), read("heatmap.csv")]
open(os.path.join(out, "run"), "wb").write(b"\n--FILE--\n".join(parts))
open(os.path.join(out, "empty"), "wb").write(b"")
PY
  rm -rf "$tmp"
fi

status=0
for target in "${TARGETS[@]}"; do
  mkdir -p "fuzz-artifacts/$target" "Tests/fuzz/regressions/$target"
  dict=()
  if [ "$target" = loader ]; then dict=(-dict=fuzz-corpus/loader.dict); fi
  echo "fuzz: $target for $SECONDS_PER_TARGET s (corpus fuzz-corpus/$target, $(ls fuzz-corpus/$target | wc -l) inputs)"
  set +e
  ASAN_OPTIONS="detect_leaks=1:abort_on_error=1${ASAN_OPTIONS:+:$ASAN_OPTIONS}" \
  UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1${UBSAN_OPTIONS:+:$UBSAN_OPTIONS}" \
  OMP_NUM_THREADS=1 \
    "build-fuzz/bin/fuzz_$target" "fuzz-corpus/$target" "${dict[@]}" \
      -max_total_time="$SECONDS_PER_TARGET" -timeout=10 -rss_limit_mb=2048 -max_len=65536 \
      -artifact_prefix="fuzz-artifacts/$target/" -print_final_stats=1 2> "fuzz-artifacts/$target.log"
  rc=$?
  set -e
  grep -E "^stat::number_of_executed_units|^stat::peak_rss_mb|^#[0-9]+.*DONE" "fuzz-artifacts/$target.log" || true
  if [ "$rc" -ne 0 ]; then
    status=1
    echo "fuzz: $target FAILED (exit $rc); the report is in fuzz-artifacts/$target.log" >&2
    grep -E "ERROR|SUMMARY|runtime error|Test unit written" "fuzz-artifacts/$target.log" | head -20 >&2 || true
    for f in fuzz-artifacts/"$target"/*; do
      [ -f "$f" ] || continue
      cp "$f" "Tests/fuzz/regressions/$target/$(basename "$f")"
      echo "fuzz: reproducer saved as Tests/fuzz/regressions/$target/$(basename "$f")" >&2
    done
  else
    echo "fuzz: $target clean"
  fi
done
exit "$status"
