// Broken glTF files, one row each: every load fails with a message that
// names the file and the element, in bounded time and bounded memory. Each
// row loads in a child process whose address space is capped at what this
// process uses now plus kHeadroom, so a loader that allocates for what a
// file declares (2^30 instances, a 2^40-element accessor, a 1 TB buffer)
// dies there instead of passing; the parent times it.
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <string>

#include <stb_image_write.h>
#include <gtest/gtest.h>

#include "scene_test_util.hpp"
#include "scenes/gltf.hpp"
#include "scenes/gltf_check.hpp"

namespace tally::scenes {
namespace {

using json = nlohmann::json;
using test::GltfWriter;
using test::TempDir;

constexpr uint64_t kHeadroom = 256ull << 20;  // bytes the child may allocate beyond the parent's size
// CPU seconds a load may use (each row takes milliseconds): CPU time, not
// wall time, so that a busy machine does not fail the bound. The wall-clock
// alarm only ends a child that blocks without using any.
constexpr double kMaxSeconds = 5.0;
constexpr unsigned kHangSeconds = 300;

uint64_t addressSpaceBytes() {
  std::ifstream statm("/proc/self/statm");
  uint64_t pages = 0;
  statm >> pages;
  return pages * uint64_t(sysconf(_SC_PAGESIZE));
}

struct Outcome {
  bool refused = false;   // the load failed
  std::string message;    // its error
  bool crashed = false;   // killed (e.g. out of the capped memory) or timed out
  double seconds = 0;     // CPU time, user + system
};

// Loads `path` in a child capped at the current address space + kHeadroom.
Outcome loadInChild(const std::string& path) {
  int fds[2];
  if (pipe(fds) != 0) return {false, "pipe failed", true, 0};
  const uint64_t cap = addressSpaceBytes() + kHeadroom;
  pid_t pid = fork();
  if (pid == 0) {
    close(fds[0]);
    rlimit limit = {cap, cap};
    setrlimit(RLIMIT_AS, &limit);
    rlimit cpu = {rlim_t(kMaxSeconds * 4), rlim_t(kMaxSeconds * 4)};
    setrlimit(RLIMIT_CPU, &cpu);
    alarm(kHangSeconds);
    Result<Scene> r = loadGltf(path, {.maxTextureSize = 0, .threads = 1});
    const std::string msg = r.ok() ? std::string("LOADED") : r.error();
    (void)!write(fds[1], msg.data(), msg.size());
    _exit(r.ok() ? 3 : 0);
  }
  close(fds[1]);
  std::string msg;
  char buf[4096];
  for (ssize_t n; (n = read(fds[0], buf, sizeof buf)) > 0;) msg.append(buf, size_t(n));
  close(fds[0]);
  int status = 0;
  rusage usage{};
  wait4(pid, &status, 0, &usage);
  Outcome o;
  o.seconds = double(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
              1e-6 * double(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
  o.crashed = !WIFEXITED(status);
  o.refused = WIFEXITED(status) && WEXITSTATUS(status) == 0;
  o.message = msg;
  return o;
}

struct Row {
  const char* name;
  std::function<void(GltfWriter&)> edit;
  const char* mentions;  // the element (and problem) the message must name
};

// A chain of `depth` nodes, each listing the next twice: 2^depth instances of the quad.
void doublingChain(GltfWriter& w, int depth) {
  w.meshNode({w.quadPrimitive()});
  json nodes = json::array();
  for (int i = 0; i < depth; ++i) nodes.push_back({{"children", {i + 1, i + 1}}});
  nodes.push_back({{"mesh", 0}});
  w.doc["nodes"] = nodes;
  w.doc["scenes"] = {{{"nodes", {0}}}};
}

const Row kRows[] = {
    {"nan-position",
     [](GltfWriter& w) {
       std::vector<float> pos = {0, 0, 0, 1, 0, 0, std::numeric_limits<float>::quiet_NaN(), 1, 0};
       json p = {{"attributes", {{"POSITION", w.accessor(pos, 5126, "VEC3", 3)}}}};
       w.meshNode({p});
     },
     "POSITION (accessor 0): vertex 2 is not finite"},
    {"infinite-position",
     [](GltfWriter& w) {
       std::vector<float> pos = {0, 0, 0, std::numeric_limits<float>::infinity(), 0, 0, 1, 1, 0};
       json p = {{"attributes", {{"POSITION", w.accessor(pos, 5126, "VEC3", 3)}}}};
       w.meshNode({p});
     },
     "vertex 1 is not finite"},
    {"stride-below-element",
     [](GltfWriter& w) {
       json p = w.quadPrimitive();
       w.doc["bufferViews"][0]["byteStride"] = 8;  // POSITION's view: 12-byte elements
       w.meshNode({p});
     },
     "accessor 0: byteStride 8 of bufferView 0 is smaller than its element (12 bytes)"},
    {"stride-not-multiple-of-4",
     [](GltfWriter& w) {
       json p = w.quadPrimitive();
       w.doc["bufferViews"][0]["byteStride"] = 14;
       w.meshNode({p});
     },
     "bufferView 0: byteStride 14"},
    {"count-overflows",
     [](GltfWriter& w) {
       json p = w.quadPrimitive();
       w.doc["accessors"][0]["count"] = uint64_t(1) << 62;  // x 12 bytes overflows 64 bits
       w.meshNode({p});
     },
     "accessor 0: reads past the end of bufferView 0"},
    {"index-count-overflows",
     [](GltfWriter& w) {
       json p = w.quadPrimitive();
       w.doc["accessors"][p["indices"].get<int>()]["count"] = uint64_t(1) << 63;
       w.meshNode({p});
     },
     "accessor 3: reads past the end of bufferView 3"},
    {"view-past-buffer",
     [](GltfWriter& w) {
       json p = w.quadPrimitive();
       w.doc["bufferViews"][1]["byteLength"] = 1 << 20;
       w.meshNode({p});
     },
     "bufferView 1: bytes"},
    {"buffer-longer-than-file",
     [](GltfWriter& w) {
       w.meshNode({w.quadPrimitive()});
       w.declaredBufferBytes = uint64_t(1) << 40;  // 1 TiB declared, a few bytes on disk
     },
     "buffer 0: byteLength 1099511627776 exceeds the"},
    {"instances-2-to-the-30", [](GltfWriter& w) { doublingChain(w, 30); }, "over Tally's limit of 65536"},
    {"instances-just-over-the-limit",
     [](GltfWriter& w) { doublingChain(w, 17); },  // 131072 draws of one quad
     "node 0: instances 131072 mesh primitives (draws), over Tally's limit of 65536"},  // node k holds
                                                                                        // 2^(17-k)
    {"node-cycle",
     [](GltfWriter& w) {
       w.meshNode({w.quadPrimitive()});
       w.doc["nodes"] = {{{"mesh", 0}, {"children", {1}}}, {{"children", {0}}}};
     },
     "the node graph has a cycle"},
    {"child-does-not-exist",
     [](GltfWriter& w) {
       w.meshNode({w.quadPrimitive()});
       w.doc["nodes"][0]["children"] = {7};
     },
     "node 0: child 7 does not exist"},
    {"mesh-does-not-exist",
     [](GltfWriter& w) {
       w.meshNode({w.quadPrimitive()});
       w.doc["nodes"][0]["mesh"] = 3;
     },
     "node 0: mesh out of range"},
    {"points",
     [](GltfWriter& w) {
       json p = w.quadPrimitive();
       p["mode"] = 0;
       w.meshNode({p});
     },
     "primitive 0: mode 0 (POINTS)"},
    {"required-unknown-extension",
     [](GltfWriter& w) {
       w.meshNode({w.quadPrimitive()});
       w.doc["extensionsUsed"] = w.doc["extensionsRequired"] = {"KHR_materials_pbrSpecularGlossiness"};
     },
     "requires extension KHR_materials_pbrSpecularGlossiness, which Tally does not implement"},
    {"meshopt-required",
     [](GltfWriter& w) {
       w.meshNode({w.quadPrimitive()});
       w.doc["extensionsUsed"] = w.doc["extensionsRequired"] = {"EXT_meshopt_compression"};
     },
     "compressed with EXT_meshopt_compression, which Tally cannot decode"},
    {"draco-used-no-fallback",
     [](GltfWriter& w) {
       json p = w.quadPrimitive();
       p["extensions"] = {{"KHR_draco_mesh_compression", {{"bufferView", 0}, {"attributes", {{"POSITION", 0}}}}}};
       w.meshNode({p});
       w.doc["accessors"][0].erase("bufferView");
       w.doc["extensionsUsed"] = {"KHR_draco_mesh_compression"};
     },
     "mesh 0 primitive 0: its geometry is compressed with KHR_draco_mesh_compression"},
    {"texcoord-2",
     [](GltfWriter& w) {
       json p = w.quadPrimitive();
       p["material"] = 0;
       w.meshNode({p});
       w.doc["images"] = {{{"uri", test::kTestPngDataUri}}};
       w.doc["textures"] = {{{"source", 0}}};
       w.doc["materials"] = {{{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}, {"texCoord", 2}}}}}}};
     },
     "material 0 diffuse: texCoord 2 is not supported"},
    {"bad-wrap-mode",
     [](GltfWriter& w) {
       json p = w.quadPrimitive();
       p["material"] = 0;
       w.meshNode({p});
       w.doc["images"] = {{{"uri", test::kTestPngDataUri}}};
       w.doc["samplers"] = {{{"wrapS", 1234}}};
       w.doc["textures"] = {{{"source", 0}, {"sampler", 0}}};
       w.doc["materials"] = {{{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}}};
     },
     "sampler 0: wrapS 1234"},
    // Fields of the wrong JSON type (found by tests/fuzz/fuzz_gltf): the
    // pre-check threw nlohmann's type_error instead of refusing the file.
    {"accessor-type-not-a-string",
     [](GltfWriter& w) {
       w.meshNode({w.quadPrimitive()});
       w.doc["accessors"][0]["type"] = {0.0, 0.0, 0.0};
     },
     "accessor 0: type [0.0,0.0,0.0] is not a glTF type"},
    {"accessor-component-type-a-string",
     [](GltfWriter& w) {
       w.meshNode({w.quadPrimitive()});
       w.doc["accessors"][0]["componentType"] = "5126";
     },
     "accessor 0: componentType \"5126\" is not a glTF type"},
    {"accessor-not-an-object",
     [](GltfWriter& w) {
       w.meshNode({w.quadPrimitive()});
       w.doc["accessors"].push_back(7);
     },
     "count missing"},
    {"invalid-json", [](GltfWriter& w) { w.rawText = "{\"asset\": {\"version\": \"2.0\"}, \"nodes\": [ }"; },
     "invalid JSON"},
    {"huge-image",
     [](GltfWriter& w) {
       json p = w.quadPrimitive();
       p["material"] = 0;
       w.meshNode({p});
       w.doc["images"] = {{{"uri", "huge.png"}}};
       w.doc["textures"] = {{{"source", 0}}};
       w.doc["materials"] = {{{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}}};
       w.hugePng = true;
     },
     "image 0 (huge.png): cannot decode: too large"},  // stb refuses from the header, before allocating
};

