#!/usr/bin/env bash
# Installs Debian's chromium for the browser test of report.html (tests skip without it).
set -euo pipefail
if command -v chromium >/dev/null 2>&1; then
  exit 0
fi
if command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = 0 ]; then
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null
  echo "installed $(chromium --version)"
else
  echo "chromium missing and not installable here (needs root and apt-get): the browser test of report.html will skip" >&2
fi
