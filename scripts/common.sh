# Shared by the scripts: paths, a clean PATH for the ROS tools, the workspace build.
# Debian's ROS tools need Debian's python3 (a pyenv or conda python3 first on PATH breaks catkin).
export PATH="/usr/bin:/bin:/usr/sbin:/sbin:${PATH}"
unset PYTHONPATH PYTHONHOME VIRTUAL_ENV CONDA_PREFIX
FLEXCLOUD_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
FLEXCLOUD_WS="${FLEXCLOUD_WS:-${FLEXCLOUD_ROOT}/.ws}"
FLEXCLOUD_BUILD_TYPE="${FLEXCLOUD_BUILD_TYPE:-Release}"
export FLEXCLOUD_ROOT FLEXCLOUD_WS

log() { printf '[flexcloud] %s\n' "$*" >&2; }

# usage_or_help USAGE ARG: without ARG, prints USAGE on stderr and exits 2; with -h or --help,
# prints it on stdout and exits 0; otherwise returns.
usage_or_help() {
  case "$2" in
    "") echo "$1" >&2; exit 2 ;;
    -h|--help) echo "$1"; exit 0 ;;
  esac
}

# Compiles go through ccache. Paths under the repository are hashed relative to the build folder,
# so a clone elsewhere, or a catkin workspace of the same shape, reuses what was compiled before.
export CCACHE_BASEDIR="${CCACHE_BASEDIR:-${FLEXCLOUD_ROOT}}" CCACHE_NOHASHDIR=1
CCACHE_ARGS=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)

# catkin caches how its setup script changes the environment at configure time; configured in a
# shell that already sourced a setup file, the cache comes out empty and later runs from a clean
# shell cannot find the package. The scripts therefore configure without any ROS environment.
clean_ros_env() {
  unset ROS_PACKAGE_PATH ROS_DISTRO ROS_ETC_DIR ROS_PYTHON_VERSION ROS_VERSION ROS_ROOT \
        CMAKE_PREFIX_PATH PKG_CONFIG_PATH
}

