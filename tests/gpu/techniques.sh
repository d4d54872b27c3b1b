#!/usr/bin/env bash
# Techniques on the GPU: every capture spec in tests/gpu/techniques/ (or the
# names given), each run by `tallyd capture --spec` as the service's jobs run
# them, then a per-variant summary (tests/gpu/techniques_summary.py): frame
# and pass times, bytes per frame, image error against the reference variant
# and against forward, and each technique's extras. docs/techniques.md reports
# the figures. Build first with tests/gpu/build.sh; bring the Vulkan loader's
# .debs in .gl/ (see run.sh) and a copy of the Sponza folder in .scenes/sponza.
#
#   tests/gpu/techniques.sh [NAME...]   NAME: a spec in tests/gpu/techniques/ without .json; default all
#   OUT=dir                  where results go (default ./gpu-out): technique-NAME-SCENE.json
#                            (result), technique-NAME-SCENE.txt (summary), technique-NAME-SCENE.log
#   CAMERAS=N                cameras per scene where the spec has none (default 2): the first N
#                            of tests/gpu/accuracy-<scene>.json
#   TALLYD=path              tallyd to run (default build-gpu/server/tallyd)
#   TECHNIQUE_RESOLUTION=WxH replaces every spec resolution, e.g. 160x90 for a check on lavapipe
#   TECHNIQUE_FRAMES=N       replaces each spec's frame count
set -uo pipefail
cd "$(dirname "$0")/../.."

# $out, $tallyd; Vulkan on the GPU machine (env.sh).
. tests/gpu/env.sh
override="${TECHNIQUE_RESOLUTION:-}"
tally_gpu_script techniques.sh TECHNIQUE_RESOLUTION || exit 2
frames="${TECHNIQUE_FRAMES:-}"
sponza="$(tally_sponza_path)"

names=("$@")
if [ ${#names[@]} -eq 0 ]; then
  for f in tests/gpu/techniques/*.json; do names+=("$(basename "$f" .json)"); done
fi

status=0
for name in "${names[@]}"; do
  source_spec="tests/gpu/techniques/$name.json"
  [ -f "$source_spec" ] || { echo "techniques.sh: no $source_spec" >&2; status=2; continue; }
  # One capture per scene: each scene takes its own cameras (the spec's
  # "cameras" when it has them, else the first CAMERAS of
  # tests/gpu/accuracy-<scene>.json, which frame that scene).
  for scene in $(python3 -c 'import json,sys; print(" ".join(json.load(open(sys.argv[1])).get("scenes", ["atrium"])))' "$source_spec"); do
    tag="$name-$(echo "$scene" | tr 'A-Z' 'a-z')"
    spec="$out/technique-$tag-spec.json"
    python3 tests/gpu/spec_edit.py "$source_spec" --scene "$scene" --cameras "${CAMERAS:-2}" --sponza "$sponza" \
      ${override:+--resolution "$override"} ${frames:+--frames "$frames"} > "$spec" || { status=2; continue; }
    tally_timed_capture "technique $tag" "$spec" "$out/technique-$tag.json" "$out/technique-$tag.log" \
      || { status=$?; continue; }
    python3 tests/gpu/techniques_summary.py "$out/technique-$tag.json" > "$out/technique-$tag.txt" || status=1
    cat "$out/technique-$tag.txt"
  done
done
exit $status
