#!/bin/bash
# ctest cli.output.paraview: runs check_paraview.py with ParaView's pvpython on the run OUT and
# renders PNG. ParaView is not a dependency of Fabrica: without pvpython the test is skipped
# (exit 77). The Debian package renders through X: without a display the check runs under
# xvfb-run, or without the rendering step if xvfb-run is missing too.
#   check_paraview.sh OUT PNG
out=$1 png=$2
script=$(dirname "$0")/check_paraview.py
if ! command -v pvpython >/dev/null; then
  echo "cli.output.paraview: skipped: pvpython not found (ParaView is not a Fabrica dependency; install it, e.g. apt-get install paraview, to run this check)"
  exit 77
fi
if [ -n "$DISPLAY" ]; then
  exec pvpython --force-offscreen-rendering "$script" "$out" --png "$png"
elif command -v xvfb-run >/dev/null; then
  exec xvfb-run -a pvpython --force-offscreen-rendering "$script" "$out" --png "$png"
else
  echo "cli.output.paraview: no X display and no xvfb-run: checking without rendering"
  exec pvpython "$script" "$out" --no-render
fi
