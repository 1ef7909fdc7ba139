#!/usr/bin/env bash
# Builds the fuzz preset and runs every libFuzzer target of fuzz/ for a bounded time, with ASan
# and UBSan, starting from the seeds scripts/fuzz_seeds.sh cuts from ../shared/data. Exits
# non-zero on any finding (crash, sanitizer report, leak, timeout, out-of-memory, or an exception
# other than the errors Kestrel reports to users: fuzz/fuzz_input.hpp).
#   KESTREL_FUZZ_SECONDS  time per target (default 30)
#   KESTREL_FUZZ_JOBS     targets run at once (default 2: the CI machine's cores)
# Corpora grow in build/fuzz/corpus/<target> (kept between runs); a finding's input is written to
# build/fuzz/findings/<target>/ and its log to build/fuzz/logs/<target>.log.
# Reproduce one: build/fuzz/fuzz/fuzz_<target> build/fuzz/findings/<target>/crash-...
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${KESTREL_FUZZ_SECONDS:-30}"
jobs="${KESTREL_FUZZ_JOBS:-2}"
start=$(date +%s)
scripts/build.sh fuzz
root="$PWD/build/fuzz"
scripts/fuzz_seeds.sh "$root/seeds" >/dev/null
mkdir -p "$root/corpus" "$root/findings" "$root/logs"

run_one() {
  local target="$1" seconds="$2" root="$3"
  local corpus="$root/corpus/$target" findings="$root/findings/$target" log="$root/logs/$target.log"
  mkdir -p "$corpus" "$findings"
  # -timeout: one input taking 10 s is a hang; -rss_limit_mb/-malloc_limit_mb: one input asking
  # for more than 2 GB is a finding (a header claiming a huge image, say).
  if UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 ASAN_OPTIONS=detect_leaks=1 \
     "$root/fuzz/fuzz_$target" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
       -malloc_limit_mb=2048 -max_len=16384 -print_final_stats=1 \
       -artifact_prefix="$findings/" "$corpus" "$root/seeds/$target" > "$log" 2>&1; then
    local done_line execs
    done_line=$(grep -E '^#[0-9]+[[:space:]]+DONE' "$log" | tail -n 1)
    execs=$(grep -E '^stat::number_of_executed_units' "$log" | awk '{print $2}')
    echo "fuzz: $target ok: $execs runs in ${seconds} s; ${done_line#*DONE}"
  else
    echo "fuzz: $target FAILED (log: $log; input: $findings/)" >&2
    grep -E 'ERROR|SUMMARY|terminate|what\(\)' "$log" | head -n 5 >&2
    return 1
  fi
}
export -f run_one

targets=$(cd "$root/fuzz" && ls fuzz_* | sed 's/^fuzz_//')
status=0
printf '%s\n' $targets | xargs -P "$jobs" -I{} bash -c 'run_one "$@"' _ {} "$seconds" "$root" \
  || status=1
echo "fuzz: $(echo $targets | wc -w) targets, ${seconds} s each, $jobs at once:" \
     "$( [ $status -eq 0 ] && echo 'no finding' || echo 'FINDINGS' ) in $(( $(date +%s) - start )) s"
exit $status
