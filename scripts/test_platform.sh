#!/usr/bin/env bash
# Builds and tests flexcloud on another Debian release, in a chroot made from Debian's archive:
# the stand-in for ROS Noetic on Ubuntu 20.04 (GCC 9-10, CMake 3.16-3.18, Ceres 1.14, Eigen 3.3,
# PCL 1.10-1.11, PROJ 6-7, glibc 2.31). Ends with the line "N passed, N failed".
#   scripts/test_platform.sh bullseye    Debian 11: the whole package (the ROS layer included),
#                                        the unit tests, the offline tool's end-to-end tests and
#                                        the node's rostest (live.test)
# The chroot is made once with debootstrap and kept (FLEXCLOUD_PLATFORM_CACHE, default
# /var/cache/flexcloud) until scripts/deps.txt changes; its compiles go through a ccache of its
# own there. Needs root.
set -uo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

usage="usage: scripts/test_platform.sh bullseye"
usage_or_help "${usage}" "${1:-}"
release="$1"
case "${release}" in
  bullseye) ;;
  *) echo "scripts/test_platform.sh: ${release}: not a platform it knows (${usage#usage: })" >&2; exit 2 ;;
esac

fail() { log "$1"; echo "0 passed, 1 failed"; exit 1; }
[ "$(id -u)" -eq 0 ] || fail "scripts/test_platform.sh makes a chroot: run it as root"

# What is not run on the platform, and why: said, not skipped silently.
log "${release}: not run there: the sanitizer and ThreadSanitizer builds and the fuzzers (built" \
    "with clang 14, which Debian 11 does not ship), rviz and the screenshots (no display" \
    "there), the README and packaging tests (scripts/test.sh runs them on this machine)"

# Debian 11's names of the packages of scripts/deps.txt, without those of what is not run there.
platform_packages() {
  local p
  for p in $(grep -v '^#' "${FLEXCLOUD_ROOT}/scripts/deps.txt"); do
    case "${p}" in
      libgeographiclib-dev) echo libgeographic-dev ;;
      clang-14 | libfuzzer-14-dev | libclang-rt-14-dev | rviz | librviz-dev | xvfb | \
        imagemagick | x11-apps | nodejs | npm | clang-format | libbenchmark-dev | \
        catkin-lint | debootstrap | python3-xmlrunner) ;;
      *) echo "${p}" ;;
    esac
  done
}

cache="${FLEXCLOUD_PLATFORM_CACHE:-/var/cache/flexcloud}"
packages="$(platform_packages | sort -u | tr '\n' ' ')"
key="$(printf '%s %s' "${release}" "${packages}" | sha256sum | cut -c1-12)"
root="${cache}/${release}-${key}"
mounts=()
cleanup() {
  local m
  for ((m = ${#mounts[@]} - 1; m >= 0; m--)); do umount -l "${mounts[m]}" 2>/dev/null || true; done
}
trap cleanup EXIT
bind() {  # bind SOURCE TARGET [ro]
  mkdir -p "$2"
  mount --bind "$1" "$2" && mounts+=("$2") || return 1
  [ "${3:-}" = ro ] && mount -o remount,bind,ro "$2"
  return 0
}

# The chroot: made in a folder of its own and moved into place whole, so an interrupted run
# leaves nothing that looks ready. Older chroots of this release go.
if [ ! -f "${root}/.ready" ]; then
  command -v debootstrap > /dev/null || { DEBIAN_FRONTEND=noninteractive apt-get install -y -q \
    debootstrap >&2 || fail "debootstrap could not be installed"; }
  mkdir -p "${cache}"
  rm -rf "${cache:?}/${release}-"*
  staging="${cache}/.${release}-${key}.partial"
  rm -rf "${staging}"
  log "${release}: making the chroot in ${root} (debootstrap, then $(wc -w <<< "${packages}") packages)"
  debootstrap --variant=minbase "${release}" "${staging}" http://deb.debian.org/debian >&2 ||
    fail "debootstrap ${release} failed"
  cp /etc/resolv.conf "${staging}/etc/resolv.conf"
  mount -t proc proc "${staging}/proc" && mounts+=("${staging}/proc")
  bind /dev "${staging}/dev" && bind /dev/pts "${staging}/dev/pts"
  chroot "${staging}" bash -c "apt-get update -q && DEBIAN_FRONTEND=noninteractive \
    apt-get install -y -q --no-install-recommends ${packages}" >&2 ||
    fail "installing the packages into the ${release} chroot failed"
  cleanup
  mounts=()
  touch "${staging}/.ready"
  mv "${staging}" "${root}"
fi

# The repository read-only at /repo, the real drives beside it at /shared, a workspace and a
# ccache of the platform's own.
results="${FLEXCLOUD_ROOT}/out/test_results/platform-${release}"
rm -rf "${results}"
mkdir -p "${results}" "${cache}/ccache-${release}" "${cache}/ws-${release}"
cp /etc/resolv.conf "${root}/etc/resolv.conf"
cp /etc/hosts "${root}/etc/hosts"  # rostest resolves localhost
mount -t proc proc "${root}/proc" && mounts+=("${root}/proc")
bind /dev "${root}/dev" && bind /dev/pts "${root}/dev/pts"
bind "${FLEXCLOUD_ROOT}" "${root}/repo" ro || fail "could not mount the repository in the chroot"
shared="$(dirname "${FLEXCLOUD_ROOT}")/shared"
[ -d "${shared}" ] && bind "${shared}" "${root}/shared" ro
bind "${cache}/ccache-${release}" "${root}/ccache"
bind "${cache}/ws-${release}" "${root}/ws"
bind "${results}" "${root}/results"

log "${release}: building and testing (log: ${results}/run.log)"
chroot "${root}" /usr/bin/env -i PATH=/usr/bin:/bin:/usr/sbin:/sbin HOME=/root LANG=C.UTF-8 \
  CCACHE_DIR=/ccache CCACHE_BASEDIR=/repo CCACHE_NOHASHDIR=1 bash /repo/scripts/platform_run.sh \
  > "${results}/run.log" 2>&1
rc=$?
grep -E "^\[platform\]" "${results}/run.log" >&2 || true

# The same tool runs on this machine's build (scripts/test.sh's), held against the platform's.
here_bin="${FLEXCLOUD_WS}/devel/lib/flexcloud"
if [ -x "${here_bin}/georeference" ] && [ -d "${results}/tool/drive" ]; then
  here="$(mktemp -d)"
  "${here_bin}/simulate_drive" --out "${here}/drive" --seed 4 --length 2000 --map-points 20000 \
    > /dev/null 2>&1
  for run in defaults:fusion=true fusion_false:fusion=false; do
    "${here_bin}/georeference" --gnss "${here}/drive/gnss.txt" --poses \
      "${here}/drive/slam_trajectory.txt" --map "${here}/drive/map.pcd" --datum 48.262 11.667 480 \
      --set "${run#*:}" --set report_png=false -q --out "${here}/${run%%:*}" > /dev/null 2>&1
  done
  python3 "${FLEXCLOUD_ROOT}/scripts/compare_platforms.py" "${here}" "${results}/tool" \
    "${results}/platform_outputs.xml" 0.001 >&2
  rm -rf "${here}"
else
  log "${release}: no build of this machine's to hold the tool's outputs against (scripts/build.sh)"
fi
record_exit "${rc}" "platform-${release}" "${results}" "${results}/run.log"
python3 "${FLEXCLOUD_ROOT}/scripts/count_results.py" "${results}"
