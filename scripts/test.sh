#!/usr/bin/env bash
# Installs what is missing, builds and runs the tests; ends with the line "N passed, N failed"
# and exits non-zero on any failure.
#   scripts/test.sh              every test: the suite (unit, end-to-end, rostests), the unit and
#                                end-to-end tests again under ASan + UBSan, the node's threads
#                                under ThreadSanitizer (races.test), and each fuzz target for
#                                FUZZ_SECONDS (default 20)
#   scripts/test.sh --quick      the suite only
#   scripts/test.sh --sanitize   the sanitizer runs only (ASan + UBSan, ThreadSanitizer)
#   scripts/test.sh --fuzz [S]   the fuzz targets only, S seconds each (default 20)
set -uo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

suite=1 sanitize=1 fuzz=1
fuzz_seconds="${FUZZ_SECONDS:-20}"
case "${1:-}" in
  "") ;;
  --quick) sanitize=0 fuzz=0 ;;
  --sanitize) suite=0 fuzz=0 ;;
  --fuzz) suite=0 sanitize=0; fuzz_seconds="${2:-${fuzz_seconds}}" ;;
  -h|--help) sed -n '2,10p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'; exit 0 ;;
  *) echo "usage: scripts/test.sh [--quick | --sanitize | --fuzz [SECONDS]]" >&2; exit 2 ;;
esac

fail() { log "$1"; echo "0 passed, 1 failed"; exit 1; }
install_deps || fail "installing the dependencies failed"
# Results, logs and any fuzz finding stay in out/test_results (git-ignored) until the next run.
results="${FLEXCLOUD_ROOT}/out/test_results"
rm -rf "${results}"
mkdir -p "${results}"

if [ "${suite}" = 1 ]; then
  build_workspace || fail "build failed"
  rm -rf "${FLEXCLOUD_WS}/build/test_results"
  run_log="${FLEXCLOUD_WS}/run_tests.log"
  log "running the tests (log: ${run_log})"
  # catkin_make run_tests exits 0 even when tests fail: the result files decide. It runs inside
  # the workspace's environment, so rostest finds the package whatever the configure-time cache.
  (cd "${FLEXCLOUD_WS}" && in_workspace catkin_make run_tests -j"$(nproc)" \
      -DCMAKE_BUILD_TYPE="${FLEXCLOUD_BUILD_TYPE}" "${CCACHE_ARGS[@]}" \
      -DPYTHON_EXECUTABLE=/usr/bin/python3) \
      > "${run_log}" 2>&1
  grep -E "^(loop|open|a2rl|outage|3 )" "${run_log}" >&2 || true
  cp -r "${FLEXCLOUD_WS}/build/test_results" "${results}/suite" 2>/dev/null || true
  # The README's commands as typed (with a catkin workspace and an install space of their own),
  # the packages the commands come from, the source format.
  install_test_readers || fail "the tests' LAS reader could not be installed"
  log "running the README, packaging and format tests (log: ${results}/scripts.log)"
  (cd "${FLEXCLOUD_ROOT}/test/scripts" && \
    /usr/bin/python3 -m xmlrunner discover -p 'test_*.py' -o "${results}/scripts") \
    > "${results}/scripts.log" 2>&1
  record_exit "$?" "scripts" "${results}/scripts" "${results}/scripts.log"
fi

if [ "${sanitize}" = 1 ] || [ "${fuzz}" = 1 ]; then
  build_sanitize_workspace || fail "the sanitizer build failed"
fi

if [ "${sanitize}" = 1 ]; then
  mkdir -p "${results}/sanitize"
  # The accuracy tests (the targets on three seeds of seven drives, the simulated drives' map
  # error, the urban and lever-arm drives) run the same code as the other end-to-end tests and
  # took most of the sanitizer run's time: they run in the suite only; so do the tool's runs on
  # ascii and compressed maps, whose readers the unit tests and fuzz_pcd take through ASan, and
  # the real drive's study (A2rl.*: a minute under ASan, the fusion's code the BadInput and
  # SimulatedDrive tests take through it too). The unit and end-to-end binaries run side by side.
  # The clock and revisit figures (Clock.*, Revisits.*) are accuracy bounds of the suite's
  # compiler: the sanitizer's compiler rounds differently, and on two drives the run takes
  # another branch (urban_keyframes_1hz seed 2: clock off by 41 ms instead of 6 ms). The second
  # real drive (Monza.*) is left to the suite like A2rl.*, and so are the KITTI drives against
  # their truth (TruthDrives.*: 70 runs) and a fusion held far too stiff
  # (SimulatedDrive.AFusionHeldFarTooStiff*: six runs). The tool's runs stopped by a signal in
  # the middle of a map of millions of points (Tools.AnInterruptedWarp*, Tools.AKilledRun*) test
  # the process, not the memory: they took seven of the sanitizer run's fourteen minutes.
  SANITIZE_FILTER="-Targets/Accuracy.*:AccuracyMore.*:SimulatedDrive.*AgainstTheTruth:A2rl.*"
  SANITIZE_FILTER+=":SimulatedDrive.AFusionHeldFarTooStiff*"
  SANITIZE_FILTER+=":Tools.AnInterruptedWarp*:Tools.AKilledRun*"
  SANITIZE_FILTER+=":Tools.AsciiMaps*:Tools.CompressedMaps*:Scenarios/SlamFailures.*"
  SANITIZE_FILTER+=":Clock.*:Revisits.*:GnssLateAndEarly.*:Monza.*:TruthDrives.*:MulranDrives.*"
  SANITIZE_FILTER+=":SigmaCalibration.*:TruthMaps.*"
  for t in flexcloud_unit_tests flexcloud_e2e_tests; do
    log "running ${t} under AddressSanitizer and UndefinedBehaviorSanitizer"
    (ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
      "${FLEXCLOUD_SAN_WS}/devel/lib/flexcloud/${t}" \
      --gtest_output="xml:${results}/sanitize/sanitize-${t}.xml" --gtest_filter="${SANITIZE_FILTER}" \
      > "${results}/sanitize/${t}.log" 2>&1
    # A sanitizer report aborts the binary: record it as a failure if gtest could not.
    record_exit "$?" "sanitize-${t}" "${results}/sanitize" "${results}/sanitize/${t}.log") &
  done
  wait
fi

if [ "${sanitize}" = 1 ]; then
  build_tsan_workspace || fail "the ThreadSanitizer build failed"
  run_tsan_races "${results}/tsan"
fi

if [ "${fuzz}" = 1 ]; then
  run_fuzzers "${fuzz_seconds}" "${results}/fuzz"
fi

python3 "${FLEXCLOUD_ROOT}/scripts/count_results.py" "${results}"
