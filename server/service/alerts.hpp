// Baselines, alerts and trends as routes: POST/GET /api/baselines,
// GET/DELETE /api/baselines/{id}, GET /api/alerts, GET/PATCH/POST
// /api/alerts/{id}, GET /api/trend (docs/api.md, "Baselines and alerts").
#pragma once

#include "api/router.hpp"
#include "service/service.hpp"

namespace tally::service {

// Added by addServiceRoutes; `context` must outlive the router.
void addAlertRoutes(api::Router& router, ServiceContext& context);

}  // namespace tally::service
