// Prints the device ceilings (gpu/ceilings.hpp) beside a host memcpy of the
// same size timed in this process, and their ratio: on lavapipe both run on
// the host's memory, so the ratio says how much of it the compute copy
// reaches. A figure, not a check (docs/benchmarks.md, "Device ceilings");
// tests/integration/ceilings_test.cpp checks what does not depend on time.
//
//   tally_bench_ceilings [--device NAME] [--shaders DIR] [--rounds N]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "gpu/ceilings.hpp"
#include "gpu/context.hpp"

namespace {

// Bytes read + written per second by the fastest of `repetitions` memcpys of `bytes`.
double hostCopyBandwidth(size_t bytes, int repetitions) {
  std::vector<char> from(bytes, 1), to(bytes, 0);
  double best = 1e30;
  for (int r = 0; r < repetitions; ++r) {
    from[size_t(r) % bytes] = char(r);
    auto started = std::chrono::steady_clock::now();
    std::memcpy(to.data(), from.data(), bytes);
    best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count());
  }
  if (to[bytes / 2] != from[bytes / 2]) std::fprintf(stderr, "host copy: wrong data\n");
  return 2.0 * double(bytes) / best;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Device ceilings beside a host memcpy of the same size"};
  std::string device, shaders = TALLY_BENCH_SHADER_DIR;
  int rounds = 3;
  app.add_option("--device", device, "device name substring or index (default: the usual choice)");
  app.add_option("--shaders", shaders, "folder with ceiling_copy.comp.glsl and ceiling_fma.comp.glsl");
  app.add_option("--rounds", rounds, "measurements, each printed")->check(CLI::Range(1, 100));
  CLI11_PARSE(app, argc, argv);

  tally::gpu::ContextOptions options;
  options.device = device;
  auto ctx = tally::gpu::createContext(options);
  if (!ctx.ok()) {
    std::fprintf(stderr, "tally_bench_ceilings: %s\n", ctx.error().c_str());
    return 1;
  }
  std::printf("device: %s\n", ctx->properties.deviceName);
  std::printf("%5s %12s %12s %8s %14s %10s\n", "round", "copy GB/s", "memcpy GB/s", "ratio", "arith Gop/s",
              "seconds");
  int status = 0;
  for (int r = 0; r < rounds; ++r) {
    auto c = tally::gpu::measureCeilings(*ctx, shaders);
    if (!c.ok()) {
      std::fprintf(stderr, "tally_bench_ceilings: %s\n", c.error().c_str());
      status = 1;
      break;
    }
    double host = hostCopyBandwidth(size_t(c->copyBytes), 5);
    std::printf("%5d %12.2f %12.2f %8.3f %14.2f %10.3f\n", r + 1, c->bandwidthBytesPerS * 1e-9, host * 1e-9,
                c->bandwidthBytesPerS / host, c->arithmeticOpsPerS * 1e-9, c->measureSeconds);
  }
  tally::gpu::destroyContext(*ctx);
  return status;
}
