-- Compute passes (docs/result-schema.md, "Passes"): a pass that dispatches
-- stores its counted compute invocations and the pipeline statistic beside
-- the fragment ones. NULL for passes stored before and for passes without
-- compute work. Applied after 0003_variants in one transaction, which then
-- sets PRAGMA user_version = 4. Never edit a released migration.
ALTER TABLE passes ADD COLUMN compute_invocations REAL;
ALTER TABLE passes ADD COLUMN compute_invocations_statistic REAL;
