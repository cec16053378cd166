#!/usr/bin/env bash
# The offline tool from a fresh clone, from any folder: installs and builds once if needed, then
# runs `rosrun flexcloud georeference ARGS...`. See scripts/georeference.sh --help.
# (Named .sh so that `rosrun flexcloud georeference` finds only the built tool.)
exec "$(dirname "${BASH_SOURCE[0]}")/env.sh" rosrun flexcloud georeference "$@"
