-- PostgreSQL twin of migrations/0014_compact_spreads.sql: count spreads of
-- n frames that all counted the counter's count are stored as n alone
-- (server/store/count_spread.hpp); the version keeps daemons built before
-- from reading them. Never edit a released migration.
--
-- And the ids that an ingest reserves by the hundred (samples, passes,
-- screenshots) are handed out in blocks: each nextval of these sequences
-- reserves the 1,024 ids from the value it returns, and the ingest takes
-- as many blocks as it needs (store/batch_insert.cpp, reserveIds). One
-- nextval per id was 1,160 calls for a 200-sample capture. Ids stay
-- unique; the rest of a block is skipped, and ids no longer follow the
-- order of commits across connections, which nothing reads them for
-- (runs, whose ids order the listing, still take one id per nextval).
ALTER TABLE samples ALTER COLUMN id SET INCREMENT BY 1024;
ALTER TABLE passes ALTER COLUMN id SET INCREMENT BY 1024;
ALTER TABLE screenshots ALTER COLUMN id SET INCREMENT BY 1024;

-- The checks that the samples' and passes' JSON columns parse as JSON go:
-- the store writes them only by serialising JSON it has parsed
-- (BatchInsert::add), and casting each to jsonb on every row was 45 % of
-- the samples' COPY and 20 % of the passes' (docs/benchmarks.md, "Ingest,
-- fourth pass"), as it was for the count spreads in 0012. The runs' own
-- stay: one row a run.
ALTER TABLE samples
  DROP CONSTRAINT IF EXISTS samples_camera_check,
  DROP CONSTRAINT IF EXISTS samples_extras_check,
  DROP CONSTRAINT IF EXISTS samples_frame_ms_spread_check,
  DROP CONSTRAINT IF EXISTS samples_frame_ms_frames_check;
ALTER TABLE passes
  DROP CONSTRAINT IF EXISTS passes_gpu_ms_spread_check,
  DROP CONSTRAINT IF EXISTS passes_gpu_ms_frames_check;
