-- Stability sweeps (docs/result-schema.md, "Sweep results") and each run's
-- counter headroom. Applied after 0001_initial in one transaction, which then
-- sets PRAGMA user_version = 2. Never edit a released migration.

-- One sweep result of a capture job whose spec was a sweep. The whole result
-- is kept (its points, plots and sweep-specific fields differ per sweep); the
-- columns beside it are what listing and filtering need without parsing it.
-- fails_at is NULL when no point reaches the threshold.
CREATE TABLE sweeps (
  id          INTEGER PRIMARY KEY,
  job_id      INTEGER NOT NULL REFERENCES jobs (id) ON DELETE CASCADE,
  device_id   INTEGER NOT NULL REFERENCES devices (id),
  name        TEXT NOT NULL,
  parameters  TEXT NOT NULL CHECK (json_valid(parameters)),
  threshold   TEXT NOT NULL CHECK (json_valid(threshold)),
  fails_at    TEXT CHECK (fails_at IS NULL OR json_valid(fails_at)),
  point_count INTEGER NOT NULL CHECK (point_count >= 0),
  result      TEXT NOT NULL CHECK (json_valid(result)),
  created_at  TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now'))
);
-- As for runs: filters end in id, so "WHERE <filter> AND id < cursor ORDER BY
-- id DESC" walks one index (the primary key serves the unfiltered list).
CREATE INDEX sweeps_by_name    ON sweeps (name, id);
CREATE INDEX sweeps_by_device  ON sweeps (device_id, id);
CREATE INDEX sweeps_by_job     ON sweeps (job_id, id);
CREATE INDEX sweeps_by_created ON sweeps (created_at, id);

-- The run's "counter_headroom" object (docs/result-schema.md); NULL for runs
-- stored before this migration and for results without one.
ALTER TABLE runs ADD COLUMN counter_headroom TEXT
  CHECK (counter_headroom IS NULL OR json_valid(counter_headroom));
