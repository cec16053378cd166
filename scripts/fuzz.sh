#!/usr/bin/env bash
# Fuzzes the text readers, the pipeline, the PCD reader and the bag reader with libFuzzer (clang,
# ASan + UBSan), each for SECONDS (default 600). Findings are kept in OUT (default out/fuzz).
#   scripts/fuzz.sh [SECONDS] [OUT]
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
case "${1:-}" in
  -h|--help) sed -n '2,4p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'; exit 0 ;;
esac
seconds="${1:-600}"
out="${2:-${FLEXCLOUD_ROOT}/out/fuzz}"
install_deps
build_sanitize_workspace
run_fuzzers "${seconds}" "${out}"
python3 "${FLEXCLOUD_ROOT}/scripts/count_results.py" "${out}"
