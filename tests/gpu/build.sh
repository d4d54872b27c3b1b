#!/usr/bin/env bash
# Builds the exactness tests for the GPU test machine, which has the NVIDIA
# Vulkan driver but none of our build dependencies: a Release binary with
# libstdc++ and libgcc linked statically (glslang and SPIRV-Tools are static
# libraries already), so that it needs only libc and the Vulkan loader there.
# The shaders are copied next to it; run.sh points TALLY_SHADER_DIR at them.
#
#   tests/gpu/build.sh            -> build-gpu/tests/integration/{tally_exactness_tests,shaders/},
#                                    build-gpu/tests/renderers/tally_renderer_tests, build-gpu/server/tallyd,
#                                    build-gpu/layer/ (the Vulkan layer and its manifest),
#                                    build-gpu/tests/layer/tally_layer_{compute,shader_object,descriptor_buffer}_app
#   BUILD_DIR=out tests/gpu/build.sh
set -euo pipefail
cd "$(dirname "$0")/../.."

build="${BUILD_DIR:-build-gpu}"
cmake -S . -B "$build" -G Ninja \
  -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_EXE_LINKER_FLAGS="-static-libstdc++ -static-libgcc" \
  -DCMAKE_MODULE_LINKER_FLAGS="-static-libstdc++ -static-libgcc" >/dev/null
cmake --build "$build" --target tally_exactness_tests tally_renderer_tests tallyd VkLayer_tally_counters \
  tally_layer_compute_app tally_layer_shader_object_app tally_layer_descriptor_buffer_app -j"$(nproc)"

dir="$build/tests/integration"
strip "$dir/tally_exactness_tests" "$build/tests/renderers/tally_renderer_tests" "$build/server/tallyd" \
  "$build/layer/libVkLayer_tally_counters.so" "$build/tests/layer/tally_layer_compute_app" \
  "$build/tests/layer/tally_layer_shader_object_app" \
  "$build/tests/layer/tally_layer_descriptor_buffer_app"
rm -rf "$dir/shaders"
cp -r tests/integration/shaders "$dir/shaders"
# tinygltf, stb, cpp-httplib, SQLite (and what they pull in: OpenSSL, zlib,
# brotli) are shared libraries in Debian; the GPU machine has none of them.
# It has libc and, once run.sh unpacks it, the Vulkan loader.
mkdir -p "$build/lib"
for lib in $(ldd "$build/server/tallyd" | awk '/=>/ {print $3}' | grep -vE '/(libc|libm|libvulkan|ld-linux[^/]*)\.so'); do
  cp -L "$lib" "$build/lib/"
done
echo "built $dir/tally_exactness_tests ($(du -h "$dir/tally_exactness_tests" | cut -f1)); needs: $(
  ldd "$dir/tally_exactness_tests" | awk '/=>/ {print $1}' | tr '\n' ' ')"
