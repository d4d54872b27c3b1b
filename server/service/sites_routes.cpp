// GET /api/samples/{id}/sites, /api/samples/{id}/draws, /api/runs/{id}/shaders
// and /api/runs/{id}/shaders/{name}: the sample's sites (or source lines),
// draws (or materials) ranked by bytes with their share of the pass, paged
// by limit and offset; a run's shader sources.
#include "service/sites_routes.hpp"

#include "service/routes.hpp"

namespace tally::service::detail {
namespace {

using api::Request;
using api::Response;
using nlohmann::json;

constexpr int64_t kMaxOffset = 1'000'000'000;

json passesJson(const std::vector<store::PassBytes>& passes) {
  json out = json::array();
  for (const auto& p : passes) {
    out.push_back({{"name", p.name}, {"position", p.position}, {"bytes", p.bytes}, {"sites", p.sites},
                   {"draws", p.draws}, {"materials", p.materials}});
  }
  return out;
}

// The row's share of its pass's bytes (0..1); null for a pass of no bytes.
json share(double bytes, int position, const std::vector<store::PassBytes>& passes) {
  for (const auto& p : passes) {
    if (p.position == position) return p.bytes > 0 ? json(bytes / p.bytes) : json(nullptr);
  }
  return nullptr;
}

// A 404 naming the sample's passes where the request names one it does not
// have. The store reads every pass of the sample whatever the filter, so one
// query both answers and checks the name.
void checkPass(const std::optional<std::string>& pass, int64_t sampleId, const std::vector<store::PassBytes>& passes) {
  if (!pass) return;
  std::string names;
  for (const auto& p : passes) {
    if (p.name == *pass) return;
    names += (names.empty() ? "" : ", ") + p.name;
  }
  missing("sample " + std::to_string(sampleId) + " has no pass \"" + *pass + "\" (its passes: " +
          (names.empty() ? "none" : names) + ")");
}

struct Paging {
  int64_t limit, offset;
};

Paging paging(const Request& req) {
  return {queryInt(req, "limit", 1, 1000).value_or(100), queryInt(req, "offset", 0, kMaxOffset).value_or(0)};
}

json pageFields(const Paging& page, int64_t total) {
  return {{"total", total},
          {"limit", page.limit},
          {"offset", page.offset},
          {"next_offset", page.offset + page.limit < total ? json(page.offset + page.limit) : json(nullptr)}};
}

json siteJson(const store::SiteRow& s, const std::vector<store::PassBytes>& passes) {
  return {{"pass", s.pass},
          {"pass_position", s.passPosition},
          {"shader", s.shader},
          {"stage", s.stage},
          {"entry_point", s.entryPoint},
          {"instruction", opt(s.instruction)},
          {"opcode", s.opcode},
          {"resource", s.resource},
          {"access", s.access},
          {"kind", opt(s.kind)},
          {"file", opt(s.file)},
          {"line", opt(s.line)},
          {"disassembly", s.disassembly},
          {"count", s.count},
          {"bytes", s.bytes},
          {"share", share(s.bytes, s.passPosition, passes)},
          {"sites", s.sites},
          {"resources", s.resources}};
}

Response getSites(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {"pass", "by", "limit", "offset"});
  int64_t id = pathId(req);
  std::string by = queryString(req, "by", 16).value_or("site");
  if (by != "site" && by != "line") invalid("by", "must be site or line");
  Paging page = paging(req);
  auto& store = reader(ctx);
  store::SiteQuery query{queryString(req, "pass"), by == "line" ? store::SiteGrouping::Line : store::SiteGrouping::Site,
                         page.limit, page.offset};
  auto result = check(store.runs().sites(id, query));
  if (!result) missing("no sample " + std::to_string(id));
  checkPass(query.pass, id, result->passes);
  json rows = json::array();
  for (const auto& s : result->rows) rows.push_back(siteJson(s, result->passes));
  json out = {{"sample", id}, {"by", by}, {"passes", passesJson(result->passes)}, {"sites", rows}};
  out.update(pageFields(page, result->total));
  return Response::ok(out);
}

Response getDraws(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {"pass", "by", "limit", "offset"});
  int64_t id = pathId(req);
  std::string by = queryString(req, "by", 16).value_or("draw");
  if (by != "draw" && by != "material") invalid("by", "must be draw or material");
  Paging page = paging(req);
  auto& store = reader(ctx);
  store::DrawQuery query{queryString(req, "pass"), by == "material", page.limit, page.offset};
  auto result = check(store.runs().draws(id, query));
  if (!result) missing("no sample " + std::to_string(id));
  checkPass(query.pass, id, result->passes);
  const auto& passes = result->passes;
  json draws = json::array(), materials = json::array(), rest = json::array();
  for (const auto& d : result->draws) {
    draws.push_back({{"pass", d.pass}, {"pass_position", d.passPosition}, {"rank", d.rank}, {"index", d.index},
                     {"name", d.name}, {"mesh", opt(d.mesh)}, {"material", opt(d.material)}, {"count", d.count},
                     {"bytes_read", d.bytesRead}, {"bytes_written", d.bytesWritten}, {"bytes", d.bytes},
                     {"share", share(d.bytes, d.passPosition, passes)}});
  }
  for (const auto& m : result->materials) {
    materials.push_back({{"pass", m.pass}, {"pass_position", m.passPosition}, {"material", m.material},
                         {"draws", m.draws}, {"bytes_read", m.bytesRead}, {"bytes_written", m.bytesWritten},
                         {"bytes", m.bytes}, {"share", share(m.bytes, m.passPosition, passes)}});
  }
  for (const auto& r : result->rests) {
    rest.push_back({{"pass", r.pass}, {"pass_position", r.passPosition}, {"draws", r.draws}, {"count", r.count},
                    {"bytes_read", r.bytesRead}, {"bytes_written", r.bytesWritten}, {"bytes", r.bytes},
                    {"share", share(r.bytes, r.passPosition, passes)}});
  }
  json out = {{"sample", id}, {"by", by}, {"passes", passesJson(passes)}, {"draws", draws},
              {"materials", materials}, {"rest", rest}};
  out.update(pageFields(page, result->total));
  return Response::ok(out);
}

