-- PostgreSQL twin of migrations/0006_footprint.sql: the same tables, columns, constraints
-- and indexes, spelled for PostgreSQL (BIGINT ids as identity columns, DOUBLE
-- PRECISION for REAL, BYTEA for BLOB, JSON checked by a cast to jsonb, text in
-- the C collation so ORDER BY sorts as SQLite does). The comments there
-- explain the columns. tests/store/migrations_test.cpp checks both sets
-- build the same schema. Never edit a released migration.

-- The run's block size in bytes (the spec's "footprint": 32, 64 or 128).
ALTER TABLE runs ADD COLUMN footprint_block_bytes BIGINT
  CHECK (footprint_block_bytes IS NULL OR footprint_block_bytes IN (32, 64, 128));

-- A line's footprint per frame, averaged over the sample's counted frames.
ALTER TABLE counters ADD COLUMN footprint_bytes DOUBLE PRECISION CHECK (footprint_bytes IS NULL OR footprint_bytes >= 0);

-- The sample's footprint (the sum over its lines that have one) and the
-- requested bytes of those same lines, so that reuse (requested / footprint)
-- compares like with like; both NULL when no line has a footprint. Set by
-- ingest from the counters, as samples.bytes is.
ALTER TABLE samples ADD COLUMN footprint_bytes DOUBLE PRECISION;
ALTER TABLE samples ADD COLUMN footprint_requested_bytes DOUBLE PRECISION;
