#!/usr/bin/env bash
# Regenerates the committed seed corpus of every fuzz target, tests/fuzz/corpus/<target minus fuzz_>/,
# from our own writers: the fuzz_corpus tool (tests/fuzz/corpus_tool/fuzz_corpus.cpp, built with the
# fuzz preset) for the C++ targets, and models/edgefusion_models/tflite_write.py for the TFLite
# reader's fuzzer (tests/fuzz/tflite/). The seeds are the same bytes on every run, so a diff after
# running this is a change in a writer.
#   bash tests/fuzz/make_corpus.sh          (configures and builds build/fuzz when needed)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
jobs="${EF_JOBS:-2}"

if [ ! -f build/fuzz/build.ninja ]; then cmake --preset fuzz >/dev/null; fi
nice -n 5 cmake --build --preset fuzz -j "$jobs" --target fuzz_corpus
out=tests/fuzz/corpus
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
# ASan's leak check stays on: the tool is our code too.
build/fuzz/tests/fuzz_tools/fuzz_corpus "$tmp"
PYTHONDONTWRITEBYTECODE=1 PYTHONPATH=models /usr/bin/python3 -m edgefusion_models.tflite_write --seeds "$tmp/tflite"
# Replace the corpus whole: a seed the tool no longer writes goes.
rm -rf "$out"
mkdir -p "$out"
cp -r "$tmp"/. "$out"/
echo "make_corpus.sh: $(find "$out" -type f | wc -l) seeds, $(find "$out" -type f -exec cat {} + | wc -c) bytes in $out"
