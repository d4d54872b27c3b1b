// Each run's summary over its samples (migration 0013), written at ingest.
#include "store/internal.hpp"

namespace tally::store::detail {

void writeRunSummaries(Connection* db, int64_t jobId) {
  // The statement of migrations/0013_run_summary.sql (and of its PostgreSQL
  // twin) for one job's runs: a correlated subquery per run, the same index
  // walk as the LATERAL subquery the listing used, so sums add in the same
  // order and the means are the same doubles (tests/store/run_summary_test.cpp).
  Statement update(db,
                   "UPDATE runs SET (sample_count, mean_frame_ms, mean_bytes, mean_frame_ms_instrumented, "
                   "mean_overhead_ratio, image_compared, image_identical, mean_psnr, min_psnr, "
                   "mean_footprint_bytes, mean_footprint_requested_bytes) = "
                   "(SELECT COUNT(s.id), AVG(s.frame_ms), AVG(s.bytes), AVG(s.frame_ms_instrumented), "
                   "AVG(s.overhead_ratio), COUNT(s.image_against), COUNT(CASE WHEN s.image_identical = 1 THEN 1 END), "
                   "AVG(s.psnr), MIN(s.psnr), AVG(s.footprint_bytes), AVG(s.footprint_requested_bytes) "
                   "FROM samples s WHERE s.run_id = runs.id) WHERE job_id = ?1");
  update.bind(1, jobId).run();
}

}  // namespace tally::store::detail
