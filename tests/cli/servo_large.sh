#!/bin/bash
# The servo at 10^5 spheres on 2 ranks (issue 13 item 4): tiles the shared dense-13584 packing
# 2 x 2 x 2 (benchmarks/make_tiled.py), runs tests/cli/data/servo_large.toml (consolidation to
# 200 kPa at rest, then a short triaxial compression) and checks the stresses
# (check_servo_large.py).
#   servo_large.sh WORK_DIR FABRICA MPIEXEC
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
work=$1 fabrica=$2 mpiexec=$3
rm -rf "$work" && mkdir -p "$work"
/usr/bin/python3 "$here/../../benchmarks/make_tiled.py" 2 "$work/tiled2.data"
cp "$here/data/servo_large.toml" "$work/"
"$mpiexec" --oversubscribe -np 2 "$fabrica" run "$work/servo_large.toml" -o "$work/out" | tail -6
/usr/bin/python3 "$here/check_servo_large.py" "$work/out" 200e3