# The package as the workspace sees it: a folder of links to the repository's top-level entries,
# except the workspaces and outputs. A plain link to the repository would hold the workspace
# itself, and `rosrun` (which searches the package folder with `find -L`) would then meet a
# file-system loop and every built executable twice.
link_package() {
  local view="$1/src/flexcloud" entry name
  [ -L "${view}" ] && rm -f "${view}"
  mkdir -p "${view}"
  for entry in "${FLEXCLOUD_ROOT}"/* "${FLEXCLOUD_ROOT}"/.clang-format; do
    name="$(basename "${entry}")"
    case "${name}" in out|.ws|.ws-*|.git) continue ;; esac
    # Idempotent, so that several scripts running at once (a launch and a service call) agree.
    [ -e "${entry}" ] && [ "$(readlink "${view}/${name}")" != "${entry}" ] && \
      { ln -sfn "${entry}" "${view}/${name}" 2>/dev/null || true; }
  done
  find "${view}" -mindepth 1 -maxdepth 1 -xtype l -delete 2>/dev/null || true
}

# Makes the workspace (src/flexcloud: see link_package) and runs catkin_make in it.
build_workspace() {
  clean_ros_env
  link_package "${FLEXCLOUD_WS}"
  local jobs
  jobs="$(nproc)"
  log "building in ${FLEXCLOUD_WS} (${FLEXCLOUD_BUILD_TYPE}, ${jobs} jobs)"
  (cd "${FLEXCLOUD_WS}" && catkin_make -j"${jobs}" \
      -DCMAKE_BUILD_TYPE="${FLEXCLOUD_BUILD_TYPE}" "${CCACHE_ARGS[@]}" \
      -DPYTHON_EXECUTABLE=/usr/bin/python3 "$@" >&2)
}

# Runs a command inside the workspace's ROS environment. catkin's setup script reads the
# positional parameters of whoever sources it: they are cleared before, and restored after.
in_workspace() {
  local command=("$@")
  set --
  # shellcheck disable=SC1091
  set +u
  source "${FLEXCLOUD_WS}/devel/setup.bash"
  set -u
  "${command[@]}"
}

# Installs the missing Debian packages of scripts/deps.txt; quick when nothing is missing.
install_deps() {
  local wanted missing=()
  wanted="$(grep -v '^#' "${FLEXCLOUD_ROOT}/scripts/deps.txt" | tr -s ' \n' ' ')"
  for pkg in ${wanted}; do
    dpkg-query -W -f='${Status}' "${pkg}" 2>/dev/null | grep -q "install ok installed" \
      || missing+=("${pkg}")
  done
  # npm comes with nodejs from some archives and as a package of its own from Debian's.
  command -v npm > /dev/null 2>&1 || missing+=(npm)
  [ "${#missing[@]}" -eq 0 ] && return 0
  log "installing ${#missing[@]} Debian packages: ${missing[*]}"
  if [ "$(id -u)" -ne 0 ]; then
    log "not root: run as root, or install them with: sudo apt-get install ${missing[*]}"
    return 1
  fi
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -q >&2
  apt-get install -y -q --no-install-recommends "${missing[@]}" >&2
}

# The npm packages of the tests' independent LAS reader (test/las) in out/las_reader, installed
# once (npm reaches its registry; the tests themselves never install anything).
install_test_readers() {
  local folder="${FLEXCLOUD_ROOT}/out/las_reader"
  mkdir -p "${folder}"
  cp "${FLEXCLOUD_ROOT}/test/las/package.json" "${FLEXCLOUD_ROOT}/test/las/read_las.mjs" "${folder}/"
  [ -d "${folder}/node_modules/@loaders.gl/las" ] && return 0
  log "installing the test's LAS reader (npm: @loaders.gl/las) into ${folder}"
  npm install --no-audit --no-fund --prefix "${folder}" >&2
}

# The instrumented workspace: clang-14 with AddressSanitizer, UndefinedBehaviorSanitizer and
# libFuzzer coverage; builds the unit and end-to-end tests, the tools and the fuzz targets.
FLEXCLOUD_SAN_WS="${FLEXCLOUD_SAN_WS:-${FLEXCLOUD_ROOT}/.ws-sanitize}"
build_sanitize_workspace() {
  clean_ros_env
  link_package "${FLEXCLOUD_SAN_WS}"
  # CMake keeps the compiler of the first configure: start over if it was not clang.
  local cache="${FLEXCLOUD_SAN_WS}/build/CMakeCache.txt"
  if [ -f "${cache}" ] && ! grep -q "CMAKE_CXX_COMPILER:.*clang" "${cache}"; then
    rm -rf "${FLEXCLOUD_SAN_WS}/build" "${FLEXCLOUD_SAN_WS}/devel"
  fi
  log "building the sanitizer and fuzz workspace in ${FLEXCLOUD_SAN_WS}"
  (cd "${FLEXCLOUD_SAN_WS}" && CC=clang-14 CXX=clang++-14 catkin_make -j"$(nproc)" \
      -DCMAKE_BUILD_TYPE=RelWithDebInfo -DFLEXCLOUD_FUZZ=ON -DCATKIN_ENABLE_TESTING=ON \
      "${CCACHE_ARGS[@]}" \
      -DPYTHON_EXECUTABLE=/usr/bin/python3 \
      flexcloud_unit_tests flexcloud_e2e_tests georeference simulate_drive \
      fuzz_text fuzz_pipeline fuzz_pcd fuzz_bag >&2)
}

# The ThreadSanitizer workspace: clang-14 with -fsanitize=thread; builds the node and the
# rostests' binary (test/ros/races.test runs the two against each other).
FLEXCLOUD_TSAN_WS="${FLEXCLOUD_TSAN_WS:-${FLEXCLOUD_ROOT}/.ws-tsan}"
build_tsan_workspace() {
  clean_ros_env
  link_package "${FLEXCLOUD_TSAN_WS}"
  log "building the ThreadSanitizer workspace in ${FLEXCLOUD_TSAN_WS}"
  (cd "${FLEXCLOUD_TSAN_WS}" && CC=clang-14 CXX=clang++-14 catkin_make -j"$(nproc)" \
      -DCMAKE_BUILD_TYPE=RelWithDebInfo -DFLEXCLOUD_TSAN=ON -DCATKIN_ENABLE_TESTING=ON \
      "${CCACHE_ARGS[@]}" -DPYTHON_EXECUTABLE=/usr/bin/python3 \
      georeference_node flexcloud_ros_tests >&2)
}

# record_exit RC NAME DIR LOG: a run that exited non-zero without a failure in its result files
# (it crashed, or could not start) is recorded as one failed case, so it cannot pass unseen.
record_exit() {
  [ "$1" -eq 0 ] && return 0
  mkdir -p "$3"
  grep -qs -e "<failure" -e "<error" "$3"/*.xml && return 0
  tail -40 "$4" >&2
  printf '<testsuite><testcase classname="%s" name="exit"><failure message="exit %s"/></testcase></testsuite>\n' \
    "$2" "$1" > "$3/$2-exit.xml"
}

# Runs test/ros/races.test with the node and the test built by build_tsan_workspace; writes its
# JUnit files into $1, and turns the reports on flexcloud's own code into failed cases
# (scripts/tsan_reports.py; the whole reports stay in $1/report.PID).
run_tsan_races() {
  local results="$1"
  mkdir -p "${results}"
  log "running races.test under ThreadSanitizer (log: ${results}/races.log)"
  (export ROS_TEST_RESULTS_DIR="${results}" ROS_LOG_DIR="${results}/ros_log" \
     TSAN_OPTIONS="log_path=${results}/report history_size=4" && \
   FLEXCLOUD_WS="${FLEXCLOUD_TSAN_WS}" in_workspace rostest flexcloud races.test) \
    > "${results}/races.log" 2>&1
  record_exit "$?" "tsan-races" "${results}/flexcloud" "${results}/races.log"
  python3 "${FLEXCLOUD_ROOT}/scripts/tsan_reports.py" "${results}" || true
}

# Runs every fuzz target for $1 seconds on a copy of its seed corpus; writes a JUnit file per
# target into $2. A crash, leak, timeout or sanitizer report fails the target and leaves the
# input that caused it in $2.
run_fuzzers() {
  local seconds="$1" results="$2" target work rc
  mkdir -p "${results}"
  for target in text pipeline pcd bag; do
    work="$(mktemp -d)"
    cp -r "${FLEXCLOUD_ROOT}/fuzz/corpus/${target}/." "${work}/"
    log "fuzzing ${target} for ${seconds} s"
    set +e
    ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
      "${FLEXCLOUD_SAN_WS}/devel/lib/flexcloud/fuzz_${target}" -max_total_time="${seconds}" \
      -rss_limit_mb=2048 -timeout=20 -print_final_stats=1 \
      -artifact_prefix="${results}/fuzz_${target}-" "${work}" > "${results}/fuzz_${target}.log" 2>&1
    rc=$?
    set -e
    python3 - "${results}/fuzz_${target}.xml" "${target}" "${rc}" "${results}/fuzz_${target}.log" <<'PY'
import sys, xml.sax.saxutils as x
path, target, rc, log = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
text = open(log, errors="replace").read()[-4000:]
fail = "" if rc == 0 else f'<failure message="fuzz_{target} exited {rc}">{x.escape(text)}</failure>'
open(path, "w").write(f'<testsuite name="fuzz" tests="1"><testcase classname="fuzz" name="{target}">'
                      f'{fail}<system-out>{x.escape(text)}</system-out></testcase></testsuite>\n')
PY
    grep -E "stat::number_of_executed_runs|stat::new_units_added" "${results}/fuzz_${target}.log" | \
      sed "s/^/[fuzz_${target}] /" >&2 || true
    rm -rf "${work}"
  done
}
