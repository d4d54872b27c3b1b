# Sourced by the GPU scripts (run.sh, protocol.sh, accuracy.sh, ...), from the
# repository root: makes Vulkan work on the GPU test machine, which has the
# NVIDIA driver but not the Vulkan loader, and finds what build.sh built.
#
#   tally_gpu_env      unpacks the loader's Debian packages from .gl/ (see
#                      run.sh), points the loader at the NVIDIA ICD when it
#                      would not find it, and puts build-gpu/lib (the shared
#                      libraries build.sh copies) on LD_LIBRARY_PATH. Fails
#                      when no loader can be had.
#   tally_sponza_path  the Sponza glTF: the copy in .scenes/sponza (the GPU
#                      machine has no ../shared), else ../shared's.
#   tally_gpu_script   the common start of a script that runs tallyd.
#   tally_timed_capture  one timed `tallyd capture`.
# Specs are shrunk or redirected by tests/gpu/spec_edit.py.

tally_gpu_env() {
  local debs f d icd_found=false
  local nvidia_icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
  shopt -s nullglob
  debs=(.gl/*.deb)
  if [ ${#debs[@]} -gt 0 ]; then
    for f in "${debs[@]}"; do dpkg -x "$f" /; done
    ldconfig
  elif ! ldconfig -p | grep 'libvulkan\.so\.1' >/dev/null; then  # not -q: an early exit breaks the pipe (pipefail)
    echo "no Vulkan loader installed and no .gl/*.deb to unpack" >&2
    return 2
  fi
  for d in /etc/vulkan/icd.d /usr/share/vulkan/icd.d /usr/local/share/vulkan/icd.d; do
    if compgen -G "$d/*.json" >/dev/null; then icd_found=true; fi
  done
  if [ -f "$nvidia_icd" ] && [ "$icd_found" = false ] && [ -z "${VK_DRIVER_FILES:-}${VK_ICD_FILENAMES:-}" ]; then
    export VK_DRIVER_FILES="$nvidia_icd"
  fi
  if [ -d "$PWD/build-gpu/lib" ]; then
    export LD_LIBRARY_PATH="$PWD/build-gpu/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
  fi
}

tally_sponza_path() {
  local sponza="$PWD/.scenes/sponza/Sponza.gltf"
  [ -f "$sponza" ] || sponza="$PWD/../shared/scenes/sponza/Sponza.gltf"
  echo "$sponza"
}

# The common start of a script that runs tallyd on the GPU: sets `out` (the
# absolute $OUT folder, made), `tallyd` ($TALLYD or build-gpu's, which must
# exist), `width` and `height` (from RESOLUTION_VAR, a WxH environment variable
# defaulting to 1280x720), then tally_gpu_env and the shader folder.
#   tally_gpu_script NAME RESOLUTION_VAR
tally_gpu_script() {
  local name="$1" var="$2" resolution
  out="${OUT:-./gpu-out}"
  mkdir -p "$out"
  out="$(cd "$out" && pwd)"
  tallyd="${TALLYD:-build-gpu/server/tallyd}"
  [ -x "$tallyd" ] || { echo "$name: no $tallyd (run tests/gpu/build.sh, or set TALLYD)" >&2; return 2; }
  resolution="${!var:-1280x720}"
  case "$resolution" in
    [0-9]*x[0-9]*) width="${resolution%x*}"; height="${resolution#*x}" ;;
    *) echo "$name: $var must be WxH, got '$resolution'" >&2; return 2 ;;
  esac
  tally_gpu_env || return 2
  export TALLY_SHADER_DIR="$PWD/shaders"
}

# Runs `tallyd capture` on SPEC into RESULT, its stderr in LOG; prints (and
# appends to SUMMARY, when given) "LABEL: capture wall time N ms, exit RC",
# and the log's tail when it failed. Returns tallyd's exit status.
#   tally_timed_capture LABEL SPEC RESULT LOG [SUMMARY]
tally_timed_capture() {
  local label="$1" spec="$2" result="$3" log="$4" summary="${5:-/dev/null}" start end rc
  start=$(date +%s%N)
  "$tallyd" capture --spec "$spec" --out "$result" 2> "$log"
  rc=$?
  end=$(date +%s%N)
  echo "$label: capture wall time $(( (end - start) / 1000000 )) ms, exit $rc" | tee -a "$summary"
  [ "$rc" -eq 0 ] || tail -5 "$log"
  return "$rc"
}
