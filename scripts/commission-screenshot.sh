#!/bin/sh
# Takes docs/img/commission-report.png again: a commissioning run on the
# simulated bench, its report.html shot by headless Chromium (the top of the
# page: the verdict, the summary, the bench, the first module). Needs `chromium`
# (apt-get install chromium). Run it after changing what the report shows.
set -eu
cd "$(dirname "$0")/.."
cargo build --quiet
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
target/debug/axisctl --link sim commission --out "$dir/report" --yes >/dev/null 2>&1
chromium --headless --no-sandbox --disable-gpu --hide-scrollbars --window-size=1000,2600 \
    --screenshot="$dir/shot.png" "file://$dir/report/report.html" 2>/dev/null
mv "$dir/shot.png" docs/img/commission-report.png
ls -l docs/img/commission-report.png