Response listShaders(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  int64_t id = pathId(req);
  auto& store = reader(ctx);
  if (!check(store.runs().get(id))) missing("no run " + std::to_string(id));
  json shaders = json::array();
  for (const auto& s : check(store.runs().shaderSources(id))) {
    shaders.push_back({{"name", s.name}, {"hash", s.hash}, {"length", s.length}});
  }
  return Response::ok({{"run", id}, {"shaders", shaders}});
}

Response getShader(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  int64_t id = pathId(req);
  const std::string& name = req.param("name");
  auto& store = reader(ctx);
  auto source = check(store.runs().shaderSource(id, name));
  if (!source) {
    if (!check(store.runs().get(id))) missing("no run " + std::to_string(id));
    missing("run " + std::to_string(id) + " has no shader source \"" + name + "\"");
  }
  return Response::ok({{"run", id}, {"name", source->name}, {"hash", source->hash}, {"length", source->length},
                       {"lines", source->lines}, {"source", source->text}});
}

}  // namespace

std::map<int, std::vector<store::SiteRow>> topLinesPerPass(store::Store& store, int64_t sampleId, int top) {
  std::map<int, std::vector<store::SiteRow>> out;
  auto probe = check(store.runs().sites(sampleId, {std::nullopt, store::SiteGrouping::Line, 1, 0}));
  if (!probe) return out;
  for (const auto& pass : probe->passes) {
    if (pass.sites == 0) continue;
    auto lines = check(store.runs().sites(sampleId, {pass.name, store::SiteGrouping::Line, top, 0}));
    if (!lines) continue;
    // Passes of one name (rare) are told apart by position.
    for (auto& row : lines->rows) {
      if (row.passPosition == pass.position) out[pass.position].push_back(std::move(row));
    }
  }
  return out;
}

void addSiteRoutes(api::Router& router, ServiceContext& ctx) {
  auto route = [&ctx](RouteHandler fn) { return routed(ctx, fn); };
  router.get("/api/samples/{id}/sites", route(getSites));
  router.get("/api/samples/{id}/draws", route(getDraws));
  router.get("/api/runs/{id}/shaders", route(listShaders));
  router.get("/api/runs/{id}/shaders/{name}", route(getShader));
}

}  // namespace tally::service::detail
