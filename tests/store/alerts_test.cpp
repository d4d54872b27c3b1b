// Labels, baselines, the alert evaluation's claims and the webhook's outbox,
// on either engine (store.* on SQLite, store.postgresql on PostgreSQL):
// configurations ignore lights and labels, a baseline replaced is recorded,
// each run is evaluated once however many daemons claim at once, an
// evaluator's error stores nothing, and each alert is claimed for delivery
// by one claimer at a time.
#include <mutex>
#include <set>
#include <thread>

#include "store_fixture.hpp"

namespace tally::store::testing {
namespace {

class Alerts : public StoreTest {
 protected:
  // A job with `labels` whose capture stores the realistic capture's two runs
  // (forward, deferred) with `lights`; their ids, forward first.
  std::vector<int64_t> capture(const json& labels, int lights = 400, int seed = 0) {
    json spec = {{"renderers", {"forward", "deferred"}}};
    if (!labels.is_null()) spec["labels"] = labels;
    auto job = store_->jobs().create(spec);
    EXPECT_TRUE(job) << job.error();
    Capture c = realisticCapture(seed);
    for (auto& run : c.result["runs"]) run["lights"] = lights;
    ingest(job->job.id, c);
    RunFilter f;
    f.jobId = job->job.id;
    auto page = store_->runs().list(f, Page{});
    EXPECT_TRUE(page) << page.error();
    std::vector<int64_t> ids;
    for (const auto& r : page->runs) ids.insert(ids.begin(), r.id);  // oldest (forward) first
    return ids;
  }

