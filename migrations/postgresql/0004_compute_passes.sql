-- PostgreSQL twin of migrations/0004_compute_passes.sql: the same tables, columns, constraints
-- and indexes, spelled for PostgreSQL (BIGINT ids as identity columns, DOUBLE
-- PRECISION for REAL, BYTEA for BLOB, JSON checked by a cast to jsonb, text in
-- the C collation so ORDER BY sorts as SQLite does). The comments there
-- explain the columns. tests/store/migrations_test.cpp checks both sets
-- build the same schema. Never edit a released migration.

ALTER TABLE passes ADD COLUMN compute_invocations DOUBLE PRECISION;
ALTER TABLE passes ADD COLUMN compute_invocations_statistic DOUBLE PRECISION;
