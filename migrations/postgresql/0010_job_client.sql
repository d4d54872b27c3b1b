-- PostgreSQL twin of migrations/0010_job_client.sql: the same column and
-- index, spelled for PostgreSQL (text in the C collation). The comments there
-- explain the column. tests/store/migrations_test.cpp checks both sets build
-- the same schema. Never edit a released migration.

ALTER TABLE jobs ADD COLUMN client TEXT COLLATE "C";
CREATE INDEX jobs_by_client ON jobs (client, status);
