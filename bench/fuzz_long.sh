#!/usr/bin/env bash
# Long fuzz runs (issue 34): every libFuzzer target of build/fuzz/tests/fuzz/ and the TFLite
# reader's Python fuzzer, each to N executions or a time limit, whichever comes first, twice: from
# an empty corpus and from the committed seeds (tests/fuzz/corpus/<target>/). Prints one table:
#
#   target  run  executions  seconds  ended  crashes leaks timeouts ooms  functions reached / parser functions
#
# "ended": runs (N executions done), time (the limit), or finding (libFuzzer stops at its first).
# Functions: libFuzzer's -print_coverage=1 at the end of each run lists every instrumented function
# as COVERED_FUNC or UNCOVERED_FUNC with its file; the script counts those of the target's parser
# (PARSER below: files, and for the image targets the functions of one format in image_codec.cpp).
# A third figure, "seeds": the same count after running the seeds alone (-runs=0), what the corpus
# reaches before any mutation. The Python fuzzer reports its own (tests/fuzz/tflite/fuzz_tflite.py:
# functions of tflite.py reached, from sys.settrace).
#
#   bench/fuzz_long.sh [N]              N default 10000000
#   EF_FUZZ_SECONDS=900                 time limit of each run, s (default 900: 15 min)
#   EF_FUZZ_EMPTY_SECONDS=S             time limit of the runs from an empty corpus (default EF_FUZZ_SECONDS)
#   EF_FUZZ_TARGETS="klg model tflite"  only these (names without fuzz_)
#   EF_FUZZ_OUT=DIR                     logs, findings and the work corpora (default a temporary folder, kept)
# Runs niced (nice -n 10), one target at a time. Needs clang (the fuzz preset), which it builds
# when needed. Findings (crash-*, leak-*, timeout-*, oom-* files) stay in EF_FUZZ_OUT/<target>/.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
runs="${1:-10000000}"
seconds="${EF_FUZZ_SECONDS:-900}"
empty_seconds="${EF_FUZZ_EMPTY_SECONDS:-$seconds}"
out="${EF_FUZZ_OUT:-$(mktemp -d /tmp/ef-fuzz-long.XXXXXX)}"
mkdir -p "$out"

if [ ! -f build/fuzz/build.ninja ]; then cmake --preset fuzz >/dev/null; fi
nice -n 5 cmake --build --preset fuzz -j "${EF_JOBS:-2}" --target tests/fuzz/all >/dev/null

# The parser of each target: "file regex :: function regex[ :: functions left out]" (function regex
# "." = every function of those files; left out: the writers that share a file with a reader). The
# readers of recordings count the image decoders they call (image_codec.cpp's JPEG and PNG decoding). Paths as the compiler saw them (absolute); headers with parser code are included.
declare -A PARSER=(
  [args]='/firmware_app/(args|config_file)\.cpp$|/src/core/options\.(cpp|h)$ :: .'
  [config]='/firmware_app/config_file\.cpp$|/src/pipeline/run_config\.cpp$|/src/core/options\.(cpp|h)$ :: .'
  [jpeg]='/src/io/image_codec\.cpp$ :: jpeg_decode|decode_jpeg|jpeg_(error_exit|emit_message|output_message)_cb|read_color_image|file_error|open_error|FileCloser'
  [klg]='/src/io/(klg_format|image_codec)\.cpp$ :: . :: KlgWriter|write_klg_side_file|png|pnm|ppm|read_color_image|encode_jpeg|string_dest|write_|host_little_endian|FileCloser|open_error'
  [lists]='/src/io/(tum_source|sevenscenes_source|text_parse|source_uri)\.cpp$|/src/io/text_parse\.h$ :: .'
  [mcap]='/src/io/(mcap_reader|mcap_source|foxglove_msgs|image_codec)\.cpp$|/src/io/cdr\.h$ :: . :: write_png|png_write|pnm|ppm|read_color_image|read_png|read_ppm|encode_jpeg|string_dest|FileCloser|open_error|encode_|Encoder|_schema|nested|with_time|Writer|raw_image_data|to_nanoseconds'
  [model]='/src/nn/ :: . :: serialize_model|Writer::'
  [ply]='/src/io/ply_writer\.cpp$ :: parse_type|get_u32|get_f32|known_is|read_surfel_ply|SurfelCloud::view'
  [png]='/src/io/image_codec\.cpp$ :: png_read_stream|read_png|decode_png|png_(error|warning)_cb|read_color_image|file_error|open_error|FileCloser'
  [ppm]='/src/io/image_codec\.cpp$ :: pnm|ppm|read_color_image|file_error|open_error|FileCloser'
  [snapshot]='/src/io/snapshot_file\.cpp$|/src/pipeline/checkpoint\.cpp$ :: . :: SnapshotWriter|write_checkpoint|put_pose'
  [trajectory]='/src/io/trajectory_io\.cpp$|/src/eval/trajectory_eval\.cpp$ :: . :: TumTrajectoryWriter|write_tum_trajectory|steady_ns|format_ate|format_rpe|_files'
  [uri]='/src/io/(source_uri|text_parse)\.cpp$|/src/sources/|/src/synth/synthetic_source\.cpp$|/platform/devices/camera_common\.cpp$ :: .'
)

