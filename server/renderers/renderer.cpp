#include "renderers/renderer.hpp"

#include "renderers/renderers.hpp"

namespace tally::renderers {

std::string_view toString(MaterialSelection selection) {
  switch (selection) {
    case MaterialSelection::NonUniform: return "nonuniform";
    case MaterialSelection::Uniform: return "uniform";
    case MaterialSelection::FirstLane: return "first-lane";
  }
  return "nonuniform";
}

std::optional<MaterialSelection> parseMaterialSelection(std::string_view name) {
  for (auto s : {MaterialSelection::NonUniform, MaterialSelection::Uniform, MaterialSelection::FirstLane}) {
    if (name == toString(s)) return s;
  }
  return std::nullopt;
}

std::string_view toString(ForwardOutput output) {
  switch (output) {
    case ForwardOutput::Shaded: return "shaded";
    case ForwardOutput::Overdraw: return "overdraw";
    case ForwardOutput::Overshading: return "overshading";
    case ForwardOutput::Density: return "density";
  }
  return "shaded";
}

std::optional<ForwardOutput> parseForwardOutput(std::string_view name) {
  for (auto o : {ForwardOutput::Shaded, ForwardOutput::Overdraw, ForwardOutput::Overshading, ForwardOutput::Density}) {
    if (name == toString(o)) return o;
  }
  return std::nullopt;
}

std::string_view toString(BarycentricEncoding encoding) {
  return encoding == BarycentricEncoding::Float32 ? "float32" : "unorm16";
}

std::string_view toString(UvDerivativeEncoding encoding) {
  switch (encoding) {
    case UvDerivativeEncoding::Half: return "half";
    case UvDerivativeEncoding::Unorm16Clamped: return "unorm16-clamped";
    case UvDerivativeEncoding::Float32: return "float32";
  }
  return "half";
}

std::optional<BarycentricEncoding> parseBarycentricEncoding(std::string_view name) {
  for (auto e : {BarycentricEncoding::Unorm16, BarycentricEncoding::Float32}) {
    if (name == toString(e)) return e;
  }
  return std::nullopt;
}

std::optional<UvDerivativeEncoding> parseUvDerivativeEncoding(std::string_view name) {
  for (auto e :
       {UvDerivativeEncoding::Half, UvDerivativeEncoding::Unorm16Clamped, UvDerivativeEncoding::Float32}) {
    if (name == toString(e)) return e;
  }
  return std::nullopt;
}

std::string_view toString(BloomBlur blur) {
  switch (blur) {
    case BloomBlur::Off: return "off";
    case BloomBlur::Naive: return "naive";
    case BloomBlur::Separable: return "separable";
    case BloomBlur::Bilinear: return "bilinear";
  }
  return "off";
}

std::optional<BloomBlur> parseBloomBlur(std::string_view name) {
  for (auto b : {BloomBlur::Off, BloomBlur::Naive, BloomBlur::Separable, BloomBlur::Bilinear}) {
    if (name == toString(b)) return b;
  }
  return std::nullopt;
}

std::vector<std::string> rendererNames() {
  return {"forward", "forward-zprepass", "deferred", "visbuffer", "visbuffer-lean"};
}

std::vector<std::string> workloadNames() { return {"volume-fog", "raytrace"}; }

bool isWorkload(std::string_view name) {
  for (const auto& n : workloadNames()) {
    if (n == name) return true;
  }
  return false;
}

Result<std::unique_ptr<Renderer>> makeRenderer(std::string_view name) {
  if (name == "forward") return makeForward(false);
  if (name == "forward-zprepass") return makeForward(true);
  if (name == "deferred") return makeDeferred();
  if (name == "visbuffer-lean") return makeLeanVisbuffer();
  if (name == "visbuffer") return makeVisbuffer();
  if (name == "volume-fog") return makeVolumeFog();
  if (name == "raytrace") return makeRaytrace();
  std::string known;
  for (const auto& n : rendererNames()) known += (known.empty() ? "" : ", ") + n;
  for (const auto& n : workloadNames()) known += ", " + n;
  return makeError("renderer: unknown '" + std::string(name) + "' (known: " + known + ")");
}

}  // namespace tally::renderers
