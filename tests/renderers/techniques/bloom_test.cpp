// Bloom (docs/techniques.md, "Bloom"): the kernel's derivation, the option
// table's checks, and on the test device (lavapipe in CI) each blur variant's
// passes, counted reads (taps x pixels, derived here from N) and final image
// against the naive blur's.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "analysis/image.hpp"
#include "capture/spec.hpp"
#include "render_fixture.hpp"
#include "renderers/techniques/bloom.hpp"
#include "renderers/options.hpp"

namespace tally::renderers {
using namespace fixture;
namespace {

// Events on exactly the resource `name` (fixture::counted matches a prefix,
// and "bloom" prefixes every bloom target).
uint64_t countedOn(const PassResult& p, const std::string& name, bool write) {
  uint64_t n = 0;
  for (const auto& a : p.accesses) {
    if (a.write == write && a.source == "counter" && a.resource == name) n += a.count;
  }
  return n;
}

const ResourceInfo* resourceNamed(const Rendered& r, const std::string& name) {
  for (const auto& info : r.resources) {
    if (info.name == name) return &info;
  }
  return nullptr;
}

// Reads per pixel of each blur pass, from N alone: the naive 2D kernel
// fetches every texel of its N x N square; a separable pass one row or column
// of N; a bilinear pass the centre plus one tap per merged pair on each side,
// 1 + 2 ceil(R / 2) with R = (N - 1) / 2.
uint64_t blurTapsPerPass(BloomBlur blur, uint32_t n) {
  const uint32_t radius = (n - 1) / 2;
  switch (blur) {
    case BloomBlur::Naive: return uint64_t(n) * n;
    case BloomBlur::Separable: return n;
    case BloomBlur::Bilinear: return 1 + 2 * ((radius + 1) / 2);
    case BloomBlur::Off: break;
  }
  return 0;
}

std::vector<std::string> blurPasses(BloomBlur blur) {
  if (blur == BloomBlur::Naive) return {"bloom_blur"};
  return {"bloom_blur_h", "bloom_blur_v"};
}

std::function<void(RendererOptions&)> bloomWith(BloomBlur blur, uint32_t taps, float threshold = 1.0f) {
  return [=](RendererOptions& o) {
    o.bloom.blur = blur;
    o.bloom.taps = taps;
    o.bloom.threshold = threshold;
  };
}

// ---------------------------------------------------------------- kernel

TEST(BloomKernel, WeightsAreANormalisedGaussianOfSigmaNOverSix) {
  for (uint32_t n : {5u, 7u, 9u, 13u, 17u, 25u}) {
    const auto w = gaussianWeights(n);
    ASSERT_EQ(w.size(), n);
    const int r = int(n / 2);
    double sum = 0;
    for (double x : w) sum += x;
    EXPECT_NEAR(sum, 1.0, 1e-12) << n;
    const double sigma = double(n) / 6.0;
    EXPECT_DOUBLE_EQ(bloomSigma(n), sigma);
    for (int i = 0; i <= r; ++i) {
      EXPECT_DOUBLE_EQ(w[size_t(r + i)], w[size_t(r - i)]) << n << " offset " << i;
      // The unnormalised Gaussian's ratio to the centre survives normalisation.
      EXPECT_NEAR(w[size_t(r + i)] / w[size_t(r)], std::exp(-double(i * i) / (2 * sigma * sigma)), 1e-12);
    }
  }
}

// The merged taps reproduce the discrete kernel's response exactly on a
// linearly interpolated signal (what a linear filter samples), and their
// count is (N + 1) / 2 for N % 4 == 1 (every allowed width).
TEST(BloomKernel, LinearTapsReproduceTheDiscreteKernel) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> value(0.0, 8.0);
  for (uint32_t n : {5u, 7u, 9u, 13u, 17u, 25u}) {
    const auto w = gaussianWeights(n);
    const auto taps = linearTaps(w);
    const uint32_t radius = (n - 1) / 2;
    EXPECT_EQ(taps.size(), 1 + 2 * ((radius + 1) / 2)) << n;
    if (n % 4 == 1) {
      EXPECT_EQ(taps.size(), (n + 1) / 2) << n;
    }
    double sum = 0;
    for (const auto& t : taps) {
      sum += t.weight;
      EXPECT_GT(t.weight, 0.0);
      EXPECT_LE(std::fabs(t.offset), double(radius));
    }
    EXPECT_NEAR(sum, 1.0, 1e-12) << n;
    // A random signal, long enough that no tap leaves it.
    std::vector<double> s(4 * n);
    for (double& x : s) x = value(rng);
    auto lerp = [&](double x) {
      const double f = std::floor(x);
      const double t = x - f;
      return s[size_t(f)] * (1 - t) + (t > 0 ? s[size_t(f) + 1] * t : 0.0);
    };
    for (size_t centre = radius; centre + radius < s.size(); ++centre) {
      double discrete = 0, merged = 0;
      for (uint32_t i = 0; i < n; ++i) discrete += w[i] * s[centre + i - radius];
      for (const auto& t : taps) merged += t.weight * lerp(double(centre) + t.offset);
      EXPECT_NEAR(merged, discrete, 1e-12) << n << " at " << centre;
    }
  }
}

TEST(BloomKernel, GlslLiteralsAreFloats) {
  EXPECT_EQ(glslFloat(1.0), "1.0");
  EXPECT_EQ(glslFloat(0.25), "0.25");
  EXPECT_EQ(glslFloatArray({0.25, 0.5, 0.25}), "float[3](0.25, 0.5, 0.25)");
}

// ---------------------------------------------------------------- options

TEST(BloomOptions, BadValuesAreRejectedNamingTheOption) {
  auto bad = [](const nlohmann::json& options, const std::string& option) {
    auto r = canonicalOptions("forward", options);
    ASSERT_FALSE(r.ok()) << options.dump();
    EXPECT_EQ(r.error().rfind(option + ":", 0), 0u) << r.error();
  };
  bad({{"bloom", "gaussian"}}, "bloom");
  bad({{"bloom", true}}, "bloom");
  bad({{"bloom_taps", 7}}, "bloom_taps");   // N % 4 != 1
  bad({{"bloom_taps", 9.0}}, "bloom_taps");  // not an integer
  bad({{"bloom_threshold", -1}}, "bloom_threshold");

  auto ok = canonicalOptions("deferred", {{"bloom", "bilinear"}, {"bloom_taps", 5}, {"bloom_threshold", 1}});
  ASSERT_TRUE(ok.ok()) << ok.error();
  EXPECT_EQ(*ok, nlohmann::json({{"bloom", "bilinear"}, {"bloom_taps", 5}}));  // the default threshold dropped
  EXPECT_EQ(variantLabel("deferred", *ok), "deferred bloom=bilinear bloom_taps=5");
  RendererOptions o;
  applyOptions(*ok, o);
  EXPECT_EQ(o.bloom.blur, BloomBlur::Bilinear);
  EXPECT_EQ(o.bloom.taps, 5u);
  for (const auto& def : optionDefs()) {
    if (def.name == "bloom") {
      EXPECT_EQ(def.reference, "naive");
      EXPECT_FALSE(def.parameter);
    }
    if (def.name == "bloom_taps" || def.name == "bloom_threshold") {
      EXPECT_TRUE(def.parameter) << def.name;
    }
  }
  // The reference variant swaps the blur for the naive one and keeps the
  // kernel's parameters: N taps are compared with N taps.
  const capture::RendererVariant separable13{"deferred", {{"bloom", "separable"}, {"bloom_taps", 13}}};
  EXPECT_EQ(separable13.reference().options, nlohmann::json({{"bloom", "naive"}, {"bloom_taps", 13}}));
  const capture::RendererVariant taps13{"deferred", {{"bloom", "naive"}, {"bloom_taps", 13}}};
  EXPECT_EQ(taps13.reference(), taps13);  // the reference itself
  // Every renderer takes bloom (a post chain of the shared base).
  for (const auto& name : rendererNames()) EXPECT_TRUE(canonicalOptions(name, {{"bloom", "naive"}}).ok()) << name;

  // Options set directly (not through the table) are checked at setup.
  Rendered r = render("forward", planes(1, "front-to-back"), {32, 24}, bloomWith(BloomBlur::Naive, 8), 1, true);
  EXPECT_EQ(r.error.rfind("bloom_taps:", 0), 0u) << r.error;
}

// ---------------------------------------------------------------- device

// Bloom off (the default) leaves the renderer as it was: no bloom passes or
// targets, tonemap reads one HDR texel per pixel, no extras; the other bloom
// fields change nothing while it is off.
TEST(Bloom, OffLeavesTheRendererUnchanged) {
  const VkExtent2D extent = {64, 48};
  const uint64_t pixels = uint64_t(extent.width) * extent.height;
  const auto spec = planes(3, "back-to-front");
  for (const char* name : {"forward", "deferred"}) {
    Rendered plain = render(name, spec, extent);
    Rendered off = render(name, spec, extent, bloomWith(BloomBlur::Off, 25, 0.0f));
    ASSERT_TRUE(plain.ok && off.ok);
    for (const auto& p : plain.frame.passes) EXPECT_EQ(p.name.rfind("bloom", 0), std::string::npos) << p.name;
    for (const auto& info : plain.resources) EXPECT_EQ(info.name.rfind("bloom", 0), std::string::npos);
    EXPECT_EQ(plain.extras.value("bloom", nlohmann::json()), nlohmann::json()) << plain.extras.dump();
    EXPECT_EQ(countedOn(passNamed(plain, "tonemap"), "hdr", false), pixels);
    EXPECT_EQ(plain.image, off.image) << name;
    ASSERT_EQ(plain.frame.passes.size(), off.frame.passes.size());
    ASSERT_EQ(plain.resources.size(), off.resources.size());
    for (size_t i = 0; i < plain.frame.passes.size(); ++i) {
      const auto& a = plain.frame.passes[i];
      const auto& b = off.frame.passes[i];
      EXPECT_EQ(a.name, b.name);
      ASSERT_EQ(a.accesses.size(), b.accesses.size()) << a.name;
      for (size_t k = 0; k < a.accesses.size(); ++k) {
        EXPECT_EQ(a.accesses[k].resource, b.accesses[k].resource);
        EXPECT_EQ(a.accesses[k].count, b.accesses[k].count) << a.name << " " << a.accesses[k].resource;
      }
    }
  }
}

// Every pass of every variant reads and writes exactly what N and the
// resolution say; the renderer's own passes count as they do without bloom.
TEST(Bloom, CountedReadsAreTapsTimesPixels) {
  const VkExtent2D extent = {64, 48};
  const uint64_t pixels = uint64_t(extent.width) * extent.height;
  const auto spec = planes(3, "back-to-front");
  for (const char* name : {"forward", "deferred"}) {
    Rendered plain = render(name, spec, extent);
    ASSERT_TRUE(plain.ok);
    for (uint32_t n : {5u, 9u}) {
      for (BloomBlur blur : {BloomBlur::Naive, BloomBlur::Separable, BloomBlur::Bilinear}) {
        const std::string label = std::string(name) + " " + std::string(toString(blur)) + " N=" + std::to_string(n);
        Rendered r = render(name, spec, extent, bloomWith(blur, n));
        ASSERT_TRUE(r.ok) << label;
        // Passes: the renderer's own, bright, the blur(s), tonemap, skybox.
        std::vector<std::string> expected;
        for (const auto& p : plain.frame.passes) {
          if (p.name != "tonemap" && p.name != "skybox") expected.push_back(p.name);
        }
        expected.push_back("bloom_bright");
        for (const auto& p : blurPasses(blur)) expected.push_back(p);
        expected.push_back("tonemap");
        expected.push_back("skybox");
        std::vector<std::string> got;
        for (const auto& p : r.frame.passes) got.push_back(p.name);
        EXPECT_EQ(got, expected) << label;
        for (size_t i = 0; i + 2 < plain.frame.passes.size(); ++i) {
          EXPECT_EQ(r.frame.passes[i].accesses.size(), plain.frame.passes[i].accesses.size()) << label;
          EXPECT_EQ(r.frame.passes[i].fragmentInvocations, plain.frame.passes[i].fragmentInvocations) << label;
        }
        // Targets: RGBA16F at the screen's size; bytes follow from the format.
        for (const char* target : {"bloom_bright", "bloom"}) {
          const ResourceInfo* info = resourceNamed(r, target);
          ASSERT_NE(info, nullptr) << label << " " << target;
          EXPECT_EQ(info->formatName, "R16G16B16A16_SFLOAT");
          EXPECT_EQ(info->elementBytes, 8u);
          EXPECT_EQ(info->width, extent.width);
          EXPECT_EQ(info->height, extent.height);
        }
        EXPECT_EQ(resourceNamed(r, "bloom_h") != nullptr, blur != BloomBlur::Naive) << label;

        const PassResult& bright = passNamed(r, "bloom_bright");
        EXPECT_EQ(countedOn(bright, "hdr", false), pixels) << label;
        EXPECT_EQ(countedOn(bright, "bloom_bright", true), pixels) << label;
        EXPECT_EQ(bytes(bright, "bloom_bright", true), pixels * 8) << label;
        const uint64_t taps = blurTapsPerPass(blur, n);
        const auto passes = blurPasses(blur);
        for (size_t i = 0; i < passes.size(); ++i) {
          const PassResult& p = passNamed(r, passes[i]);
          const std::string source = i == 0 ? "bloom_bright" : "bloom_h";
          const std::string target = i + 1 == passes.size() ? "bloom" : "bloom_h";
          EXPECT_EQ(p.fragmentInvocations, pixels) << label << " " << p.name;
          EXPECT_EQ(countedOn(p, source, false), taps * pixels) << label << " " << p.name;
          EXPECT_EQ(bytes(p, source, false), taps * pixels * 8) << label << " " << p.name;
          EXPECT_EQ(countedOn(p, target, true), pixels) << label << " " << p.name;
          EXPECT_EQ(r.extras["bloom"]["taps_per_pixel"].value(p.name, 0u), taps) << label;
          std::printf("%-8s %-9s N=%-2u %-12s reads/pixel %3llu  %.3f ms\n", name, std::string(toString(blur)).c_str(),
                      n, p.name.c_str(), (unsigned long long)(countedOn(p, source, false) / pixels), p.gpuMs);
        }
        // Composite: one more read per pixel.
        const PassResult& tonemap = passNamed(r, "tonemap");
        EXPECT_EQ(countedOn(tonemap, "hdr", false), pixels) << label;
        EXPECT_EQ(countedOn(tonemap, "bloom", false), pixels) << label;

        const nlohmann::json& extras = r.extras["bloom"];
        EXPECT_EQ(extras["variant"], std::string(toString(blur)));
        EXPECT_EQ(extras["taps"], n);
        EXPECT_DOUBLE_EQ(extras["sigma"].get<double>(), n / 6.0);
        EXPECT_EQ(extras["bloom_resolution"], nlohmann::json({extent.width, extent.height}));
        EXPECT_EQ(extras["taps_per_pixel"]["bloom_bright"], 1);
        EXPECT_EQ(extras["taps_per_pixel"]["tonemap"], 2);
      }
    }
  }
}

// The chain is the shared base's: every renderer runs it with the same counts
// (visbuffer and visbuffer-lean included, whose descriptor pools are shared).
TEST(Bloom, EveryRendererRunsTheChain) {
  const VkExtent2D extent = {32, 24};
  const uint64_t pixels = uint64_t(extent.width) * extent.height;
  const uint32_t n = 5;
  for (const auto& name : rendererNames()) {
    Rendered r = render(name, planes(2, "front-to-back"), extent, bloomWith(BloomBlur::Bilinear, n));
    ASSERT_TRUE(r.ok) << name << ": " << r.error;
    EXPECT_EQ(countedOn(passNamed(r, "bloom_bright"), "hdr", false), pixels) << name;
    EXPECT_EQ(countedOn(passNamed(r, "bloom_blur_h"), "bloom_bright", false),
              blurTapsPerPass(BloomBlur::Bilinear, n) * pixels) << name;
    EXPECT_EQ(countedOn(passNamed(r, "bloom_blur_v"), "bloom_h", false),
              blurTapsPerPass(BloomBlur::Bilinear, n) * pixels) << name;
    EXPECT_EQ(countedOn(passNamed(r, "tonemap"), "bloom", false), pixels) << name;
  }
}

// Final images against the naive blur's, with threshold 0 so every lit pixel
// blooms. Separable: the same sums in another order, plus one rounding of the
// horizontal result to RGBA16F (relative 2^-11); after tonemapping (L / (1 +
// L) <= 1) and the sRGB store that moves a channel by far less than one 8-bit
// step, so at most across one rounding boundary: |error| <= 1. Bilinear: the
// same, plus the linear filter's fractional weight precision.
TEST(Bloom, ImagesAgainstTheNaiveBlur) {
  const VkExtent2D extent = {64, 48};
  const auto spec = planes(3, "back-to-front");
  constexpr int kSeparableMaxAbs = 1;
  constexpr int kBilinearMaxAbs = 2;  // lavapipe measured 1; other filters quantise their weights more coarsely
  for (uint32_t n : {5u, 9u, 17u}) {
    Rendered off = render("forward", spec, extent);
    Rendered naive = render("forward", spec, extent, bloomWith(BloomBlur::Naive, n, 0.0f));
    Rendered separable = render("forward", spec, extent, bloomWith(BloomBlur::Separable, n, 0.0f));
    Rendered bilinear = render("forward", spec, extent, bloomWith(BloomBlur::Bilinear, n, 0.0f));
    ASSERT_TRUE(off.ok && naive.ok && separable.ok && bilinear.ok);
    auto bloomEffect = analysis::compareImages(off.image, naive.image, extent.width, extent.height);
    auto sep = analysis::compareImages(naive.image, separable.image, extent.width, extent.height);
    auto bil = analysis::compareImages(naive.image, bilinear.image, extent.width, extent.height);
    ASSERT_TRUE(bloomEffect.ok() && sep.ok() && bil.ok());
    std::printf("N=%u  off vs naive: max %d mean %.4f  separable vs naive: max %d mean %.4f PSNR %.1f dB  "
                "bilinear vs naive: max %d mean %.4f PSNR %.1f dB\n",
                n, bloomEffect->maxAbs, bloomEffect->meanAbs, sep->maxAbs, sep->meanAbs, sep->psnr, bil->maxAbs,
                bil->meanAbs, bil->psnr);
    // Time is printed, never asserted (lavapipe shares the machine).
    for (const Rendered* r : {&naive, &separable, &bilinear}) {
      double ms = 0;
      uint64_t reads = 0;
      for (const auto& p : r->frame.passes) {
        if (p.name.rfind("bloom_blur", 0) != 0) continue;
        ms += p.gpuMs;
        reads += countedOn(p, "bloom_bright", false) + countedOn(p, "bloom_h", false);
      }
      std::printf("N=%u  %-9s blur reads %llu (%.0f per pixel)  blur time %.3f ms\n", n,
                  r->extras["bloom"]["variant"].get<std::string>().c_str(), (unsigned long long)reads,
                  double(reads) / (double(extent.width) * extent.height), ms);
    }
    // The bloom is visible: far more than the variants' differences.
    EXPECT_GT(bloomEffect->maxAbs, kBilinearMaxAbs) << n;
    EXPECT_LE(sep->maxAbs, kSeparableMaxAbs) << n;
    EXPECT_LE(bil->maxAbs, kBilinearMaxAbs) << n;
  }
}

}  // namespace
}  // namespace tally::renderers