# "reached/total" of the parser's functions in a libFuzzer log with -print_coverage=1.
parser_functions() {
  local log="$1" spec="$2"
  local files="${spec%% :: *}" rest="${spec#* :: }"
  local funcs="${rest%% :: *}" skip='^$'
  if [ "$rest" != "$funcs" ]; then skip="${rest#* :: }"; fi
  grep -E '^(COVERED|UNCOVERED)_FUNC: ' "$log" 2>/dev/null |
    sed -E 's/^(COVERED|UNCOVERED)_FUNC: hits: [0-9]+ edges: [0-9]+\/[0-9]+ /\1 /' |
    awk -v files="$files" -v funcs="$funcs" -v skip="$skip" '{
      state = $1; loc = $NF; name = $0; sub(/^[A-Z]+ /, "", name); sub(/ [^ ]+$/, "", name)
      file = loc; sub(/:[0-9]+$/, "", file)
      if (file !~ files || name !~ funcs || name ~ skip) next
      key = name " " loc
      if (!(key in seen)) { seen[key] = 1; total++ }
      if (state == "COVERED" && !(key in hit)) { hit[key] = 1; reached++ }
    } END { if (total == 0) print "n/a"; else printf "%d/%d\n", reached, total }'
}

count_files() { find "$1" -maxdepth 1 -name "$2-*" 2>/dev/null | wc -l; }

# One libFuzzer run: fuzz_one NAME BINARY MODE(empty|seeds) SECONDS -> a table row.
fuzz_one() {
  local name="$1" bin="$2" mode="$3" limit="$4"
  local dir="$out/$name/$mode" seeds=()
  rm -rf "$dir"
  mkdir -p "$dir/corpus" "$dir/findings"
  if [ "$mode" = seeds ]; then seeds=("tests/fuzz/corpus/$name"); fi
  local log="$dir/fuzz.log" rc=0 t0=$SECONDS
  nice -n 10 "$bin" -runs="$runs" -max_total_time="$limit" -rss_limit_mb=2048 -timeout=25 -print_final_stats=1 \
    -print_coverage=1 -artifact_prefix="$dir/findings/" "$dir/corpus" "${seeds[@]}" >"$log" 2>&1 || rc=$?
  local took=$((SECONDS - t0))
  local execs
  execs="$(grep -Eo 'stat::number_of_executed_units: [0-9]+' "$log" | awk '{print $2}' | tail -n 1)"
  local ended=time
  if [ "$rc" != 0 ]; then ended="finding(rc $rc)"; elif [ "${execs:-0}" -ge "$runs" ]; then ended=runs; fi
  local f="$dir/findings"
  printf '%-11s %-6s %11s %7s  %-14s %3s %3s %3s %3s   %s\n' "$name" "$mode" "${execs:-?}" "$took" "$ended" \
    "$(count_files "$f" crash)" "$(count_files "$f" leak)" "$(count_files "$f" timeout)" "$(count_files "$f" oom)" \
    "$(parser_functions "$log" "${PARSER[$name]:-. :: .}")"
}

