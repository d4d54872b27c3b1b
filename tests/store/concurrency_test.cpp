// One writer ingesting while readers query on their own connections: WAL and
// busy_timeout must keep every error (SQLITE_BUSY included) from the readers.
#include <atomic>
#include <thread>

#include "store_fixture.hpp"

namespace tally::store::testing {
namespace {

TEST(Concurrency, ReadersNeverFailWhileOneWriterIngests) {
  TempDb db;
  auto writer = openStore(db.path());
  ASSERT_NE(writer, nullptr);
  // Something to read from the start.
  auto seed = writer->jobs().create({{"renderers", {"forward"}}});
  ASSERT_TRUE(seed);
  Capture first = realisticCapture();
  ASSERT_TRUE(writer->runs().ingestCapture(seed->job.id, first.result, first.screenshots));

  constexpr int kReaders = 8;
  constexpr int kCaptures = 50;
  std::atomic<bool> writing{true};
  std::atomic<int> errors{0};
  std::atomic<int64_t> reads{0};
  std::atomic<int64_t> readsWhileWriting{0};
  std::vector<std::string> firstErrors(kReaders);
  std::vector<std::thread> readers;
  for (int r = 0; r < kReaders; ++r) {
    readers.emplace_back([&, r] {
      auto opened = Store::open(db.path(), {.readOnly = true});
      if (!opened) {
        ++errors;
        firstErrors[r] = opened.error();
        return;
      }
      Store& store = **opened;
      auto fail = [&](const std::string& what) {
        if (errors++ == 0 || firstErrors[r].empty()) firstErrors[r] = what;
      };
      // Keep reading until the writer is done, and at least a few rounds.
      for (int round = 0; writing.load() || round < 5; ++round) {
        auto page = store.runs().list(r % 2 ? RunFilter{.renderer = "deferred"} : RunFilter{}, {.limit = 5});
        if (!page) {
          fail(page.error());
          continue;
        }
        for (const auto& run : page->runs) {
          auto samples = store.runs().samples(run.id);
          if (!samples) {
            fail(samples.error());
            continue;
          }
          for (const auto& s : *samples) {
            auto sample = store.runs().sample(s.id);
            if (!sample) fail(sample.error());
            // A sample may vanish between the calls only through a re-ingest; this writer never re-ingests.
            else if (!sample->has_value() || (*sample)->passes.size() != 4)
              fail("sample incomplete");
            ++reads;
            if (writing.load()) ++readsWhileWriting;
          }
        }
        if (r == 0 && page->runs.size() >= 2) {
          auto cmp = store.runs().compare({page->runs[0].id, page->runs[1].id});
          if (!cmp) fail(cmp.error());
        }
      }
    });
  }

  for (int i = 0; i < kCaptures; ++i) {
    auto job = writer->jobs().create({{"renderers", {"forward", "deferred"}}, {"n", i}});
    ASSERT_TRUE(job) << job.error();
    auto claimed = writer->jobs().claim(1);
    ASSERT_TRUE(claimed) << claimed.error();
    Capture c = realisticCapture(i + 1);
    auto stored = writer->runs().ingestCapture(job->job.id, c.result, c.screenshots);
    ASSERT_TRUE(stored) << stored.error();
    ASSERT_TRUE(writer->jobs().finish(job->job.id, JobStatus::Done));
  }
  writing = false;
  for (auto& t : readers) t.join();

  for (int r = 0; r < kReaders; ++r)
    EXPECT_TRUE(firstErrors[r].empty()) << "reader " << r << ": " << firstErrors[r];
  EXPECT_EQ(errors.load(), 0);
  EXPECT_GT(reads.load(), 0);
  EXPECT_GT(readsWhileWriting.load(), 0) << "the readers never overlapped the writer";
  auto all = writer->runs().list({}, {.limit = 1000});
  ASSERT_TRUE(all);
  EXPECT_EQ(all->runs.size(), 2u * (kCaptures + 1));
  auto integrity = writer->integrityCheck();
  ASSERT_TRUE(integrity);
  EXPECT_EQ(*integrity, "ok");
}

}  // namespace
}  // namespace tally::store::testing
