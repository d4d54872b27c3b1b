-- PostgreSQL twin of migrations/0003_variants.sql: the same tables, columns, constraints
-- and indexes, spelled for PostgreSQL (BIGINT ids as identity columns, DOUBLE
-- PRECISION for REAL, BYTEA for BLOB, JSON checked by a cast to jsonb, text in
-- the C collation so ORDER BY sorts as SQLite does). The comments there
-- explain the columns. tests/store/migrations_test.cpp checks both sets
-- build the same schema. Never edit a released migration.

-- The run's canonical "options" ({} for the renderer as it is) and "variant"
-- label ("forward output=overdraw"); runs stored before are their renderer.
ALTER TABLE runs ADD COLUMN options TEXT COLLATE "C" NOT NULL DEFAULT '{}' CHECK (options::jsonb IS NOT NULL);
ALTER TABLE runs ADD COLUMN variant TEXT COLLATE "C";
UPDATE runs SET variant = renderer WHERE variant IS NULL;
-- Filters end in id, as for the other run filters (0001_initial).
CREATE INDEX runs_by_variant ON runs (variant, id);

-- The sample's "extras" object, and its "variant_error" stored as image_error
-- is: variant_against is NULL when the sample was not compared with a
-- reference variant; variant_psnr is NULL when the images are identical.
ALTER TABLE samples ADD COLUMN extras TEXT COLLATE "C" NOT NULL DEFAULT '{}' CHECK (extras::jsonb IS NOT NULL);
ALTER TABLE samples ADD COLUMN variant_against TEXT COLLATE "C";
ALTER TABLE samples ADD COLUMN variant_identical BIGINT;
ALTER TABLE samples ADD COLUMN variant_psnr DOUBLE PRECISION;
ALTER TABLE samples ADD COLUMN variant_max_abs DOUBLE PRECISION;
ALTER TABLE samples ADD COLUMN variant_mean_abs DOUBLE PRECISION;
