// tally hosts, sweeps, sweep, export: the fleet, its stability sweeps and exports.
#include "commands.hpp"

#include <unistd.h>

#include <sys/stat.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "command_support.hpp"
#include "tables.hpp"

namespace tally::client {

namespace {

using Align = Table::Align;

}  // namespace

int runHosts(ApiClient& api, Io& io) {
  auto res = api.listHosts();
  if (!res) return fail(io, res.error());
  if (io.json) {
    printJson(io, *res);
    return 0;
  }
  Table t({{"NAME"},
           {"ROLE"},
           {"DEVICE"},
           {"DRIVER"},
           {"VERSION"},
           {"HEARTBEAT", Align::Right},
           {"STATE"},
           {"DONE", Align::Right},
           {"FAILED", Align::Right},
           {"JOB", Align::Right}});
  int stale = 0;
  for (const auto& host : hostList(*res)) {
    HostView h = hostView(host);
    std::string device = !h.deviceOverride.empty() ? h.deviceOverride + " (override)"
                         : h.probed                ? orMissing(h.deviceName)
                                                   : "(not probed)";
    std::string version = orMissing(h.tallyVersion);
    if (!h.tallyCommit.empty()) version += " (" + h.tallyCommit + ")";
    std::string state = !h.alive ? kMissing : *h.alive ? "alive" : "stale";
    stale += h.alive && !*h.alive;
    auto count = [](std::optional<int64_t> n) { return n ? std::to_string(*n) : std::string(kMissing); };
    t.addRow({h.name, orMissing(h.role), device, h.probed ? orMissing(h.driver) : kMissing, version,
              ago(h.secondsSinceHeartbeat), state, count(h.jobsDone), count(h.jobsFailed),
              orMissing(h.currentJob)});
  }
  t.print(io.out);
  if (stale) {
    auto after = staleAfterSeconds(*res);
    io.err << stale << (stale == 1 ? " host is" : " hosts are") << " stale: no heartbeat"
           << (after ? " in the last " + fixedOrSci(*after) + " s" : std::string(" lately")) << '\n';
  }
  return 0;
}


namespace {

// {"relative": 0.001} -> "relative 0.001"; several keys joined by ", ".
std::string thresholdText(const json& threshold) {
  if (!threshold.is_object()) return threshold.is_null() ? kMissing : threshold.dump();
  std::string text;
  for (const auto& [key, value] : threshold.items()) {
    text += (text.empty() ? "" : ", ") + key + " " + (value.is_number() ? fixedOrSci(value.get<double>()) : value.dump());
  }
  return text.empty() ? kMissing : text;
}

// The list's one-cell summary of fails_at: per swept parameter, how many of
// its groups fail ("distance 1/1, far_over_near 1/2"), or "holds".
std::string failsSummary(const SweepView& s) {
  if (s.failsAt.is_null()) return "holds";
  std::vector<std::pair<std::string, std::pair<int, int>>> counts;  // swept -> failing, groups
  for (const auto& row : failsAtRows(s.failsAt, s.parameters)) {
    auto it = std::find_if(counts.begin(), counts.end(), [&](const auto& c) { return c.first == row.swept; });
    if (it == counts.end()) it = counts.insert(counts.end(), {row.swept, {0, 0}});
    it->second.first += row.value.empty() ? 0 : 1;
    it->second.second += 1;
  }
  std::string text;
  for (const auto& [swept, n] : counts) {
    text += (text.empty() ? "" : ", ") + (swept.empty() ? std::string("groups") : swept) + " " +
            std::to_string(n.first) + "/" + std::to_string(n.second);
  }
  return text;
}

}  // namespace

int runSweeps(ApiClient& api, const SweepsArgs& args, Io& io) {
  auto res = args.all ? api.listAllSweeps(args.filters, args.limit) : api.listSweeps(args.filters, args.limit);
  return printListing(io, res, args.all, "sweeps",
                      {{"ID", Align::Right},
                       {"CAPTURE", Align::Right},
                       {"NAME"},
                       {"CREATED"},
                       {"DEVICE"},
                       {"POINTS", Align::Right},
                       {"THRESHOLD"},
                       {"FAILING GROUPS"}},
                      [](const json& page, Table& t) {
                        for (const auto& sweep : sweepList(page)) {
                          SweepView s = sweepView(sweep);
                          t.addRow({s.id, orMissing(s.capture), s.name, orMissing(s.createdAt),
                                    orMissing(s.device), s.points ? std::to_string(*s.points) : kMissing,
                                    thresholdText(s.threshold), failsSummary(s)});
                        }
                      });
}

int runSweep(ApiClient& api, const std::string& sweepId, Io& io) {
  auto res = api.getSweep(sweepId);
  if (!res) return fail(io, res.error());
  if (io.json) {
    printJson(io, *res);
    return 0;
  }
  SweepView s = sweepView(*res);
  const json result = res->is_object() ? res->value("result", json::object()) : json::object();
  io.out << "sweep " << s.id << ": " << s.name << "   capture: " << orMissing(s.capture) << '\n';
  io.out << "device: " << orMissing(s.device) << "   created: " << orMissing(s.createdAt)
         << "   points: " << (s.points ? std::to_string(*s.points) : kMissing)
         << "   threshold: " << thresholdText(s.threshold) << "\n\n";

  if (s.failsAt.is_null()) {
    io.out << "fails at: nowhere; every point holds over the range\n\n";
  } else {
    Table fails({{"SWEPT"}, {"GROUP"}, {"FAILS AT", Align::Right}});
    for (const auto& row : failsAtRows(s.failsAt, s.parameters)) {
      fails.addRow({orMissing(row.swept), row.group.empty() ? kMissing : row.group,
                    row.value.empty() ? "holds over the range" : row.value});
    }
    fails.print(io.out);
    io.out << '\n';
  }

  // Points: the parameters, then every value the plots draw.
  std::vector<std::string> columns = s.parameters;
  if (result.contains("plots") && result["plots"].is_array()) {
    for (const auto& plot : result["plots"]) {
      for (const char* axis : {"x", "y"}) {
        std::string path = plot.is_object() && plot.contains(axis) ? idString(plot[axis]) : "";
        if (!path.empty() && std::find(columns.begin(), columns.end(), path) == columns.end()) columns.push_back(path);
      }
    }
  }
  std::vector<Table::Column> header;
  for (size_t i = 0; i < columns.size(); ++i) header.push_back({columns[i], Align::Right});
  Table points(header);
  if (result.contains("points") && result["points"].is_array()) {
    for (const auto& point : result["points"]) {
      std::vector<std::string> cells;
      for (const auto& c : columns) {
        json v = pointValue(point, c);
        cells.push_back(v.is_null() ? kMissing : v.is_number() ? fixedOrSci(v.get<double>()) : idString(v));
      }
      points.addRow(cells);
    }
  }
  points.print(io.out);
  return 0;
}

Result<bool> writeFileAtomically(const std::string& path, const std::string& data) {
  namespace fs = std::filesystem;
  fs::path target(path);
  fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::string pattern = (dir / ("." + target.filename().string() + ".tmp.XXXXXX")).string();
  std::vector<char> name(pattern.begin(), pattern.end());
  name.push_back('\0');
  int fd = ::mkstemp(name.data());
  if (fd < 0) return makeError("cannot create a temporary file beside " + path + ": " + std::strerror(errno));
  size_t written = 0;
  while (written < data.size()) {
    ssize_t n = ::write(fd, data.data() + written, data.size() - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      std::string reason = std::strerror(errno);
      ::close(fd);
      ::unlink(name.data());
      return makeError("cannot write " + path + ": " + reason);
    }
    written += static_cast<size_t>(n);
  }
  ::fchmod(fd, 0644);
  if (::fsync(fd) != 0 || ::close(fd) != 0) {
    ::unlink(name.data());
    return makeError("cannot write " + path + ": " + std::strerror(errno));
  }
  if (::rename(name.data(), path.c_str()) != 0) {
    std::string reason = std::strerror(errno);
    ::unlink(name.data());
    return makeError("cannot rename to " + path + ": " + reason);
  }
  return true;
}

int runExport(ApiClient& api, const ExportArgs& args, Io& io) {
  auto body = args.trace ? api.sampleTrace(*args.trace) : api.exportRuns(args.format, args.filters);
  if (!body) return fail(io, body.error());
  if (args.output.empty() || args.output == "-") {
    io.out << *body << std::flush;
    return 0;
  }
  auto written = writeFileAtomically(args.output, *body);
  if (!written) return fail(io, written.error());
  io.err << "wrote " << args.output << " (" << humanBytes(static_cast<double>(body->size())) << ")\n";
  return 0;
}

}  // namespace tally::client