// A 1x1 PNG whose IHDR claims 60000 x 60000 (stb reads the header without its CRC).
void writeHugePng(const std::string& path) {
  const uint8_t px[4] = {1, 2, 3, 255};
  stbi_write_png(path.c_str(), 1, 1, 4, px, 4);
  std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
  const uint8_t side[4] = {0x00, 0x00, 0xEA, 0x60};  // 60000, big-endian
  f.seekp(16);
  f.write(reinterpret_cast<const char*>(side), 4);
  f.write(reinterpret_cast<const char*>(side), 4);
}

TEST(GltfBroken, EveryRowIsRefusedNamingTheFileAndElementInBoundedTimeAndMemory) {
  for (const Row& row : kRows) {
    TempDir dir;
    GltfWriter w;
    row.edit(w);
    const std::string path = w.write(dir, std::string(row.name) + ".gltf");
    if (w.hugePng) writeHugePng(dir.path("huge.png"));
    const Outcome o = loadInChild(path);
    EXPECT_FALSE(o.crashed) << row.name << ": the loader died (memory cap or time) instead of refusing";
    ASSERT_TRUE(o.refused) << row.name << ": loaded a broken file: " << o.message;
    EXPECT_EQ(o.message.rfind("\"" + path + "\": ", 0), 0u) << row.name << ": " << o.message;
    EXPECT_NE(o.message.find(row.mentions), std::string::npos) << row.name << " -> " << o.message;
    EXPECT_LT(o.seconds, kMaxSeconds) << row.name;
  }
}

