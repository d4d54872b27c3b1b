// The fleet's hosts (docs/fleet.md): device requirements and how a device
// meets them, and the hosts table (registration, heartbeats, listing).
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <ctime>

#include "store/internal.hpp"

namespace tally::store {

using detail::guarded;
using nlohmann::json;

namespace {

std::string lower(std::string_view text) {
  std::string out(text);
  std::transform(out.begin(), out.end(), out.begin(), [](unsigned char c) { return std::tolower(c); });
  return out;
}

}  // namespace

std::string isoTimeFromMs(int64_t ms) {
  std::time_t seconds = static_cast<std::time_t>(ms / 1000);
  std::tm utc{};
  gmtime_r(&seconds, &utc);
  char text[80];  // room for any int the fields hold: no truncation to warn of
  std::snprintf(text, sizeof text, "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ", utc.tm_year + 1900, utc.tm_mon + 1,
                utc.tm_mday, utc.tm_hour, utc.tm_min, utc.tm_sec, static_cast<int>(ms % 1000));
  return text;
}

std::string vendorName(std::string_view vendorId) {
  // PCI vendor ids (and Khronos vendor ids for drivers without one).
  static const std::pair<const char*, const char*> kVendors[] = {
      {"0x10de", "NVIDIA"},   {"0x1002", "AMD"},      {"0x1022", "AMD"},      {"0x8086", "Intel"},
      {"0x13b5", "ARM"},      {"0x5143", "Qualcomm"}, {"0x1010", "Imagination"}, {"0x106b", "Apple"},
      {"0x144d", "Samsung"},  {"0x10005", "Mesa"},
  };
  std::string id = lower(vendorId);
  for (const auto& [hex, name] : kVendors) {
    if (id == hex) return name;
  }
  return std::string(vendorId);
}

json DeviceRequirement::toJson() const {
  json out = json::object();
  if (name) out["name"] = *name;
  if (vendor) out["vendor"] = *vendor;
  if (!features.empty()) out["features"] = features;
  return out;
}

Result<DeviceRequirement> deviceRequirementFromJson(const json& value) {
  DeviceRequirement r;
  if (value.is_string()) {
    if (value.get<std::string>().empty()) return Error("device", "must not be empty");
    r.name = value.get<std::string>();
    return r;
  }
  if (!value.is_object()) {
    return Error("device", "must be a device name (substring) or an object with name, vendor or features");
  }
  for (const auto& [key, field] : value.items()) {
    if (key == "name" || key == "vendor") {
      if (!field.is_string() || field.get<std::string>().empty())
        return Error("device." + key, "must be a non-empty string");
      (key == "name" ? r.name : r.vendor) = field.get<std::string>();
    } else if (key == "features") {
      if (!field.is_array()) return Error("device.features", "must be an array of feature names");
      for (const auto& f : field) {
        if (!f.is_string() || f.get<std::string>().empty())
          return Error("device.features", "each feature must be a non-empty string, got " + f.dump());
        r.features.push_back(f.get<std::string>());
      }
    } else {
      return Error("device." + key, "unknown field (name, vendor, features)");
    }
  }
  if (!r.name && !r.vendor && r.features.empty()) {
    return Error("device", "give at least one of name, vendor, features");
  }
  return r;
}

Result<std::optional<DeviceRequirement>> parseDeviceRequirement(const json& spec) {
  if (!spec.is_object() || !spec.contains("device") || spec["device"].is_null()) {
    return std::optional<DeviceRequirement>();
  }
  auto r = deviceRequirementFromJson(spec["device"]);
  if (!r) return r.failure();
  return std::optional<DeviceRequirement>(std::move(*r));
}

std::string deviceMismatch(const DeviceRequirement& requirement, const json& device) {
  if (!device.is_object()) return "no device known";
  std::string name = device.value("name", std::string());
  std::string vendorId = device.value("vendorID", std::string());
  if (requirement.name && lower(name).find(lower(*requirement.name)) == std::string::npos) {
    return "name '" + name + "' does not contain '" + *requirement.name + "'";
  }
  if (requirement.vendor) {
    std::string want = lower(*requirement.vendor);
    if (want != lower(vendorId) && want != lower(vendorName(vendorId))) {
      return "vendor " + vendorName(vendorId) + " (" + vendorId + ") is not " + *requirement.vendor;
    }
  }
  const json features = device.contains("features") && device["features"].is_object() ? device["features"]
                                                                                       : json::object();
  for (const auto& f : requirement.features) {
    auto it = features.find(f);
    if (it == features.end() || !it->is_boolean() || !it->get<bool>()) return "feature " + f + " is missing";
  }
  return "";
}

Result<bool> Hosts::join(const HostInfo& info, int64_t staleAfterMs,
                         const std::function<bool(const std::string&)>& instanceIsGone) {
  if (info.name.empty() || info.name.size() > 255) return makeError("host name: must be 1 to 255 characters");
  if (info.role != "worker" && info.role != "all") return makeError("host role: must be worker or all");
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return guarded<bool>("registerHost", [&]() -> Result<bool> {
    Transaction tx(db_, Transaction::Kind::Write);
    Statement existing(db_, std::string("SELECT instance, ") + nowMsSql(*db_) +
                                " - heartbeat_ms FROM hosts WHERE name = ?1" +
                                (db_->engine() == Engine::Postgres ? " FOR UPDATE" : ""));
    existing.bind(1, info.name);
    if (existing.step()) {
      RowReader row(existing);
      std::string instance = row.getText();
      int64_t ago = row.getInt();
      row.end();
      existing.run();
      if (instance != info.instance && ago < staleAfterMs && !(instanceIsGone && instanceIsGone(instance))) {
        return makeError("host name '" + info.name + "' is in use by a live daemon (heartbeat " +
                         std::to_string(ago / 1000) + " s ago); give each daemon its own --host-name");
      }
    }
    Statement upsert(db_, std::string("INSERT INTO hosts (name, instance, role, device, device_override, "
                                      "tally_version, tally_commit, heartbeat_ms) VALUES (?1, ?2, ?3, ?4, ?5, "
                                      "?6, ?7, ") +
                              nowMsSql(*db_) +
                              ") ON CONFLICT (name) DO UPDATE SET instance = excluded.instance, role = "
                              "excluded.role, device = excluded.device, device_override = "
                              "excluded.device_override, tally_version = excluded.tally_version, tally_commit = "
                              "excluded.tally_commit, heartbeat_ms = excluded.heartbeat_ms, started_at = " +
                              nowSql(*db_) + ", current_job = NULL");
    upsert.bind(1, info.name).bind(2, info.instance).bind(3, info.role);
    if (info.device.is_null()) {
      upsert.bind(4, nullptr);
    } else {
      upsert.bind(4, info.device);
    }
    upsert.bind(5, info.deviceOverride).bind(6, info.tallyVersion).bind(7, info.tallyCommit).run();
    tx.commit();
    return true;
  });
}

Result<bool> Hosts::heartbeat(const std::string& name, const std::string& instance,
                              std::optional<int64_t> currentJob) {
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return guarded<bool>("heartbeat", [&]() -> Result<bool> {
    Statement beat(db_, std::string("UPDATE hosts SET heartbeat_ms = ") + nowMsSql(*db_) +
                            ", current_job = ?3 WHERE name = ?1 AND instance = ?2");
    beat.bind(1, name).bind(2, instance).bind(3, currentJob).run();
    return db_->changes() > 0;
  });
}

Result<std::vector<Host>> Hosts::list(int64_t staleAfterMs) {
  std::lock_guard lock(mutex_);
  return guarded<std::vector<Host>>("listHosts", [&]() -> Result<std::vector<Host>> {
    Statement query(db_, std::string("SELECT name, instance, role, device, device_override, tally_version, "
                                     "tally_commit, started_at, heartbeat_ms, ") +
                             nowMsSql(*db_) +
                             " - heartbeat_ms, jobs_done, jobs_failed, current_job FROM hosts ORDER BY name");
    std::vector<Host> out;
    while (query.step()) {
      RowReader row(query);
      Host h;
      h.info.name = row.getText();
      h.info.instance = row.getText();
      h.info.role = row.getText();
      h.info.device = row.getJson();
      h.info.deviceOverride = row.getOptText();
      h.info.tallyVersion = row.getText();
      h.info.tallyCommit = row.getText();
      h.startedAt = row.getText();
      int64_t beatMs = row.getInt();
      int64_t agoMs = row.getInt();
      h.secondsSinceHeartbeat = static_cast<double>(agoMs) / 1000.0;
      h.alive = agoMs < staleAfterMs;
      h.jobsDone = row.getInt();
      h.jobsFailed = row.getInt();
      h.currentJob = row.getOptInt();
      row.end();
      h.lastHeartbeat = isoTimeFromMs(beatMs);  // UTC ISO-8601, as every other time the API gives
      out.push_back(std::move(h));
    }
    return out;
  });
}

}  // namespace tally::store
