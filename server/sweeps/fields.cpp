#include "sweeps/fields.hpp"

namespace tally::sweeps::fields {

std::string joined(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

std::optional<Error> specObject(const nlohmann::json& j, const std::vector<std::string>& keys) {
  if (!j.is_object()) return fieldError("spec", "must be a JSON object, got " + show(j));
  return json_fields::unknownKey(j, "", keys);
}

Result<std::string> rendererName(const nlohmann::json& r, const std::string& field,
                                 const std::vector<std::string>& allowed,
                                 const std::vector<std::string>& knownRenderers, const std::string& whyNot) {
  const std::string list = joined(allowed);
  if (!r.is_string()) return fieldError(field, "must be a renderer name (one of " + list + ")");
  std::string name = r.get<std::string>();
  if (std::find(knownRenderers.begin(), knownRenderers.end(), name) == knownRenderers.end()) {
    return fieldError(field, "unknown renderer '" + name + "' (expected one of " + list + ")");
  }
  if (std::find(allowed.begin(), allowed.end(), name) == allowed.end()) {
    return fieldError(field, "'" + name + "' " + whyNot + " (expected one of " + list + ")");
  }
  return name;
}

}  // namespace tally::sweeps::fields