TEST(GltfBroken, TruncatedAndLyingGlbFiles) {
  TempDir dir;
  auto glb = [&](const std::string& name, uint32_t headerLength, uint32_t jsonChunk, const std::string& text) {
    const std::string path = dir.path(name);
    std::ofstream f(path, std::ios::binary);
    const uint32_t header[3] = {0x46546C67, 2, headerLength};
    f.write(reinterpret_cast<const char*>(header), 12);
    const uint32_t chunk[2] = {jsonChunk, 0x4E4F534A};
    f.write(reinterpret_cast<const char*>(chunk), 8);
    f.write(text.data(), std::streamsize(text.size()));
    return path;
  };
  const std::string text = R"({"asset":{"version":"2.0"}})";
  const uint32_t size = uint32_t(20 + text.size());
  const struct {
    std::string path;
    const char* mentions;
  } cases[] = {
      {glb("header-longer.glb", size + 1000, uint32_t(text.size()), text), "exceeds the file's"},
      {glb("chunk-past-end.glb", size, uint32_t(text.size()) + 500, text), "chunk 0: length"},
  };
  for (const auto& c : cases) {
    const Outcome o = loadInChild(c.path);
    ASSERT_TRUE(o.refused) << c.path << ": " << o.message;
    EXPECT_NE(o.message.find(c.mentions), std::string::npos) << o.message;
    EXPECT_NE(o.message.find(c.path), std::string::npos) << o.message;
  }
}

