#!/usr/bin/env bash
set -euo pipefail
# The maze's three grids and report, with the paper's main eight methods (as committed).
exec "$(dirname "$0")/domain_benchmark.sh" point_mass_maze all 2
