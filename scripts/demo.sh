#!/usr/bin/env bash
# The main workflow on the bundled sample: terrain -> world -> missions -> report.
# Run through `make demo` (which installs what is missing first).
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-demo-out}
VINECLI=${VINECLI:-.venv/bin/vinecli}
DSM=worlds/sample/fieldimager_potato_plots_dsm_3cm_utm16n.tif

rm -rf "$OUT"
mkdir -p "$OUT"
step() { printf '\n\033[1m== %s\033[0m\n' "$*"; }

step "1/6 what is in the sample DSM"
$VINECLI terrain info "$DSM"

step "2/6 DSM -> 513x513 heightmap (max resampling keeps the row tops)"
$VINECLI terrain convert "$DSM" --to heightmap --size 513 --method max --out "$OUT/heightmap"

step "3/6 DSM -> crack-free mesh tiles, 3 cm max error"
$VINECLI terrain convert "$DSM" --to tiles --max-error 0.03 --tile-px 256 --out "$OUT/tiles"

step "4/6 world: terrain + x500 sprayer + wind + geodetic origin (PyBullet + Gazebo SDF)"
$VINECLI world build worlds/vineyard-sample.yaml --out "$OUT/world"

step "5/6 the CI pipeline: takeoff, overload, spray, gust (thesis chapter 5) and a whole-field refill job"
set +e
$VINECLI run batch pipelines/ci.yaml --world "$OUT/world" --out "$OUT/runs" --workers 2
batch_rc=$?
set -e

step "6/6 report (HTML, Markdown, JUnit XML, JSON)"
set +e
$VINECLI report "$OUT/runs" --out "$OUT/report"
report_rc=$?
set -e

if [ ! -f "$OUT/report/report.html" ]; then
  echo "no report was written" >&2
  exit 1
fi
if [ "$batch_rc" -ne 0 ] || [ "$report_rc" -ne 0 ]; then
  echo "some checks failed (batch exit $batch_rc, report exit $report_rc)" >&2
  exit 1
fi
