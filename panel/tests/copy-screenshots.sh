#!/bin/bash
# Copies the screenshots of the panel's end-to-end test (panel.e2e: BUILD_DIR/panel/e2e) into
# docs/ (docs/panel.md shows them). A test run never writes into the source tree: run this
# after `ctest --test-dir BUILD_DIR -R panel.e2e` passed.
#   panel/tests/copy-screenshots.sh BUILD_DIR
set -eu
here=$(cd "$(dirname "$0")" && pwd)
docs=$here/../../docs
shots=${1:?usage: copy-screenshots.sh BUILD_DIR}/panel/e2e
names="1-setup 2-run 3-results 4-compensation 5-apply-confirm 6-applied 7-verify 8-before-after
9-report 10-history"
for name in $names; do
  [ -s "$shots/panel-$name.png" ] || {
    echo "copy-screenshots: error: $shots/panel-$name.png: missing (run ctest -R panel.e2e)" >&2
    exit 1
  }
done
for name in $names; do cp "$shots/panel-$name.png" "$docs/panel-$name.png"; done
echo "copy-screenshots: $(echo $names | wc -w) pictures into $(cd "$docs" && pwd)"
