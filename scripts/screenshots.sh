#!/bin/sh
# Draws docs/img/dashboard*.svg again from the dashboard's own drawing code
# on the simulated bench. Run it after changing what the dashboard shows;
# `cargo test` fails while the committed pictures differ from the code.
set -eu
cd "$(dirname "$0")/.."
AXISCTL_WRITE_DOCS_IMG=1 cargo test --lib tui::tests::the_docs_pictures_are_what_the_dashboard_draws -- --exact
ls -l docs/img/dashboard*.svg
