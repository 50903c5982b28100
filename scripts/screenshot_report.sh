#!/usr/bin/env bash
# Screenshot of a vinecli report with headless Chromium (Debian package "chromium").
#   scripts/screenshot_report.sh REPORT.html OUT.png [WIDTH] [HEIGHT]
# Renders the self-contained report.html offline (no network flags) into a PNG, e.g. for
# docs/report-screenshot.png (the field maps drawn: a virtual-time budget lets their script run). The tests drive
# the page through Playwright (tests/report/test_browser.py); scripts/screenshot_map.py shoots one map.
set -euo pipefail
html=${1:?usage: $0 REPORT.html OUT.png [WIDTH] [HEIGHT]}
out=${2:?usage: $0 REPORT.html OUT.png [WIDTH] [HEIGHT]}
width=${3:-1400}
height=${4:-2000}
browser=$(command -v chromium || command -v chromium-browser || command -v google-chrome || true)
if [ -z "$browser" ]; then
  echo "screenshot_report.sh: no chromium found (apt-get install -y chromium)" >&2
  exit 2
fi
[ -f "$html" ] || { echo "screenshot_report.sh: $html: no such file" >&2; exit 2; }
profile=$(mktemp -d)
trap 'rm -rf "$profile"' EXIT
mkdir -p "$(dirname "$out")"
abs_html=$(cd "$(dirname "$html")" && pwd)/$(basename "$html")
abs_out=$(cd "$(dirname "$out")" && pwd)/$(basename "$out")
"$browser" --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
  --disable-background-networking --disable-component-update --disable-sync \
  --hide-scrollbars --virtual-time-budget=3000 --user-data-dir="$profile" \
  --screenshot="$abs_out" --window-size="${width},${height}" "file://$abs_html" 2>/dev/null
[ -s "$abs_out" ] || { echo "screenshot_report.sh: chromium wrote no screenshot" >&2; exit 3; }
echo "$abs_out"
