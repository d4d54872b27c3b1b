#include "renderers/renderer.hpp"

#include "renderers/renderers.hpp"

namespace tally::renderers {

std::vector<std::string> rendererNames() {
  return {"forward", "forward-zprepass", "deferred", "visbuffer", "visbuffer-lean"};
}

Result<std::unique_ptr<Renderer>> makeRenderer(std::string_view name) {
  if (name == "forward") return makeForward(false);
  if (name == "forward-zprepass") return makeForward(true);
  if (name == "deferred") return makeDeferred();
  if (name == "visbuffer-lean") return makeLeanVisbuffer();
  if (name == "visbuffer") return makeVisbuffer();
  std::string known;
  for (const auto& n : rendererNames()) known += (known.empty() ? "" : ", ") + n;
  return makeError("renderer: unknown '" + std::string(name) + "' (known: " + known + ")");
}

}  // namespace tally::renderers
