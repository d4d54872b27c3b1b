-- PostgreSQL twin of migrations/0008_frame_times.sql: the same columns and
-- constraints, spelled for PostgreSQL (JSON checked by a cast to jsonb, text
-- in the C collation). The comments there explain the columns.
-- tests/store/migrations_test.cpp checks both sets build the same schema.
-- Never edit a released migration.

-- JSON arrays of milliseconds, one entry per frame; NULL for samples and
-- passes stored before, or ingested from results without them.
ALTER TABLE samples ADD COLUMN frame_ms_frames TEXT COLLATE "C"
  CHECK (frame_ms_frames IS NULL OR frame_ms_frames::jsonb IS NOT NULL);
ALTER TABLE passes ADD COLUMN gpu_ms_frames TEXT COLLATE "C"
  CHECK (gpu_ms_frames IS NULL OR gpu_ms_frames::jsonb IS NOT NULL);
