// Checks a JSON value against a schema of Tally's OpenAPI document: the
// subset the document uses (local $ref, type, nullable, required, properties,
// additionalProperties, items, enum, minimum, maximum, minItems, maxItems).
// A keyword outside that subset is itself reported, so the document cannot
// grow a constraint that this check silently ignores. Stricter than JSON
// Schema in one way: a missing additionalProperties means none are allowed,
// so every field a response carries must be documented.
#pragma once

#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace tally::testing {

class OpenApiChecker {
 public:
  explicit OpenApiChecker(nlohmann::json document) : doc_(std::move(document)) {}

  // The problems found, each naming the path in the value ("$.runs[0].id").
  std::vector<std::string> check(const nlohmann::json& value, const nlohmann::json& schema) const {
    std::vector<std::string> problems;
    walk(value, schema, "$", problems, 0);
    return problems;
  }

  // The schema of a path's response: paths[path][method].responses[status].content[application/json].schema.
  nlohmann::json responseSchema(const std::string& path, const std::string& method, const std::string& status) const {
    const auto& response = doc_.at("paths").at(path).at(method).at("responses").at(status);
    return response.at("content").at("application/json").at("schema");
  }

 private:
  const nlohmann::json& resolve(const nlohmann::json& schema) const {
    const std::string prefix = "#/components/schemas/";
    std::string ref = schema.at("$ref").get<std::string>();
    if (ref.rfind(prefix, 0) != 0) throw std::runtime_error("unsupported $ref " + ref);
    return doc_.at("components").at("schemas").at(ref.substr(prefix.size()));
  }

  static bool hasType(const nlohmann::json& v, const std::string& type) {
    if (type == "object") return v.is_object();
    if (type == "array") return v.is_array();
    if (type == "string") return v.is_string();
    if (type == "integer") return v.is_number_integer();
    if (type == "number") return v.is_number();
    if (type == "boolean") return v.is_boolean();
    return false;
  }

  void walk(const nlohmann::json& v, const nlohmann::json& schema, const std::string& at,
            std::vector<std::string>& problems, int depth) const {
    if (depth > 64) {
      problems.push_back(at + ": schema nests too deeply");
      return;
    }
    if (schema.contains("$ref")) {
      walk(v, resolve(schema), at, problems, depth + 1);
      return;
    }
    static const std::set<std::string> known = {
        "type", "nullable", "required", "properties", "additionalProperties", "items", "enum", "minimum", "maximum",
        "minItems", "maxItems", "description", "format", "example"};
    for (const auto& [key, unused] : schema.items()) {
      if (!known.count(key)) problems.push_back(at + ": the checker does not know schema keyword " + key);
    }
    if (v.is_null()) {
      if (!schema.value("nullable", false)) problems.push_back(at + ": null, but not nullable");
      return;
    }
    if (schema.contains("type") && !hasType(v, schema["type"].get<std::string>())) {
      problems.push_back(at + ": expected " + schema["type"].get<std::string>() + ", got " + v.dump().substr(0, 60));
      return;
    }
    if (schema.contains("enum")) {
      bool found = false;
      for (const auto& e : schema["enum"]) found = found || e == v;
      if (!found) problems.push_back(at + ": " + v.dump() + " is not in " + schema["enum"].dump());
    }
    if (v.is_number()) {
      if (schema.contains("minimum") && v.get<double>() < schema["minimum"].get<double>()) {
        problems.push_back(at + ": below the minimum");
      }
      if (schema.contains("maximum") && v.get<double>() > schema["maximum"].get<double>()) {
        problems.push_back(at + ": above the maximum");
      }
    }
    if (v.is_array()) {
      if (schema.contains("minItems") && v.size() < schema["minItems"].get<size_t>()) {
        problems.push_back(at + ": fewer items than minItems");
      }
      if (schema.contains("maxItems") && v.size() > schema["maxItems"].get<size_t>()) {
        problems.push_back(at + ": more items than maxItems");
      }
      if (schema.contains("items")) {
        for (size_t i = 0; i < v.size(); ++i) {
          walk(v[i], schema["items"], at + "[" + std::to_string(i) + "]", problems, depth + 1);
        }
      }
    }
    if (v.is_object()) {
      for (const auto& name : schema.value("required", nlohmann::json::array())) {
        if (!v.contains(name.get<std::string>())) problems.push_back(at + ": missing required " + name.get<std::string>());
      }
      const nlohmann::json properties = schema.value("properties", nlohmann::json::object());
      for (const auto& [key, item] : v.items()) {
        if (properties.contains(key)) {
          walk(item, properties[key], at + "." + key, problems, depth + 1);
          continue;
        }
        const nlohmann::json extra = schema.value("additionalProperties", nlohmann::json(false));
        if (extra.is_boolean()) {
          if (!extra.get<bool>()) problems.push_back(at + ": field " + key + " is not documented");
        } else {
          walk(item, extra, at + "." + key, problems, depth + 1);
        }
      }
    }
  }

  nlohmann::json doc_;
};

}  // namespace tally::testing
