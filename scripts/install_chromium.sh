#!/usr/bin/env bash
# Debian's chromium, for the test that opens a case's report.html in a real headless browser
# (tests/test_report.py). Exits at once when present.
exec bash "$(dirname "$0")/apt_ensure.sh" install_chromium chromium
