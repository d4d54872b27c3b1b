-- Each run's summary over its samples, and its frame time, on the run's own
-- row: runs are immutable after ingest (a capture's runs and samples are
-- written in one transaction, and a re-ingest deletes and re-writes them), so
-- the runs listing reads them instead of aggregating every run's samples per
-- request (docs/benchmarks.md, "Runs summary written at ingest"). Applied
-- after 0012_counter_arrays in one transaction, which then sets PRAGMA
-- user_version = 13. Never edit a released migration.
--
-- The eleven aggregates are exactly those the listing computed before
-- (COUNT and AVG over the run's samples; 0 and NULL for a run without
-- samples); the ingest writes them with the same expressions
-- (server/store/run_summary.cpp), and the backfill below computes them for the
-- runs stored before.
ALTER TABLE runs ADD COLUMN sample_count INTEGER NOT NULL DEFAULT 0;
ALTER TABLE runs ADD COLUMN mean_frame_ms REAL;
ALTER TABLE runs ADD COLUMN mean_bytes REAL;
ALTER TABLE runs ADD COLUMN mean_frame_ms_instrumented REAL;
ALTER TABLE runs ADD COLUMN mean_overhead_ratio REAL;
ALTER TABLE runs ADD COLUMN image_compared INTEGER NOT NULL DEFAULT 0;
ALTER TABLE runs ADD COLUMN image_identical INTEGER NOT NULL DEFAULT 0;
ALTER TABLE runs ADD COLUMN mean_psnr REAL;
ALTER TABLE runs ADD COLUMN min_psnr REAL;
ALTER TABLE runs ADD COLUMN mean_footprint_bytes REAL;
ALTER TABLE runs ADD COLUMN mean_footprint_requested_bytes REAL;

-- The run's frame time (docs/statistics.md, "One frame time per run"): the
-- median, its 95% interval, the per-frame times it is over and its source
-- ("frames", "samples" or "none"). NULL source: not computed (runs ingested
-- before 0013, left so rather than read every per-frame time here); readers
-- compute it from the samples for those runs.
ALTER TABLE runs ADD COLUMN frame_time_median REAL;
ALTER TABLE runs ADD COLUMN frame_time_lower REAL;
ALTER TABLE runs ADD COLUMN frame_time_upper REAL;
ALTER TABLE runs ADD COLUMN frame_time_frames INTEGER CHECK (frame_time_frames IS NULL OR frame_time_frames >= 0);
ALTER TABLE runs ADD COLUMN frame_time_source TEXT
  CHECK (frame_time_source IS NULL OR frame_time_source IN ('frames', 'samples', 'none'));

UPDATE runs SET (sample_count, mean_frame_ms, mean_bytes, mean_frame_ms_instrumented, mean_overhead_ratio,
                 image_compared, image_identical, mean_psnr, min_psnr, mean_footprint_bytes,
                 mean_footprint_requested_bytes) =
  (SELECT COUNT(s.id), AVG(s.frame_ms), AVG(s.bytes), AVG(s.frame_ms_instrumented), AVG(s.overhead_ratio),
          COUNT(s.image_against), COUNT(CASE WHEN s.image_identical = 1 THEN 1 END), AVG(s.psnr), MIN(s.psnr),
          AVG(s.footprint_bytes), AVG(s.footprint_requested_bytes)
     FROM samples s WHERE s.run_id = runs.id);
