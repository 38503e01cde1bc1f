#!/usr/bin/env bash
# Build the partial plotly.js bundle of the browser UI and the report
# (src/vectorid/views/static/plotly-vectorid.min.js): plotly.js core (scatter) with bar, box,
# heatmap, scattergl and parcoords only, 1.6 MB instead of the full 4.8 MB. The version must be
# the one plotly.py ships (see plotly/package_data/plotly.min.js's header). Needs node and npm.
#
#   scripts/build_plotly_bundle.sh [PLOTLY_JS_VERSION]
set -euo pipefail
VERSION="${1:-$(head -c 200 "$(${PYTHON:-python} -c 'import plotly, os; print(os.path.join(os.path.dirname(plotly.__file__), "package_data", "plotly.min.js"))')" | sed -n 's/.*plotly.js v\([0-9.]*\).*/\1/p')}"
OUT="$(cd "$(dirname "$0")/.." && pwd)/src/vectorid/views/static/plotly-vectorid.min.js"
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
cd "$WORK"
npm init -y >/dev/null
npm install --no-audit --no-fund "plotly.js@$VERSION" esbuild esbuild-plugin-glsl \
  esbuild-plugin-inline-css esbuild-plugin-environment buffer stream-browserify >/dev/null
cat > entry.js <<'JS'
var Plotly = require('plotly.js/lib/core');
Plotly.register([
  require('plotly.js/lib/bar'),
  require('plotly.js/lib/box'),
  require('plotly.js/lib/heatmap'),
  require('plotly.js/lib/scattergl'),
  require('plotly.js/lib/parcoords'),
]);
module.exports = Plotly;
JS
cat > build.js <<JS
const path = require('path');
const { environmentPlugin } = require('esbuild-plugin-environment');
const { glsl } = require('esbuild-plugin-glsl');
const InlineCSSPlugin = require('esbuild-plugin-inline-css');
require('esbuild').build({
  entryPoints: [path.resolve('entry.js')], outfile: '$OUT',
  format: 'iife', globalName: 'Plotly', bundle: true, minify: true, sourcemap: false,
  plugins: [InlineCSSPlugin(), glsl({ minify: true }), environmentPlugin({ NODE_DEBUG: false })],
  alias: { regl: '@plotly/regl', stream: 'stream-browserify' },
  define: { global: 'window', 'define.amd': 'false' }, target: 'es2016', logLevel: 'warning',
  banner: { js: '/*! plotly.js v$VERSION partial bundle for vectorid (core, bar, box, heatmap, ' +
    'scattergl, parcoords); Copyright 2012-2026 Plotly, Inc.; MIT license. Built by ' +
    'scripts/build_plotly_bundle.sh */' },
}).catch(e => { console.error(String(e)); process.exit(1); });
JS
node build.js
ls -l "$OUT"
