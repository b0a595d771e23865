#!/usr/bin/env bash
# The check before a release: the test suite N times in a row; each test that failed in any run.
#   bash scripts/stress_tests.sh 5                    # five runs of `python -m pytest -q`
#   bash scripts/stress_tests.sh 3 --hog              # three, with one core kept busy beside them
#   bash scripts/stress_tests.sh 2 -- tests/serve -x  # after --: pytest's arguments for every run
# --hog starts one busy process (a shell loop) before the first run and kills it, by its process id,
# when the script ends (also on Ctrl-C; on SIGTERM once the run in progress has ended). Each run's
# output is kept in the log folder (RAP_STRESS_LOGS, else a new one under /tmp); each failed test is
# read from pytest's short test summary (-rfE: its `FAILED`/`ERROR` lines). Prints one line per run,
# then each test that failed with the runs it failed in. Exit status: 0 when every run passed, 1
# otherwise, 2 for bad usage.
set -euo pipefail
cd "$(dirname "$0")/.."

usage() { sed -n '2,5p' "$0" >&2; exit 2; }
[ $# -ge 1 ] || usage
runs=$1
shift
[[ "$runs" =~ ^[1-9][0-9]*$ ]] || usage
hog=0
pytest_args=()
while [ $# -gt 0 ]; do
  case "$1" in
    --hog) hog=1 ;;
    --) shift; pytest_args=("$@"); break ;;
    *) usage ;;
  esac
  shift
done

logs=${RAP_STRESS_LOGS:-$(mktemp -d /tmp/rap-stress-XXXXXX)}
mkdir -p "$logs"
hog_pid=""
stop_hog() {
  if [ -n "$hog_pid" ]; then
    kill "$hog_pid" 2>/dev/null || true
    wait "$hog_pid" 2>/dev/null || true
    hog_pid=""
  fi
}
trap stop_hog EXIT
trap 'stop_hog; exit 130' INT TERM
if [ "$hog" = 1 ]; then
  sh -c 'while :; do :; done' &
  hog_pid=$!
  echo "hog: process $hog_pid keeps one core busy"
fi

failed_runs=0
: > "$logs/failures"
for i in $(seq 1 "$runs"); do
  log="$logs/run-$i.log"
  start=$(date +%s)
  status=0
  python -m pytest -q -rfE "${pytest_args[@]}" > "$log" 2>&1 || status=$?
  seconds=$(( $(date +%s) - start ))
  # the short test summary's lines: "FAILED tests/x.py::test_y[id] - why", "ERROR tests/x.py::..."
  named=$( (grep -E '^(FAILED|ERROR) ' "$log" || true) | sed -E 's/^(FAILED|ERROR) //; s/ - .*$//' \
           | sort -u)
  if [ -n "$named" ]; then
    printf '%s\n' "$named" | sed "s/^/$i\t/" >> "$logs/failures"
  elif [ "$status" != 0 ]; then  # no test to name: a collection error, a crash, a timeout
    printf '%s\t%s\n' "$i" "(the run itself: pytest exited $status, see $log)" >> "$logs/failures"
  fi
  echo "run $i/$runs: exit $status in ${seconds} s: $(tail -n 1 "$log")"
  if [ "$status" != 0 ]; then
    failed_runs=$((failed_runs + 1))
  fi
done
stop_hog

busy=""
[ "$hog" = 1 ] && busy=" (one core kept busy)"
echo "$((runs - failed_runs)) of $runs runs passed$busy; logs in $logs"
if [ -s "$logs/failures" ]; then
  echo "failed in some run:"
  sort -t $'\t' -k2,2 -k1,1n "$logs/failures" \
    | awk -F '\t' '{ if ($2 in runs) runs[$2] = runs[$2] "," $1
                     else { runs[$2] = $1; order[n++] = $2 } }
                   END { for (k = 0; k < n; k++) print "  " order[k] "  (run " runs[order[k]] ")" }'
fi
[ "$failed_runs" = 0 ]
