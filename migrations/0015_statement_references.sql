-- No table changes on SQLite: its foreign keys stay as they are. On
-- PostgreSQL, four of them (passes to samples, samples to runs and to
-- screenshots, run_resources to runs) are checked once per statement
-- instead of once per row (migrations/postgresql/0015_statement_references.sql);
-- both engines keep one version number. Never edit a released migration.
SELECT 1;
