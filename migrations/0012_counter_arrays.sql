-- Nothing changes on SQLite: its counters stay one row per counter. On
-- PostgreSQL the same migration moves a pass's counters into arrays on the
-- pass's row behind a `counters` view with the table's columns
-- (migrations/postgresql/0012_counter_arrays.sql), because there the rows'
-- indexes and foreign key checks were most of the ingest. SQLite writes rows
-- as cheap function calls, and reads them with the queries it has now.
-- Applied after 0011_sites in one transaction, which then sets PRAGMA
-- user_version = 12. Never edit a released migration.
SELECT 1;
