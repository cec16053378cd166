#!/usr/bin/env bash
# Installs whatever of scripts/deps.txt is missing (as root, from Debian's archive).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
install_deps
