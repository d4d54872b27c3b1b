#include "scenes/cameras.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <optional>
#include <set>
#include <string>

namespace tally::scenes {
namespace {

constexpr float kPi = 3.14159265358979f;

// Coarse grid used to screen candidates: 16x9 rays, ~0.07 resolution in sky
// fraction; category picks are re-measured on the full grid before use.
constexpr int kScreenRaysX = 16;
constexpr int kScreenRaysY = 9;
// Candidate grid inside the bounds (fractions of the extent).
constexpr float kGridFractions[] = {0.1f, 0.3f, 0.5f, 0.7f, 0.9f};  // along both horizontal axes
constexpr float kHeightFractions[] = {0.08f, 0.35f, 0.62f, 0.85f};  // ~eye height, mid, upper storey, roof
constexpr int kYaws = 8;                                            // every 45 degrees
constexpr float kPitches[] = {-45.0f, -20.0f, 0.0f, 20.0f, 45.0f, 70.0f, 88.0f};
// Open space: an eye is kept when none of 26 rays (cube directions) hits
// closer than this fraction of the bounds diagonal, and at most a few of them
// see back faces (more means the eye is inside a closed object or behind a
// one-sided wall).
constexpr float kClearance = 0.01f;
constexpr int kMaxBackFaces = 2;
// Rotations of a fixed camera about its eye (planes, sky).
constexpr float kFixedYaws[] = {-30.0f, -15.0f, 0.0f, 15.0f, 30.0f};
constexpr float kFixedPitchStep = 5.0f;  // -75..75 degrees
constexpr float kFixedPitchMax = 75.0f;
// Variety: lower edges of the sky-fraction bins the remaining cameras are
// spread over, the most sky a variety camera may show (an empty view
// measures nothing) ...
constexpr float kVarietyBins[] = {0.0f, 0.02f, 0.15f, 0.3f, 0.5f, 0.7f, 0.85f};
constexpr float kVarietyMaxSky = 0.95f;
// ... and the least mean distance to what the rays hit, in bounds diagonals
// (~3 m in atrium and Sponza), so they do not stare at a nearby wall.
constexpr float kVarietyMinDepth = 0.1f;
// A scene whose smallest extent is under this fraction of its largest is
// flat or thin (a single triangle, a plane, a 1 cm panel): eyes inside its
// bounds lie in its plane and see it edge-on, so it is viewed from outside.
constexpr float kThinFraction = 0.05f;

struct Basis {
  glm::vec3 right, up, forward;
};

// The camera's basis as viewMatrix() defines it, so rays match the renderer.
Basis basisOf(const Camera& camera) {
  glm::mat4 v = viewMatrix(camera);
  return {glm::vec3(v[0][0], v[1][0], v[2][0]), glm::vec3(v[0][1], v[1][1], v[2][1]),
          -glm::vec3(v[0][2], v[1][2], v[2][2])};
}

struct Measure {
  float sky = 0.0f;
  float meanDistance = 0.0f;  // of the rays that hit, in bounds diagonals
};

// Casts the grid; closest hits only when distances are wanted.
Measure cast(const Bvh& bvh, const Camera& camera, float aspect, int raysX, int raysY, float diagonal,
             bool distances) {
  const Basis b = basisOf(camera);
  const float tanHalf = std::tan(glm::radians(camera.fovDeg) * 0.5f);
  int sky = 0, hits = 0;
  double distance = 0.0;
  for (int j = 0; j < raysY; ++j) {
    float y = (1.0f - 2.0f * (float(j) + 0.5f) / float(raysY)) * tanHalf;
    for (int i = 0; i < raysX; ++i) {
      float x = (2.0f * (float(i) + 0.5f) / float(raysX) - 1.0f) * tanHalf * aspect;
      // As drawn: a single-sided triangle seen from behind is culled, so the
      // pixel shows what lies beyond it (sky, when nothing does).
      Ray ray{camera.eye, glm::normalize(b.forward + b.right * x + b.up * y)};
      ray.cullBackFaces = true;
      if (distances) {
        std::optional<Hit> h = bvh.closestHit(ray);
        if (!h) {
          ++sky;
        } else {
          ++hits;
          distance += h->t;
        }
      } else if (!bvh.anyHit(ray)) {
        ++sky;
      }
    }
  }
  Measure m;
  m.sky = float(sky) / float(raysX * raysY);
  m.meanDistance = hits > 0 && diagonal > 0.0f ? float(distance / hits) / diagonal : 0.0f;
  return m;
}

glm::vec3 direction(float yawDeg, float pitchDeg) {
  float yaw = glm::radians(yawDeg), pitch = glm::radians(pitchDeg);
  // Yaw 0 looks down +X (the long axis of a court), 90 down +Z.
  return glm::vec3(std::cos(pitch) * std::cos(yaw), std::sin(pitch), std::cos(pitch) * std::sin(yaw));
}

struct Candidate {
  Camera camera;
  float yaw = 0.0f, pitch = 0.0f;
  glm::vec3 where{0.0f};  // eye as fractions of the bounds
  Measure screen;
  std::optional<float> full;  // full-grid sky fraction, once measured
  bool fixed = false;         // one of the scene's fixed cameras, unchanged
  std::string description;    // where it is and where it looks
};

template <class... Args>
std::string fmt(const char* format, Args... args) {
  char buf[160];
  std::snprintf(buf, sizeof buf, format, args...);
  return buf;
}

bool inOpenSpace(const Bvh& bvh, const glm::vec3& eye, float clearance) {
  int backFaces = 0;
  for (int x = -1; x <= 1; ++x)
    for (int y = -1; y <= 1; ++y)
      for (int z = -1; z <= 1; ++z) {
        if (x == 0 && y == 0 && z == 0) continue;
        std::optional<Hit> h = bvh.closestHit({eye, glm::normalize(glm::vec3(x, y, z))});
        if (!h) continue;
        if (h->t < clearance) return false;
        if (h->backFace && ++backFaces > kMaxBackFaces) return false;
      }
  return true;
}

std::vector<Candidate> gridCandidates(const Scene& scene, const Bvh& bvh) {
  const Bounds& b = scene.bounds;
  const glm::vec3 e = b.extent();
  const float diagonal = b.diagonal();
  const float reach = 0.25f * diagonal;  // target distance; only the direction matters
  std::vector<Candidate> out;
  for (float fh : kHeightFractions)
    for (float fz : kGridFractions)
      for (float fx : kGridFractions) {
        glm::vec3 where(fx, fh, fz);
        glm::vec3 eye = b.min + e * where;
        if (!inOpenSpace(bvh, eye, kClearance * diagonal)) continue;
        for (int yi = 0; yi < kYaws; ++yi)
          for (float pitch : kPitches) {
            Candidate c;
            c.yaw = 360.0f * float(yi) / kYaws;
            c.pitch = pitch;
            c.where = where;
            c.camera.eye = eye;
            c.camera.target = eye + direction(c.yaw, pitch) * reach;
            c.description = fmt("eye at (%.2f, %.2f, %.2f) of bounds, yaw %.0f deg, pitch %.0f deg", where.x,
                                where.y, where.z, c.yaw, pitch);
            out.push_back(std::move(c));
          }
      }
  return out;
}

bool isThin(const Bounds& b) {
  const glm::vec3 e = b.extent();
  const float largest = std::max({e.x, e.y, e.z}), smallest = std::min({e.x, e.y, e.z});
  return smallest < kThinFraction * largest;
}

// Fallback when no grid eye is in open space (a closed object, a solid
// block), and the views of flat or thin scenes: from outside the bounds,
// one from beyond each corner (off every axis plane, so off a flat scene's
// plane too), aimed at the centre and turned a little; for a thin scene also
// head-on from either side of its thin axis, framing its largest extent.
std::vector<Candidate> outsideCandidates(const Scene& scene) {
  const Bounds& b = scene.bounds;
  const glm::vec3 center = b.center(), half = 0.5f * b.extent();
  std::vector<Candidate> out;
  if (isThin(b)) {
    const glm::vec3 e = b.extent();
    const int thin = e.x <= e.y && e.x <= e.z ? 0 : e.y <= e.z ? 1 : 2;
    const float reach = 0.6f * std::max({e.x, e.y, e.z}) / std::tan(glm::radians(30.0f)) + e[thin];
    for (float side : {1.0f, -1.0f}) {
      glm::vec3 axis(0.0f);
      axis[thin] = side;
      // Tilted 20 degrees off the normal towards another axis: a view
      // straight down a vertical axis would need viewMatrix's fallback up.
      glm::vec3 other(0.0f);
      other[(thin + 1) % 3] = 1.0f;
      const glm::vec3 dir = glm::normalize(axis * std::cos(glm::radians(20.0f)) + other * std::sin(glm::radians(20.0f)));
      Candidate c;
      c.camera.eye = center + dir * reach;
      c.camera.target = center;
      const glm::vec3 d = glm::normalize(center - c.camera.eye);
      c.yaw = glm::degrees(std::atan2(d.z, d.x));
      c.pitch = glm::degrees(std::asin(std::clamp(d.y, -1.0f, 1.0f)));
      c.where = (c.camera.eye - b.min) / glm::max(b.extent(), glm::vec3(1e-6f));
      c.description = fmt("outside, head-on to the flat scene from its %s side", side > 0 ? "+" : "-");
      out.push_back(std::move(c));
    }
  }
  for (int corner = 0; corner < 8; ++corner) {
    glm::vec3 sign(corner & 1 ? 1.0f : -1.0f, corner & 2 ? 1.0f : -1.0f, corner & 4 ? 1.0f : -1.0f);
    glm::vec3 eye = center + sign * (half * 1.5f + glm::vec3(0.25f * b.diagonal()));
    glm::vec3 d = glm::normalize(center - eye);
    float yaw0 = glm::degrees(std::atan2(d.z, d.x)), pitch0 = glm::degrees(std::asin(d.y));
    for (auto [dy, dp] :
         {std::pair{0.0f, 0.0f}, {20.0f, 0.0f}, {-20.0f, 0.0f}, {0.0f, 15.0f}, {0.0f, -15.0f}}) {
      Candidate c;
      c.yaw = yaw0 + dy;
      c.pitch = std::clamp(pitch0 + dp, -88.0f, 88.0f);
      c.where = (eye - b.min) / glm::max(b.extent(), glm::vec3(1e-6f));
      c.camera.eye = eye;
      c.camera.target = eye + direction(c.yaw, c.pitch) * glm::length(center - eye);
      c.description =
          fmt("outside, beyond corner %d of bounds, yaw %.0f deg, pitch %.0f deg", corner, c.yaw, c.pitch);
      out.push_back(std::move(c));
    }
  }
  return out;
}

std::vector<Candidate> fixedCandidates(const Scene& scene) {
  std::vector<Candidate> out;
  for (const Camera& f : scene.fixedCameras) {
    Candidate base;
    base.camera = f;
    base.fixed = true;
    base.description = f.label.empty() ? "fixed" : f.label;
    out.push_back(base);
    glm::vec3 d = glm::normalize(f.target - f.eye);
    float reach = glm::length(f.target - f.eye);
    float yaw0 = glm::degrees(std::atan2(d.z, d.x)),
          pitch0 = glm::degrees(std::asin(std::clamp(d.y, -1.0f, 1.0f)));
    for (float dy : kFixedYaws)
      for (float dp = -kFixedPitchMax; dp <= kFixedPitchMax + 0.01f; dp += kFixedPitchStep) {
        if (dy == 0.0f && dp == 0.0f) continue;
        Candidate c;
        c.yaw = yaw0 + dy;
        c.pitch = std::clamp(pitch0 + dp, -88.0f, 88.0f);
        c.camera = f;
        c.camera.target = f.eye + direction(c.yaw, c.pitch) * reach;
        c.camera.skyFraction = -1.0f;
        c.description = base.description + fmt(", turned yaw %+.0f deg, pitch %+.0f deg", dy, dp);
        out.push_back(std::move(c));
      }
  }
  return out;
}

}  // namespace

float skyFraction(const Bvh& bvh, const Camera& camera, float aspect, int raysX, int raysY) {
  if (raysX <= 0 || raysY <= 0) return -1.0f;
  return cast(bvh, camera, aspect, raysX, raysY, 0.0f, false).sky;
}

float skyFraction(const Scene& scene, const Camera& camera, float aspect, int raysX, int raysY) {
  return skyFraction(Bvh::build(scene), camera, aspect, raysX, raysY);
}

namespace {

// The choice of a scene's automatic cameras among candidates (autoCameras):
// the scene's own cameras first, then one per sky category, then variety,
// then every camera made to see some of the scene.
class CameraChooser {
 public:
  CameraChooser(const Bvh& bvh, std::vector<Candidate> cands) : bvh_(bvh), cands_(std::move(cands)) {}

