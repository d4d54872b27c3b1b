-- PostgreSQL twin of migrations/0013_run_summary.sql: the same columns and
-- constraints, spelled for PostgreSQL. The comments there explain them.
-- Never edit a released migration.

ALTER TABLE runs
  ADD COLUMN sample_count                   BIGINT NOT NULL DEFAULT 0,
  ADD COLUMN mean_frame_ms                  DOUBLE PRECISION,
  ADD COLUMN mean_bytes                     DOUBLE PRECISION,
  ADD COLUMN mean_frame_ms_instrumented     DOUBLE PRECISION,
  ADD COLUMN mean_overhead_ratio            DOUBLE PRECISION,
  ADD COLUMN image_compared                 BIGINT NOT NULL DEFAULT 0,
  ADD COLUMN image_identical                BIGINT NOT NULL DEFAULT 0,
  ADD COLUMN mean_psnr                      DOUBLE PRECISION,
  ADD COLUMN min_psnr                       DOUBLE PRECISION,
  ADD COLUMN mean_footprint_bytes           DOUBLE PRECISION,
  ADD COLUMN mean_footprint_requested_bytes DOUBLE PRECISION,
  ADD COLUMN frame_time_median              DOUBLE PRECISION,
  ADD COLUMN frame_time_lower               DOUBLE PRECISION,
  ADD COLUMN frame_time_upper               DOUBLE PRECISION,
  ADD COLUMN frame_time_frames              BIGINT CHECK (frame_time_frames IS NULL OR frame_time_frames >= 0),
  ADD COLUMN frame_time_source              TEXT COLLATE "C"
    CHECK (frame_time_source IS NULL OR frame_time_source IN ('frames', 'samples', 'none'));

-- Per run, the same aggregates over the same index walk (the samples of one
-- run in camera order) as the listing's LATERAL subquery computed them, so
-- every sum adds in the same order; a run without samples gets 0 and NULL.
UPDATE runs SET (sample_count, mean_frame_ms, mean_bytes, mean_frame_ms_instrumented, mean_overhead_ratio,
                 image_compared, image_identical, mean_psnr, min_psnr, mean_footprint_bytes,
                 mean_footprint_requested_bytes) =
  (SELECT COUNT(s.id), AVG(s.frame_ms), AVG(s.bytes), AVG(s.frame_ms_instrumented), AVG(s.overhead_ratio),
          COUNT(s.image_against), COUNT(CASE WHEN s.image_identical = 1 THEN 1 END), AVG(s.psnr), MIN(s.psnr),
          AVG(s.footprint_bytes), AVG(s.footprint_requested_bytes)
     FROM samples s WHERE s.run_id = runs.id);
