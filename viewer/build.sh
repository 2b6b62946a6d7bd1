#!/usr/bin/env bash
# Rebuild dalembert/plotting/viewer/viewer.js, the 3D viewer's script (three.js and
# src/main.js in one minified file), from the versions pinned in package-lock.json.
# The built file is committed: viewing a trajectory and the tests need neither npm nor
# the network. Run this after changing src/ or the pinned versions (needs node and npm).
set -euo pipefail
cd "$(dirname "$0")"
npm ci --no-audit --no-fund
npx --no-install esbuild src/main.js --bundle --minify --format=iife --target=es2020 \
    --legal-comments=eof --outfile=../dalembert/plotting/viewer/viewer.js
