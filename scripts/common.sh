# Shared by the scripts: paths, a clean PATH for the ROS tools, the workspace build.
# Debian's ROS tools need Debian's python3 (a pyenv or conda python3 first on PATH breaks catkin).
export PATH="/usr/bin:/bin:/usr/sbin:/sbin:${PATH}"
unset PYTHONPATH PYTHONHOME VIRTUAL_ENV CONDA_PREFIX
FLEXCLOUD_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
FLEXCLOUD_WS="${FLEXCLOUD_WS:-${FLEXCLOUD_ROOT}/.ws}"
FLEXCLOUD_BUILD_TYPE="${FLEXCLOUD_BUILD_TYPE:-Release}"
export FLEXCLOUD_ROOT FLEXCLOUD_WS

log() { printf '[flexcloud] %s\n' "$*" >&2; }

# catkin caches how its setup script changes the environment at configure time; configured in a
# shell that already sourced a setup file, the cache comes out empty and later runs from a clean
# shell cannot find the package. The scripts therefore configure without any ROS environment.
clean_ros_env() {
  unset ROS_PACKAGE_PATH ROS_DISTRO ROS_ETC_DIR ROS_PYTHON_VERSION ROS_VERSION ROS_ROOT \
        CMAKE_PREFIX_PATH PKG_CONFIG_PATH
}

# Makes the workspace (src/flexcloud -> the repository) and runs catkin_make in it.
build_workspace() {
  clean_ros_env
  mkdir -p "${FLEXCLOUD_WS}/src"
  if [ ! -e "${FLEXCLOUD_WS}/src/flexcloud" ]; then
    ln -s "${FLEXCLOUD_ROOT}" "${FLEXCLOUD_WS}/src/flexcloud"
  fi
  local jobs
  jobs="$(nproc)"
  log "building in ${FLEXCLOUD_WS} (${FLEXCLOUD_BUILD_TYPE}, ${jobs} jobs)"
  (cd "${FLEXCLOUD_WS}" && catkin_make -j"${jobs}" \
      -DCMAKE_BUILD_TYPE="${FLEXCLOUD_BUILD_TYPE}" \
      -DPYTHON_EXECUTABLE=/usr/bin/python3 "$@" >&2)
}

# Runs a command inside the workspace's ROS environment.
in_workspace() {
  # shellcheck disable=SC1091
  set +u
  source "${FLEXCLOUD_WS}/devel/setup.bash"
  set -u
  "$@"
}

# Installs the missing Debian packages of scripts/deps.txt; quick when nothing is missing.
install_deps() {
  local wanted missing=()
  wanted="$(grep -v '^#' "${FLEXCLOUD_ROOT}/scripts/deps.txt" | tr -s ' \n' ' ')"
  for pkg in ${wanted}; do
    dpkg-query -W -f='${Status}' "${pkg}" 2>/dev/null | grep -q "install ok installed" \
      || missing+=("${pkg}")
  done
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