// A primitive's mode or attributes of the wrong type, or a primitive that is
// not an object (found by tests/fuzz/fuzz_gltf): the pre-check answers (the
// loader judges the rest) instead of throwing.
TEST(GltfBroken, PrimitiveFieldsOfTheWrongTypeDoNotThrow) {
  TempDir dir;
  const std::function<void(json&)> edits[] = {
      [](json& p) { p["mode"] = "4"; },
      [](json& p) {
        p["attributes"] = {1, 2};
      },
      [](json& p) { p = 3; },
      [](json& p) {
        p["extensions"] = {{"KHR_draco_mesh_compression", json::object()}};
        p["attributes"] = "POSITION";
      },
  };
  int i = 0;
  for (const auto& edit : edits) {
    GltfWriter w;
    json p = w.quadPrimitive();
    edit(p);
    w.meshNode({p});
    const std::string path = w.write(dir, "primitive-" + std::to_string(i++) + ".gltf");
    EXPECT_NO_THROW((void)precheckGltf(path)) << path;
  }
}

TEST(GltfBroken, UsedButUnimplementedExtensionsBecomeNotes) {
  TempDir dir;
  GltfWriter w;
  w.meshNode({w.quadPrimitive()});
  w.doc["extensionsUsed"] = {"KHR_materials_clearcoat", "KHR_lights_punctual", "KHR_texture_transform",
                             "EXT_made_up"};
  Result<Scene> r = loadGltf(w.write(dir, "notes.gltf"));
  ASSERT_TRUE(r.ok()) << r.error();
  std::string all;
  for (const auto& n : r->notes) all += n + "\n";
  EXPECT_NE(all.find("KHR_materials_clearcoat: used but not implemented; clearcoat is not drawn"), std::string::npos)
      << all;
  EXPECT_NE(all.find("KHR_lights_punctual: used but not implemented"), std::string::npos) << all;
  EXPECT_NE(all.find("EXT_made_up: used but not implemented; its data is ignored"), std::string::npos) << all;
  EXPECT_EQ(all.find("KHR_texture_transform"), std::string::npos) << "implemented, so no note: " << all;
}

}  // namespace
}  // namespace tally::scenes