  // Marks every run stored so far evaluated, testing nothing.
  void evaluateAll() {
    auto done = store_->alerts().evaluatePending(
        [](const RunRow&, const Baseline&) { return Result(std::vector<NewAlert>{}); }, 1000, false);
    ASSERT_TRUE(done) << done.error();
  }
};

NewAlert slower(double ratio) {
  NewAlert a;
  a.kind = "time";
  a.metric = "frame";
  a.verdict = "slower";
  a.ratio = ratio;
  a.ratioLower = ratio - 0.1;
  a.ratioUpper = std::numeric_limits<double>::infinity();  // stored as null
  a.pValue = 0.001;
  a.details = {{"reason", "test"}};
  return a;
}

TEST_F(Alerts, LabelsAreStoredWithTheJobAndFilterRuns) {
  auto a = capture({{"commit", "4f2a9c1"}, {"branch", "main"}});
  auto b = capture({{"commit", "77e0d12"}, {"branch", "main"}});
  auto none = capture(nullptr);
  auto run = store_->runs().get(a[0]);
  ASSERT_TRUE(run && *run);
  EXPECT_EQ((*run)->row.labels, json({{"commit", "4f2a9c1"}, {"branch", "main"}}));
  auto plain = store_->runs().get(none[0]);
  EXPECT_EQ((*plain)->row.labels, json::object());
  auto count = [&](std::vector<std::pair<std::string, std::string>> labels) {
    RunFilter f;
    f.labels = std::move(labels);
    auto page = store_->runs().list(f, Page{});
    EXPECT_TRUE(page) << page.error();
    std::set<int64_t> ids;
    for (const auto& r : page->runs) ids.insert(r.id);
    return ids;
  };
  EXPECT_EQ(count({{"commit", "4f2a9c1"}}), std::set<int64_t>(a.begin(), a.end()));
  EXPECT_EQ(count({{"branch", "main"}}).size(), a.size() + b.size());
  EXPECT_EQ(count({{"branch", "main"}, {"commit", "77e0d12"}}), std::set<int64_t>(b.begin(), b.end()));
  EXPECT_TRUE(count({{"commit", "nope"}}).empty());
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM job_labels"), 4);
}

TEST_F(Alerts, ABaselineIsARunsConfigurationWithoutLightsOrLabels) {
  auto first = capture({{"commit", "a"}});
  auto set = store_->alerts().setBaseline({first[1], 0.03, std::string("deferred atrium")});
  ASSERT_TRUE(set && *set) << (set ? "no run" : set.error());
  const Baseline& b = (*set)->baseline;
  EXPECT_FALSE((*set)->replaced);
  EXPECT_EQ(b.runId, first[1]);
  EXPECT_EQ(b.renderer, "deferred");
  EXPECT_EQ(b.scene, "atrium");
  EXPECT_EQ(b.width, 320);
  EXPECT_EQ(b.counting, "exact");
  EXPECT_DOUBLE_EQ(b.threshold, 0.03);
  EXPECT_EQ(b.status, "active");
  EXPECT_EQ(b.labels, json({{"commit", "a"}}));
  // More lights and other labels: the same configuration, so the same baseline.
  auto later = capture({{"commit", "b"}}, 4000, 1);
  auto runs = store_->alerts().configurationRuns(b.id, 100);
  ASSERT_TRUE(runs) << runs.error();
  std::vector<int64_t> ids;
  for (const auto& r : *runs) ids.push_back(r.id);
  EXPECT_EQ(ids, (std::vector<int64_t>{first[1], later[1]}));
  // A new baseline replaces the old one, which is kept and says so.
  auto again = store_->alerts().setBaseline({later[1], 0.05, std::nullopt});
  ASSERT_TRUE(again && *again);
  EXPECT_EQ((*again)->replaced, b.id);
  auto old = store_->alerts().getBaseline(b.id);
  ASSERT_TRUE(old && *old);
  EXPECT_EQ((*old)->status, "replaced");
  EXPECT_EQ((*old)->replacedBy, (*again)->baseline.id);
  EXPECT_TRUE((*old)->endedAt);
  auto active = store_->alerts().listBaselines();
  ASSERT_TRUE(active);
  ASSERT_EQ(active->size(), 1u);
  EXPECT_EQ((*active)[0].id, (*again)->baseline.id);
  EXPECT_EQ(store_->alerts().listBaselines(true)->size(), 2u);
  // Removing keeps the row; removing twice changes nothing; unknown ids are empty.
  auto removed = store_->alerts().removeBaseline((*again)->baseline.id);
  ASSERT_TRUE(removed && *removed);
  EXPECT_EQ((*removed)->status, "removed");
  EXPECT_TRUE(store_->alerts().listBaselines()->empty());
  EXPECT_EQ((*store_->alerts().removeBaseline((*again)->baseline.id))->status, "removed");
  EXPECT_FALSE(*store_->alerts().removeBaseline(987654));
  EXPECT_FALSE(*store_->alerts().setBaseline({987654, 0.05, std::nullopt}));
  EXPECT_FALSE(store_->alerts().setBaseline({first[0], -1, std::nullopt}));
}

TEST_F(Alerts, NewRunsAreTestedOnceAgainstAnOlderBaseline) {
  auto first = capture({{"commit", "a"}});
  auto baseline = store_->alerts().setBaseline({first[0], 0.05, std::nullopt});
  ASSERT_TRUE(baseline && *baseline);
  auto second = capture({{"commit", "b"}}, 4000, 1);
  std::vector<std::pair<int64_t, int64_t>> calls;  // run, baseline run
  auto evaluator = [&](const RunRow& run, const Baseline& b) {
    calls.emplace_back(run.id, b.runId);
    EXPECT_EQ(run.lights, 4000);
    EXPECT_EQ(run.labels, json({{"commit", "b"}}));
    return Result(std::vector<NewAlert>{slower(1.4)});
  };
  auto done = store_->alerts().evaluatePending(evaluator, 100, true);
  ASSERT_TRUE(done) << done.error();
  // All four runs evaluated; only the forward run after the baseline tested
  // (the baseline run itself and the deferred runs have nothing to test against).
  EXPECT_EQ(done->runs, 4);
  EXPECT_EQ(done->tested, 1);
  EXPECT_EQ(calls, (std::vector<std::pair<int64_t, int64_t>>{{second[0], first[0]}}));
  ASSERT_EQ(done->alertIds.size(), 1u);
  auto alert = store_->alerts().get(done->alertIds[0]);
  ASSERT_TRUE(alert && *alert);
  EXPECT_EQ((*alert)->runId, second[0]);
  EXPECT_EQ((*alert)->baselineRunId, first[0]);
  EXPECT_EQ((*alert)->baselineId, (*baseline)->baseline.id);
  EXPECT_EQ((*alert)->figures.verdict, "slower");
  EXPECT_DOUBLE_EQ(*(*alert)->figures.ratio, 1.4);
  EXPECT_FALSE((*alert)->figures.ratioUpper);  // +inf is stored as null
  EXPECT_EQ((*alert)->figures.details["reason"], "test");
  EXPECT_EQ((*alert)->status, "open");
  EXPECT_EQ((*alert)->delivery, "pending");
  // Nothing left: a second pass tests nothing.
  calls.clear();
  auto again = store_->alerts().evaluatePending(evaluator, 100, true);
  ASSERT_TRUE(again);
  EXPECT_EQ(again->runs, 0);
  EXPECT_TRUE(calls.empty());
  auto baselineRow = store_->alerts().getBaseline((*baseline)->baseline.id);
  EXPECT_EQ((*baselineRow)->openAlerts, 1);
}

TEST_F(Alerts, AnEvaluatorErrorStoresNothing) {
  auto first = capture(nullptr);
  ASSERT_TRUE(*store_->alerts().setBaseline({first[0], 0.05, std::nullopt}));
  evaluateAll();
  capture(nullptr, 400, 1);
  auto failing = [](const RunRow&, const Baseline&) -> Result<std::vector<NewAlert>> {
    return makeError("store unreachable");
  };
  auto done = store_->alerts().evaluatePending(failing, 100, false);
  ASSERT_FALSE(done);
  EXPECT_NE(done.error().find("store unreachable"), std::string::npos) << done.error();
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM runs WHERE evaluated = 0"), 2);
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM alerts"), 0);
  // The next pass, with a working evaluator, takes them.
  auto ok = store_->alerts().evaluatePending(
      [](const RunRow&, const Baseline&) { return Result(std::vector<NewAlert>{slower(1.2)}); }, 100, false);
  ASSERT_TRUE(ok) << ok.error();
  EXPECT_EQ(ok->tested, 1);
  EXPECT_EQ((*store_->alerts().get(ok->alertIds.at(0)))->delivery, "none");
}

// Four daemons evaluating at once, each on its own connection: every run has
// exactly one alert. On PostgreSQL (claims with SKIP LOCKED) every run is also
// tested exactly once; on SQLite, which tests outside its write lock, a run
// may be tested twice, but its alerts are stored once.
TEST_F(Alerts, ConcurrentEvaluatorsTestEachRunOnce) {
  auto first = capture(nullptr);
  ASSERT_TRUE(*store_->alerts().setBaseline({first[0], 0.05, std::nullopt}));
  ASSERT_TRUE(*store_->alerts().setBaseline({first[1], 0.05, std::nullopt}));
  evaluateAll();
  constexpr int kCaptures = 12;
  std::set<int64_t> expected;
  for (int i = 0; i < kCaptures; ++i) {
    for (int64_t id : capture(nullptr, 400, i + 1)) expected.insert(id);
  }
  std::mutex mutex;
  std::multiset<int64_t> tested;
  std::vector<std::thread> daemons;
  for (int d = 0; d < 4; ++d) {
    daemons.emplace_back([&] {
      auto store = Store::open(db_.path());
      ASSERT_TRUE(store) << store.error();
      auto evaluator = [&](const RunRow& run, const Baseline&) {
        {
          std::lock_guard lock(mutex);
          tested.insert(run.id);
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(2));  // a real test takes a while
        return Result(std::vector<NewAlert>{slower(1.3)});
      };
      while (true) {
        auto done = (*store)->alerts().evaluatePending(evaluator, 2, false);
        ASSERT_TRUE(done) << done.error();
        if (done->runs == 0) break;
      }
    });
  }
  for (auto& t : daemons) t.join();
  if (db_.postgres()) {
    EXPECT_EQ(tested.size(), expected.size());
  }
  EXPECT_EQ(std::set<int64_t>(tested.begin(), tested.end()), expected);
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM alerts"), static_cast<int64_t>(expected.size()));
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(DISTINCT run_id) FROM alerts"),
            static_cast<int64_t>(expected.size()));
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM runs WHERE evaluated = 0"), 0);
}

TEST_F(Alerts, StatusListsAndCounts) {
  auto first = capture(nullptr);
  auto baseline = store_->alerts().setBaseline({first[0], 0.05, std::nullopt});
  evaluateAll();
  for (int i = 0; i < 3; ++i) capture(nullptr, 400, i + 1);
  auto done = store_->alerts().evaluatePending(
      [](const RunRow&, const Baseline&) {
        return Result(std::vector<NewAlert>{slower(1.5), slower(1.6)});
      },
      100, false);
  ASSERT_TRUE(done);
  ASSERT_EQ(done->alertIds.size(), 6u);
  auto acked = store_->alerts().setStatus(done->alertIds[0], AlertStatus::Acknowledged);
  ASSERT_TRUE(acked && *acked);
  EXPECT_EQ((*acked)->status, "acknowledged");
  EXPECT_TRUE((*acked)->updatedAt);
  EXPECT_FALSE(*store_->alerts().setStatus(987654, AlertStatus::Fixed));
  auto counts = store_->alerts().counts();
  ASSERT_TRUE(counts);
  EXPECT_EQ((*counts)["open"], 5);
  EXPECT_EQ((*counts)["acknowledged"], 1);
  EXPECT_EQ((*counts)["fixed"], 0);
  AlertFilter open;
  open.status = AlertStatus::Open;
  auto page = store_->alerts().list(open, Page{2, ""});
  ASSERT_TRUE(page);
  ASSERT_EQ(page->alerts.size(), 2u);
  EXPECT_GT(page->alerts[0].id, page->alerts[1].id);  // newest first
  std::vector<int64_t> seen;
  Page next{2, ""};
  while (true) {
    auto p = store_->alerts().list(open, next);
    ASSERT_TRUE(p);
    for (const auto& a : p->alerts) seen.push_back(a.id);
    if (p->nextCursor.empty()) break;
    next.cursor = p->nextCursor;
  }
  EXPECT_EQ(seen.size(), 5u);
  AlertFilter byBaseline;
  byBaseline.baselineId = (*baseline)->baseline.id;
  EXPECT_EQ(store_->alerts().list(byBaseline, Page{})->alerts.size(), 6u);
  byBaseline.baselineId = 987654;
  EXPECT_TRUE(store_->alerts().list(byBaseline, Page{})->alerts.empty());
  EXPECT_EQ(store_->alerts().configurationAlerts((*baseline)->baseline.id, 100)->size(), 6u);
  EXPECT_FALSE(store_->alerts().list({}, Page{0, ""}));
}

TEST_F(Alerts, OutboxClaimsRetriesAndFinishes) {
  auto first = capture(nullptr);
  ASSERT_TRUE(*store_->alerts().setBaseline({first[0], 0.05, std::nullopt}));
  evaluateAll();
  capture(nullptr, 400, 1);
  capture(nullptr, 400, 2);
  auto done = store_->alerts().evaluatePending(
      [](const RunRow&, const Baseline&) { return Result(std::vector<NewAlert>{slower(1.5)}); }, 100, true);
  ASSERT_TRUE(done);
  ASSERT_EQ(done->alertIds.size(), 2u);
  auto claimed = store_->alerts().claimDeliveries(10, 60000);
  ASSERT_TRUE(claimed) << claimed.error();
  ASSERT_EQ(claimed->size(), 2u);
  EXPECT_EQ((*claimed)[0].deliveryAttempts, 1);
  // Claimed: nobody else takes them while they are being posted.
  EXPECT_TRUE(store_->alerts().claimDeliveries(10, 60000)->empty());
  // One delivered, one failed with a retry due at once.
  ASSERT_TRUE(*store_->alerts().finishDelivery((*claimed)[0].id, true, "", std::nullopt));
  ASSERT_TRUE(*store_->alerts().finishDelivery((*claimed)[1].id, false, "HTTP 503", int64_t{0}));
  auto delivered = *store_->alerts().get((*claimed)[0].id);
  EXPECT_EQ(delivered->delivery, "delivered");
  EXPECT_TRUE(delivered->deliveredAt);
  auto retried = *store_->alerts().get((*claimed)[1].id);
  EXPECT_EQ(retried->delivery, "pending");
  EXPECT_EQ(retried->deliveryError, "HTTP 503");
  auto again = store_->alerts().claimDeliveries(10, 60000);
  ASSERT_EQ(again->size(), 1u);
  EXPECT_EQ((*again)[0].id, (*claimed)[1].id);
  EXPECT_EQ((*again)[0].deliveryAttempts, 2);
  // A retry in the future is not due yet; giving up fails it for good.
  ASSERT_TRUE(*store_->alerts().finishDelivery((*again)[0].id, false, "HTTP 500", int64_t{3600000}));
  EXPECT_TRUE(store_->alerts().claimDeliveries(10, 60000)->empty());
  ASSERT_TRUE(*store_->alerts().finishDelivery((*again)[0].id, false, "HTTP 500", std::nullopt));
  EXPECT_EQ((*store_->alerts().get((*again)[0].id))->delivery, "failed");
  // A delivered alert is not finished again.
  EXPECT_FALSE(*store_->alerts().finishDelivery((*claimed)[0].id, false, "late", std::nullopt));
  EXPECT_EQ((*store_->alerts().get((*claimed)[0].id))->delivery, "delivered");
}

// Four senders on their own connections: each pending alert is claimed by
// exactly one of them.
TEST_F(Alerts, ConcurrentSendersClaimEachAlertOnce) {
  auto first = capture(nullptr);
  ASSERT_TRUE(*store_->alerts().setBaseline({first[0], 0.05, std::nullopt}));
  evaluateAll();
  for (int i = 0; i < 10; ++i) capture(nullptr, 400, i + 1);
  auto done = store_->alerts().evaluatePending(
      [](const RunRow&, const Baseline&) {
        return Result(std::vector<NewAlert>{slower(1.5), slower(1.7)});
      },
      100, true);
  ASSERT_TRUE(done);
  ASSERT_EQ(done->alertIds.size(), 20u);
  std::mutex mutex;
  std::multiset<int64_t> posted;
  std::vector<std::thread> senders;
  for (int s = 0; s < 4; ++s) {
    senders.emplace_back([&] {
      auto store = Store::open(db_.path());
      ASSERT_TRUE(store) << store.error();
      while (true) {
        auto claimed = (*store)->alerts().claimDeliveries(3, 60000);
        ASSERT_TRUE(claimed) << claimed.error();
        if (claimed->empty()) break;
        for (const auto& a : *claimed) {
          {
            std::lock_guard lock(mutex);
            posted.insert(a.id);
          }
          ASSERT_TRUE(*(*store)->alerts().finishDelivery(a.id, true, "", std::nullopt));
        }
      }
    });
  }
  for (auto& t : senders) t.join();
  EXPECT_EQ(posted.size(), 20u);
  EXPECT_EQ(std::set<int64_t>(posted.begin(), posted.end()).size(), 20u);
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM alerts WHERE delivery = 'delivered'"), 20);
}

}  // namespace
}  // namespace tally::store::testing