  std::vector<Camera> choose() {
    for (size_t i = 0; i < cands_.size() && chosen_.size() < size_t(kAutoCameraCount); ++i)
      if (cands_[i].fixed) {
        chosen_.push_back(i);
        categories_.push_back("");
      }
    chooseCategories();
    chooseVariety();
    replaceSkyOnly();
    return cameras();
  }

 private:
  // The full measurement of a candidate's sky fraction, made once.
  float full(size_t i) {
    Candidate& c = cands_[i];
    if (!c.full)
      c.full = c.fixed && c.camera.skyFraction >= 0.0f ? c.camera.skyFraction : skyFraction(bvh_, c.camera);
    return *c.full;
  }
  bool isChosen(size_t i) const { return std::find(chosen_.begin(), chosen_.end(), i) != chosen_.end(); }

  void chooseCategories() {
    auto& cands = cands_;
    auto& chosen = chosen_;
    auto& categories = categories_;
  // One camera per category: candidates ordered by preference on the screening
  // grid; the first whose full measurement lies well inside the category
  // wins (so it stays there under small changes of grid or geometry), else
  // the first inside it at all, else the best-ranked one measured.
  struct Category {
    const char* name;
    std::function<bool(float)> strict, loose;
    std::function<float(const Candidate&)> rank;  // lower is better
  };
  const Category kCategories[] = {
      // Some geometry must remain: a view of empty sky measures nothing.
      {"mostly sky", [](float s) { return s > kMostlySky + 0.05f && s < 0.97f; },
       [](float s) { return s > kMostlySky; },
       [](const Candidate& c) { return std::abs(c.screen.sky - 0.85f); }},
      {"about half sky", [](float s) { return s >= kHalfSkyLo + 0.05f && s <= kHalfSkyHi - 0.05f; },
       [](float s) { return s >= kHalfSkyLo && s <= kHalfSkyHi; },
       [](const Candidate& c) { return std::abs(c.screen.sky - 0.5f); }},
      // Deepest views first: more layers behind each pixel, more overshading.
      {"all geometry", [](float s) { return s == 0.0f; }, [](float s) { return s < kAllGeometry; },
       [](const Candidate& c) { return c.screen.sky * 100.0f - c.screen.meanDistance; }},
  };
  constexpr size_t kTriesPerCategory = 32;  // full measurements at most, per category and pass
  for (const Category& cat : kCategories) {
    bool satisfied = false;
    for (size_t k = 0; k < chosen.size(); ++k)
      if (cat.loose(full(chosen[k]))) {
        if (categories[k].empty()) categories[k] = cat.name;
        satisfied = true;
      }
    if (satisfied || chosen.size() >= size_t(kAutoCameraCount)) continue;
    std::vector<size_t> order(cands.size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::stable_sort(order.begin(), order.end(),
                     [&](size_t a, size_t b) { return cat.rank(cands[a]) < cat.rank(cands[b]); });
    std::optional<size_t> pick;
    for (const auto& accepts : {cat.strict, cat.loose})
      for (size_t k = 0, tries = 0; k < order.size() && tries < kTriesPerCategory && !pick; ++k) {
        if (isChosen(order[k])) continue;
        ++tries;
        if (accepts(full(order[k]))) pick = order[k];
      }
    for (size_t k = 0; k < order.size() && !pick; ++k)
      if (!isChosen(order[k])) pick = order[k];
    if (pick) {
      chosen.push_back(*pick);
      categories.push_back(cat.loose(full(*pick)) ? cat.name : std::string("nearest to ") + cat.name);
    }
  }
  }

  void chooseVariety() {
    auto& cands = cands_;
    auto& chosen = chosen_;
    auto& categories = categories_;
  // The rest for variety: round robin over sky-fraction bins (so the set
  // spreads across the sky fractions the scene offers, not only across its
  // floor plan), taking in each bin the candidate farthest from those chosen
  // in eye position (fractions of the bounds) and view direction.
  auto bin = [](float sky) {
    int b = 0;
    while (b + 1 < int(std::size(kVarietyBins)) && sky >= kVarietyBins[b + 1]) ++b;
    return b;
  };
  auto feature = [&](const Candidate& c) {
    glm::vec3 d = glm::normalize(c.camera.target - c.camera.eye);
    return std::array<float, 6>{c.where.x, c.where.y, c.where.z, 0.5f * d.x, 0.5f * d.y, 0.5f * d.z};
  };
  auto distance2 = [](const std::array<float, 6>& a, const std::array<float, 6>& b) {
    float s = 0.0f;
    for (size_t i = 0; i < a.size(); ++i) s += (a[i] - b[i]) * (a[i] - b[i]);
    return s;
  };
  std::vector<float> nearest(cands.size(), std::numeric_limits<float>::max());
  auto update = [&](size_t picked) {
    auto f = feature(cands[picked]);
    for (size_t i = 0; i < cands.size(); ++i)
      nearest[i] = std::min(nearest[i], distance2(f, feature(cands[i])));
  };
  std::array<int, std::size(kVarietyBins)> perBin{};
  for (size_t i : chosen) {
    update(i);
    perBin[size_t(bin(cands[i].screen.sky))]++;
  }
  // Views that look into the scene rather than at a nearby surface, when
  // there are enough of them.
  size_t deep = 0;
  for (const Candidate& c : cands) deep += c.screen.meanDistance >= kVarietyMinDepth ? 1 : 0;
  const float minDepth = deep >= size_t(2 * kAutoCameraCount) ? kVarietyMinDepth : 0.0f;
  while (chosen.size() < size_t(kAutoCameraCount)) {
    // Best candidate of each bin; then the bin with the fewest picks so far.
    size_t best = cands.size();
    for (size_t i = 0; i < cands.size(); ++i) {
      if (isChosen(i) || cands[i].screen.sky > kVarietyMaxSky || cands[i].screen.meanDistance < minDepth)
        continue;
      if (best == cands.size()) {
        best = i;
        continue;
      }
      int bi = perBin[size_t(bin(cands[i].screen.sky))], bb = perBin[size_t(bin(cands[best].screen.sky))];
      if (bi < bb || (bi == bb && nearest[i] > nearest[best])) best = i;
    }
    if (best == cands.size()) break;
    chosen.push_back(best);
    categories.push_back("");
    perBin[size_t(bin(cands[best].screen.sky))]++;
    update(best);
  }
  }

  void replaceSkyOnly() {
    auto& cands = cands_;
    auto& chosen = chosen_;
    auto& categories = categories_;
  // Every camera must see some of the scene: one whose full grid hits
  // nothing (a category's nearest miss, a variety pick) gives way to the
  // unchosen candidate that sees the most geometry on the screening grid.
  for (size_t k = 0; k < chosen.size(); ++k) {
    if (full(chosen[k]) < 1.0f) continue;
    std::vector<size_t> order;
    for (size_t i = 0; i < cands.size(); ++i)
      if (!isChosen(i) && cands[i].screen.sky < 1.0f) order.push_back(i);
    std::stable_sort(order.begin(), order.end(),
                     [&](size_t a, size_t b) { return cands[a].screen.sky < cands[b].screen.sky; });
    for (size_t i : order) {
      if (full(i) < 1.0f) {
        chosen[k] = i;
        categories[k] = "sees geometry (in place of a view of sky only)";
        break;
      }
    }
  }
  }

  std::vector<Camera> cameras() {
    auto& cands = cands_;
    auto& chosen = chosen_;
    auto& categories = categories_;
  // One that still sees only sky (no candidate left that sees any geometry)
  // is dropped: a view of sky alone measures nothing of the scene. A
  // scene's fixed cameras stay as they are.
  std::vector<Camera> out;
  for (size_t k = 0; k < chosen.size(); ++k) {
    Candidate& c = cands[chosen[k]];
    if (!c.fixed && full(chosen[k]) >= 1.0f) continue;
    Camera cam = c.camera;
    cam.skyFraction = full(chosen[k]);
    cam.label = categories[k].empty() ? c.description : categories[k] + ": " + c.description;
    out.push_back(std::move(cam));
  }
    return out;
  }

  const Bvh& bvh_;
  std::vector<Candidate> cands_;
  std::vector<size_t> chosen_;
  std::vector<std::string> categories_;  // parallel to chosen_
};

}  // namespace

std::vector<Camera> autoCameras(const Scene& scene) {
  if (scene.triangleCount() == 0 || scene.bounds.empty()) return {};
  const Bvh bvh = Bvh::build(scene);
  const float diagonal = scene.bounds.diagonal();
  std::vector<Candidate> cands = !scene.fixedCameras.empty() ? fixedCandidates(scene)
                                 : isThin(scene.bounds)      ? outsideCandidates(scene)
                                                             : gridCandidates(scene, bvh);
  if (cands.empty()) cands = outsideCandidates(scene);
  for (Candidate& c : cands)
    c.screen = cast(bvh, c.camera, kSkyAspect, kScreenRaysX, kScreenRaysY, diagonal, true);
  return CameraChooser(bvh, std::move(cands)).choose();
}

namespace {

std::optional<glm::vec3> vec3From(const nlohmann::json& j) {
  if (!j.is_array() || j.size() != 3) return std::nullopt;
  glm::vec3 v(0.0f);
  for (int i = 0; i < 3; ++i) {
    if (!j[i].is_number()) return std::nullopt;
    v[i] = j[i].get<float>();
    if (!std::isfinite(v[i])) return std::nullopt;
  }
  return v;
}

}  // namespace

Result<std::vector<Camera>> camerasFromJson(const nlohmann::json& cameras) {
  if (!cameras.is_array()) return makeError("must be an array of cameras, got " + cameras.dump());
  if (cameras.empty()) return makeError("must hold at least one camera");
  static const std::set<std::string> kKeys = {"eye", "target", "fov_deg", "label", "sky_fraction"};
  std::vector<Camera> out;
  for (size_t i = 0; i < cameras.size(); ++i) {
    const nlohmann::json& c = cameras[i];
    // Built in steps: GCC 12 warns (-Wrestrict, a false positive) on "[" + to_string(i).
    std::string at = "[";
    at += std::to_string(i);
    at += "]";
    if (!c.is_object())
      return Error(at, "must be an object {\"eye\":[x,y,z], \"target\":[x,y,z]}, got " + c.dump());
    for (const auto& [key, value] : c.items())
      if (!kKeys.count(key))
        return Error(at + "." + key, "unknown key (allowed: eye, target, fov_deg, label, sky_fraction)");
    Camera cam;
    for (const char* key : {"eye", "target"}) {
      if (!c.contains(key)) return Error(at + "." + key, "missing");
      std::optional<glm::vec3> v = vec3From(c[key]);
      if (!v) return Error(at + "." + key, "must be an array of 3 finite numbers, got " + c[key].dump());
      (std::string(key) == "eye" ? cam.eye : cam.target) = *v;
    }
    if (glm::length(cam.target - cam.eye) < 1e-6f) return Error(at + ".target", "must differ from eye");
    if (c.contains("fov_deg")) {
      const nlohmann::json& f = c["fov_deg"];
      if (!f.is_number() || !(f.get<double>() > 0.0 && f.get<double>() < 180.0))
        return Error(at + ".fov_deg", "must be a number of degrees in (0, 180), got " + f.dump());
      cam.fovDeg = f.get<float>();
    }
    if (c.contains("label")) {
      if (!c["label"].is_string()) return Error(at + ".label", "must be a string, got " + c["label"].dump());
      cam.label = c["label"].get<std::string>();
    }
    if (c.contains("sky_fraction")) {
      const nlohmann::json& s = c["sky_fraction"];
      if (!s.is_number() || !(s.get<double>() >= 0.0 && s.get<double>() <= 1.0))
        return Error(at + ".sky_fraction", "must be a number in [0, 1], got " + s.dump());
      cam.skyFraction = s.get<float>();
    }
    out.push_back(std::move(cam));
  }
  return out;
}

}  // namespace tally::scenes