# The seeds alone: functions reached by the committed corpus before any mutation.
seeds_only() {
  local name="$1" bin="$2"
  local log="$out/$name/seeds-only.log"
  mkdir -p "$out/$name"
  nice -n 10 "$bin" -runs=0 -print_coverage=1 -rss_limit_mb=2048 "tests/fuzz/corpus/$name" >"$log" 2>&1 || true
  parser_functions "$log" "${PARSER[$name]:-. :: .}"
}

# The TFLite reader's Python fuzzer, as a row of the same table.
tflite_one() {
  local mode="$1" limit="$2" dir="$out/tflite/$1"
  rm -rf "$dir"
  mkdir -p "$dir"
  local seeds=()
  if [ "$mode" = seeds ]; then seeds=(--seeds tests/fuzz/corpus/tflite); fi
  local rc=0
  nice -n 10 /usr/bin/python3 tests/fuzz/tflite/fuzz_tflite.py --runs "$runs" --seconds "$limit" "${seeds[@]}" \
    --corpus "$dir/corpus" --findings "$dir/findings" >"$dir/fuzz.log" 2>&1 || rc=$?
  if [ "$rc" = 77 ]; then printf '%-11s %-6s %s\n' tflite "$mode" "skipped: $(head -n 1 "$dir/fuzz.log")"; return; fi
  local v
  v() { awk -v k="$1" '$1 == k {print $2}' "$dir/fuzz.log" | tail -n 1; }
  local ended; ended="$(v ended_by)"
  if [ "$rc" != 0 ]; then ended="finding(rc $rc)"; fi
  printf '%-11s %-6s %11s %7s  %-14s %3s %3s %3s %3s   %s\n' tflite "$mode" "$(v executions)" "$(v seconds | cut -d. -f1)" \
    "$ended" "$(v findings)" - - - "$(v functions_reached)/$(v functions_defined)"
}

targets="${EF_FUZZ_TARGETS:-}"
if [ -z "$targets" ]; then
  targets="$(find build/fuzz/tests/fuzz -maxdepth 1 -type f -perm -u+x -name 'fuzz_*' -printf '%f\n' | sed 's/^fuzz_//' | sort | tr '\n' ' ') tflite"
fi

echo "fuzz_long.sh: N=$runs executions or ${seconds} s per run from the seeds, ${empty_seconds} s from an empty corpus; logs in $out"
printf '%-11s %-6s %11s %7s  %-14s %3s %3s %3s %3s   %s\n' target run executions seconds ended crash leak tout oom \
  "functions reached / parser functions"
summary="$out/summary.txt"
: >"$summary"
for t in $targets; do
  if [ "$t" = tflite ]; then
    tflite_one empty "$empty_seconds" | tee -a "$summary"
    tflite_one seeds "$seconds" | tee -a "$summary"
    continue
  fi
  bin="build/fuzz/tests/fuzz/fuzz_$t"
  if [ ! -x "$bin" ]; then echo "$t: no binary $bin" | tee -a "$summary"; continue; fi
  fuzz_one "$t" "$bin" empty "$empty_seconds" | tee -a "$summary"
  fuzz_one "$t" "$bin" seeds "$seconds" | tee -a "$summary"
  printf '%-11s %-6s %52s   %s\n' "$t" seeds0 "(the seed corpus alone, -runs=0)" "$(seeds_only "$t" "$bin")" | tee -a "$summary"
done
echo "fuzz_long.sh: table in $summary"
