-- The Tally build that made each run (docs/result-schema.md, "tally"): its
-- version and the git commit it was built from, so that results of
-- different builds can be told apart. NULL for runs stored before builds
-- recorded it. Applied after 0004_compute_passes in one transaction, which
-- then sets PRAGMA user_version = 5. Never edit a released migration.
ALTER TABLE runs ADD COLUMN tally_version TEXT;
ALTER TABLE runs ADD COLUMN tally_commit TEXT;
